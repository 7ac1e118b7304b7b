#!/usr/bin/env bash
# A board image (firmware/boards/BOARD) built, or flashed and run with its probe-rs runner,
# with the pinned cross toolchain (installed on first use).
#   scripts/cross/board.sh BOARD build   the ELF: firmware/boards/target/elf/BOARD-trn-controller
#   scripts/cross/board.sh BOARD run     cargo run --release: probe-rs flashes it and prints its defmt log
# BOARD: stm32h743 (f32 tables) or stm32g474 (compact). Bit rates: TRN_CAN_BITRATE,
# TRN_CAN_DATA_BITRATE in the environment (firmware/README.md).
set -euo pipefail
source "$(dirname "$0")/env.sh"
board=${1:?BOARD: stm32h743 or stm32g474}
action=${2:-build}
[ -d "$root/firmware/boards/$board/src/bin" ] || { echo "board.sh: no board image $board in firmware/boards" >&2; exit 2; }
bash "$root/scripts/cross/install-toolchain.sh" >/dev/null
case $action in
    build) build_board "$board" ;;
    run)
        command -v probe-rs >/dev/null || { echo "board.sh: probe-rs is not installed (its runner flashes the board)" >&2; exit 1; }
        # the image measured by budget.sh, bytes and all: built through the same fixed path
        # (whose lock other checkouts' cross builds wait for while the board runs)
        with_fixed_src cargo_at "firmware/boards/$board" firmware/boards/target thumbv7em-none-eabihf \
            run --release --bin trn-controller
        ;;
    *) echo "board.sh: ACTION is build or run" >&2; exit 2 ;;
esac
