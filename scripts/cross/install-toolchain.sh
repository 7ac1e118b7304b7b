#!/usr/bin/env bash
# Installs what the Cortex-M builds and runs need (idempotent): Debian's Rust toolchain with
# the core sources (rustup here has only the x86_64 std), binutils for arm-none-eabi (the
# linker and `size`), and qemu-system-arm, unpacked from its .deb into .vm/qemu-arm so that
# installing it cannot disturb the machine's other QEMU packages.
set -euo pipefail
root="$(cd "$(dirname "$0")/../.." && pwd)"
need=()
[ -x /usr/bin/rustc ] && [ -x /usr/bin/cargo ] || need+=(rustc-web cargo-web)
[ -d /usr/lib/rustlib/src/rust/library/core ] || need+=(rust-web-src)
command -v arm-none-eabi-ld >/dev/null || need+=(binutils-arm-none-eabi)
dpkg -s qemu-system-common >/dev/null 2>&1 || need+=(qemu-system-common qemu-system-data)
if [ ${#need[@]} -gt 0 ]; then
    echo "cross: installing ${need[*]}"
    apt-get update -qq
    DEBIAN_FRONTEND=noninteractive apt-get install -y -qq "${need[@]}" >/dev/null
fi
qemu="$root/.vm/qemu-arm/root/usr/bin/qemu-system-arm"
if [ ! -x "$qemu" ]; then
    echo "cross: unpacking qemu-system-arm"
    mkdir -p "$root/.vm/qemu-arm"
    (cd "$root/.vm/qemu-arm" && rm -f qemu-system-arm_*.deb && apt-get download qemu-system-arm 2>/dev/null \
        && dpkg -x qemu-system-arm_*.deb root)
    # its shared libraries come with qemu-system-common's dependencies; fetch any missing
    missing=$(ldd "$qemu" | awk '/not found/{print $1}')
    if [ -n "$missing" ]; then
        echo "cross: qemu-system-arm misses $missing: installing its dependencies"
        apt-get update -qq
        # shellcheck disable=SC2046
        DEBIAN_FRONTEND=noninteractive apt-get install -y -qq $(dpkg -I "$root"/.vm/qemu-arm/qemu-system-arm_*.deb \
            | sed -n 's/^ Depends: //p' | tr ',' '\n' | sed 's/(.*//; s/|.*//' | grep -v qemu-system) >/dev/null
    fi
fi
echo "cross: /usr/bin/rustc $(/usr/bin/rustc --version | cut -d' ' -f2), $(arm-none-eabi-ld --version | head -1), $("$qemu" --version | head -1)"
