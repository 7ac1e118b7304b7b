#!/usr/bin/env bash
# Cross-builds the no_std crates (controller, protocol, node, store) for thumbv7em-none-eabihf
# (Cortex-M4F/M7) and thumbv6m-none-eabi (Cortex-M0, no FPU) with Debian's toolchain.
set -euo pipefail
source "$(dirname "$0")/env.sh"
bash "$root/scripts/cross/install-toolchain.sh" >/dev/null
cd "$root"
for target in thumbv7em-none-eabihf thumbv6m-none-eabi; do
    CARGO_TARGET_DIR="$root/target/cross" $CARGO build --quiet --release -Zbuild-std=core --target $target \
        -p trn-controller -p trn-protocol -p trn-node -p trn-store
    echo "cross: trn-controller, trn-protocol, trn-node, trn-store build for $target"
done
