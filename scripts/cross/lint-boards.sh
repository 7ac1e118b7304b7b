#!/usr/bin/env bash
# Lints the board images (firmware/boards) with the pinned cross toolchain: rustfmt, and
# clippy with -D warnings on each board together with the shared FDCAN node crate (which has
# no chip of its own to be checked alone). Debian's cargo-clippy (rust-web-clippy) is used,
# not rustup's: the crates need the cross toolchain's core for thumbv7em.
set -euo pipefail
source "$(dirname "$0")/env.sh"
bash "$root/scripts/cross/install-toolchain.sh" >/dev/null
cd "$root/firmware/boards"
find . -path ./target -prune -o -name '*.rs' -print0 | xargs -0 rustfmt --check --edition 2021
export PATH="/usr/bin:$PATH"
# the cross toolchain's clippy is 0.1.MINOR for rustc 1.MINOR.x
minor=$(/usr/bin/rustc --version | cut -d' ' -f2 | cut -d. -f2)
version=$($CARGO clippy --version)
[ "$version" = "clippy 0.1.$minor" ] ||
    { echo "lint-boards: $version is not the cross toolchain's clippy (0.1.$minor)" >&2; exit 1; }
for board in stm32h743 stm32g474; do
    (cd "$board" && CARGO_TARGET_DIR="$root/firmware/boards/target" $CARGO clippy --quiet --release \
        -p "trn-board-$board" -p trn-fdcan-node -- -D warnings)
    echo "lint-boards: $board and trn-fdcan-node: rustfmt and clippy clean"
done
