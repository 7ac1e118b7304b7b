# Sourced by the cross scripts: Debian's toolchain for the no_std targets (DEVELOPERS.md).
root="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
export RUSTC=/usr/bin/rustc RUSTC_BOOTSTRAP=1
CARGO=/usr/bin/cargo
QEMU_ARM="$root/.vm/qemu-arm/root/usr/bin/qemu-system-arm"
