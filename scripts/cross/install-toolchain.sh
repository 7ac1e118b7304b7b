#!/usr/bin/env bash
# Installs what the Cortex-M builds and runs need (idempotent): Debian's Rust toolchain with
# the core sources and clippy (rustup here has only the x86_64 std), pinned to one version,
# binutils for arm-none-eabi (the linker and `size`), and qemu-system-arm, unpacked from its
# .deb into .vm/qemu-arm so that installing it cannot disturb the machine's other QEMU
# packages (apt-installing it may remove a newer qemu-utils).
#
# The cross toolchain is pinned: Debian's rustc-web/cargo-web/rust-web-src/rust-web-clippy
# $CROSS_RUST (1.96.0, the security suite's; the board images' embassy-stm32 0.6 needs >= 1.88).
# Another version installed is replaced by it; the script fails if apt cannot provide it.
# The host's workspace is built by rustup's toolchain, not this one (Cargo.toml rust-version).
set -euo pipefail
root="$(cd "$(dirname "$0")/../.." && pwd)"
export DEBIAN_FRONTEND=noninteractive
CROSS_RUST=1.96.0

wait_dpkg() { # another apt/dpkg may hold the lock
    while fuser /var/lib/dpkg/lock-frontend /var/lib/dpkg/lock >/dev/null 2>&1; do sleep 3; done
}
updated=0
apt_update() { # once per run
    if [ $updated -eq 0 ]; then
        wait_dpkg
        apt-get update -qq
        updated=1
    fi
}
apt_install() {
    apt_update
    wait_dpkg
    apt-get install -y -qq --no-install-recommends "$@" >/dev/null
}

need=()
rust_version() { "$1" --version 2>/dev/null | cut -d' ' -f2; }
package_version() { dpkg-query -W -f='${Version}' "$1" 2>/dev/null | cut -d+ -f1; }
pinned=1
for package in rustc-web cargo-web rust-web-src rust-web-clippy; do
    [ "$(package_version "$package")" = "$CROSS_RUST" ] || pinned=0
done
if [ $pinned -eq 0 ] || [ "$(rust_version /usr/bin/rustc)" != "$CROSS_RUST" ]; then
    need+=("rustc-web=$CROSS_RUST*" "cargo-web=$CROSS_RUST*" "rust-web-src=$CROSS_RUST*"
        "rust-web-clippy=$CROSS_RUST*" "libstd-rust-web-dev=$CROSS_RUST*")
fi
command -v arm-none-eabi-ld >/dev/null || need+=(binutils-arm-none-eabi)
command -v fuser >/dev/null || need+=(psmisc)
dpkg -s qemu-system-common >/dev/null 2>&1 || need+=(qemu-system-common qemu-system-data)
if [ ${#need[@]} -gt 0 ]; then
    echo "cross: installing ${need[*]}"
    apt_install "${need[@]}"
fi

cache="$root/.vm/qemu-arm"
qemu="$cache/root/usr/bin/qemu-system-arm"
if [ ! -x "$qemu" ]; then
    echo "cross: unpacking qemu-system-arm into $cache"
    mkdir -p "$cache"
    cd "$cache"
    rm -f qemu-system-arm_*.deb
    # the version of the installed qemu-system-common (its data and modules), else the candidate
    ver=$(dpkg-query -W -f='${Version}' qemu-system-common 2>/dev/null || true)
    get() { apt-get download -qq "qemu-system-arm${ver:+=$ver}" 2>/dev/null || apt-get download -qq qemu-system-arm; }
    get || { apt_update; get; }
    dpkg -x qemu-system-arm_*.deb root
    # its shared libraries come with qemu-system-common's dependencies; install any missing
    missing=$(ldd "$qemu" | awk '/not found/{print $1}')
    if [ -n "$missing" ]; then
        echo "cross: qemu-system-arm misses" $missing": installing its dependencies"
        # shellcheck disable=SC2046
        apt_install $(dpkg -I qemu-system-arm_*.deb | sed -n 's/^ Depends: //p' | tr ',' '\n' \
            | sed 's/(.*//; s/|.*//; s/ //g' | grep -v '^qemu-system' | grep -v '^$')
    fi
    cd - >/dev/null
fi
"$qemu" -machine help | grep -q mps2-an386 || { echo "cross: $qemu has no mps2-an386 board" >&2; exit 1; }
[ "$(rust_version /usr/bin/rustc)" = "$CROSS_RUST" ] ||
    { echo "cross: /usr/bin/rustc is $(rust_version /usr/bin/rustc), not the pinned $CROSS_RUST" >&2; exit 1; }
echo "cross: /usr/bin/rustc $(rust_version /usr/bin/rustc), $(arm-none-eabi-ld --version | head -1), $("$qemu" --version | head -1)"
