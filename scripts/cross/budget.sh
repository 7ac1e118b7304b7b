#!/usr/bin/env bash
# Builds the firmware for thumbv7em-none-eabihf, measures its sections, runs its benchmark in
# QEMU (mps2-an386, -icount shift=0) and fails when a budget is exceeded:
#   static RAM (.data + .bss + .uninit) <= 240 KiB, flash (.vector_table + .text + .rodata +
#   .data) <= 128 KiB, stack high-water mark <= 8 KiB, stage-1 learning step <= 150,000
#   executed instructions (the largest of the benchmark's steps; QEMU models no pipeline, so
#   instructions are a proxy for cycles), stage-1 control step (rank + coarse output)
#   <= 60,000 instructions on average (both issue 18). The thumbv6m-none-eabi build (soft float) is reported
#   beside it, its benchmark run on the Cortex-M4 board.
#   The benchmark's per-phase costs (its "phase ...: mean M max X instructions" lines: the
#   distances, the selection, the averages and each update) are repeated in the summary.
#   The compact build (feature `compact`: i16 fixed-point tables, no Broyden servo) is built and
#   run too: its static RAM (.data + .bss + .uninit) <= 128 KiB (131,072 bytes), and with the
#   stack's high-water mark added (the larger of its benchmark's and of its CAN node's in a
#   short session: what a 128 KiB part must hold) at least 2 KiB of it left
#   free, flash <= 256 KiB (parts with 128 KiB of RAM carry at least that, e.g. STM32F411xC);
#   its step costs are reported.
#   The board images (firmware/boards: STM32H743 with the f32 tables, STM32G474 with the compact
#   ones) are built and checked against their part: one line each, `board NAME: RAM N of M B,
#   flash N of M B: ok`. Their RAM is .data + .bss + .uninit plus the stack's high-water mark
#   that QEMU measured here for the same controller build (the larger of the benchmark's and
#   the CAN node's in a short session: QEMU models neither part, so a board image cannot run
#   in it) and the stack guard's bytes (an MPU region at the stack's bottom); M is the
#   RAM region of the board's memory.x checked against the link, and the flash the image may
#   take: the part's, less the store of its learned tables (the H743: its last 512 KiB, the
#   image's FLASH region is 1,536 KiB; the G474: bank 2, the image's FLASH is bank 1's 256 KiB).
# The measured figures also go into three tables: docs/results/budget.md (each figure with its
# budget), budget-phases.md (the stage-1 phases, both builds) and budget-boards.md (the board
# lines), copied into firmware/README.md and docs/performance.md by scripts/readme_sections.py.
# The figures are deterministic (instruction counts under -icount, section sizes of images
# whose source paths are remapped), so the run fails when the tables it makes differ from the
# committed ones, with the difference:
#   bash scripts/cross/budget.sh            measure, check the budgets and the committed tables
#   bash scripts/cross/budget.sh --write    the same, and write the tables into docs/results
set -euo pipefail
write=0
case "${1:-}" in
    --write) write=1 ;;
    "") ;;
    *) echo "usage: budget.sh [--write]" >&2; exit 2 ;;
esac
source "$(dirname "$0")/env.sh"
bash "$root/scripts/cross/install-toolchain.sh" >/dev/null
cd "$root/firmware"
elf=$(build_firmware bench thumbv7em-none-eabihf)
sections() {
    arm-none-eabi-size -A "$1" | awk '
        $1==".data"{d=$2} $1==".bss"{b=$2} $1==".uninit"{u=$2}
        $1==".vector_table"{v=$2} $1==".text"{t=$2} $1==".rodata"{r=$2}
        END{print d+b+u, v+t+r+d}'
}
read -r ram flash < <(sections "$elf")
# the full firmware (the controller node, SLCAN over UART) is what has to fit
elf_pil=$(build_firmware pil thumbv7em-none-eabihf pil)
read -r ram_pil flash_pil < <(sections "$elf_pil")
rc=0
out=$(timeout 120 "$QEMU_ARM" -machine mps2-an386 -cpu cortex-m4 -nographic \
    -semihosting-config enable=on,target=native -icount shift=0 -kernel "$elf" 2>&1) || rc=$?
echo "$out"
[ $rc -eq 0 ] || { echo "budget: FAIL: the benchmark in QEMU exited with $rc (124: timeout)" >&2; exit 1; }
control=$(echo "$out" | sed -n 's/^stage1 control step.*mean \([0-9]*\) max \([0-9]*\).*/\1 \2/p')
learn=$(echo "$out" | sed -n 's/^stage1 learning step.*mean \([0-9]*\) max \([0-9]*\).*/\1 \2/p')
stack=$(echo "$out" | sed -n 's/^stack high-water mark: \([0-9]*\) bytes/\1/p')
phases=$(echo "$out" | grep -c '^phase ' || true)
[ -n "$control" ] && [ -n "$learn" ] && [ -n "$stack" ] && [ "$phases" -gt 0 ] || { echo "budget: FAIL: the benchmark printed no figures" >&2; exit 1; }
read -r learn_mean learn_max <<< "$learn"
read -r control_mean control_max <<< "$control"

# the compact build: i16 tables (benchmark and the firmware with the CAN node)
elf_c=$(build_firmware compact-bench thumbv7em-none-eabihf compact --no-default-features)
read -r ram_c flash_c < <(sections "$elf_c")
elf_pc=$(build_firmware pil-compact thumbv7em-none-eabihf pil,compact --no-default-features)
read -r ram_pc flash_pc < <(sections "$elf_pc")
rc=0
out_c=$(timeout 300 "$QEMU_ARM" -machine mps2-an386 -cpu cortex-m4 -nographic \
    -semihosting-config enable=on,target=native -icount shift=0 -kernel "$elf_c" 2>&1) || rc=$?
[ $rc -eq 0 ] || { echo "$out_c"; echo "budget: FAIL: the compact benchmark in QEMU exited with $rc" >&2; exit 1; }
control_c=$(echo "$out_c" | sed -n 's/^stage1 control step.*mean \([0-9]*\) max \([0-9]*\).*/\1 \/ \2/p')
learn_c=$(echo "$out_c" | sed -n 's/^stage1 learning step.*mean \([0-9]*\) max \([0-9]*\).*/\1 \/ \2/p')
stack_c=$(echo "$out_c" | sed -n 's/^stack high-water mark: \([0-9]*\) bytes/\1/p')
finite_c=$(echo "$out_c" | sed -n 's/^tables finite after learning: \(.*\)/\1/p')
[ -n "$control_c" ] && [ -n "$learn_c" ] && [ -n "$stack_c" ] && [ "$finite_c" = true ] || { echo "$out_c"; echo "budget: FAIL: the compact benchmark printed no figures" >&2; exit 1; }

# thumbv6m (Cortex-M0, no FPU, soft float): built, measured, and its benchmark run on QEMU's
# Cortex-M4 board (QEMU's M0 boards have 16 KiB of RAM; ARMv6-M code is a subset of
# ARMv7-M, so the counts are the soft-float build's instructions; an M0's cycles per
# instruction differ)
elf6=$(build_firmware thumbv6m-bench thumbv6m-none-eabi)
read -r ram6 flash6 < <(sections "$elf6")
rc=0
out6=$(timeout 300 "$QEMU_ARM" -machine mps2-an386 -cpu cortex-m4 -nographic \
    -semihosting-config enable=on,target=native -icount shift=0 \
    -kernel "$elf6" 2>&1) || rc=$?
[ $rc -eq 0 ] || { echo "$out6"; echo "budget: FAIL: the thumbv6m benchmark in QEMU exited with $rc" >&2; exit 1; }
control6=$(echo "$out6" | sed -n 's/^stage1 control step.*mean \([0-9]*\) max \([0-9]*\).*/\1 \/ \2/p')
learn6=$(echo "$out6" | sed -n 's/^stage1 learning step.*mean \([0-9]*\) max \([0-9]*\).*/\1 \/ \2/p')
[ -n "$control6" ] && [ -n "$learn6" ] || { echo "$out6"; echo "budget: FAIL: the thumbv6m benchmark printed no figures" >&2; exit 1; }

# The CAN node's own stack high-water mark: the firmware with the node in a short session
# (seed 1, 5 trials per network, a grasp) over SLCAN in QEMU, driven by the simulator (built
# with the host's toolchain, as the test suite's other steps build it). The code path the
# board images run; the benchmark's, the controller's deepest, is the other candidate: the
# compact check and the boards' RAM take the larger.
( cd "$root" && env -u RUSTC -u RUSTC_BOOTSTRAP cargo build --quiet --release -p trn-sim --bin trn ) >&2
node_stack() { # ELF
    TRN_QEMU_ARM="$QEMU_ARM" TRN_FIRMWARE="$1" timeout 600 "$root/target/release/trn" train --seed 1 --trials 5 \
        --eval-targets 2 --grasps 1 --quiet --bus slcan:qemu |
        sed -n 's/^trn-firmware pil: stack high-water mark: \([0-9]*\) bytes/\1/p'
}
node_stack_f=$(node_stack "$elf_pil")
node_stack_c=$(node_stack "$elf_pc")
[ -n "$node_stack_f" ] && [ -n "$node_stack_c" ] || { echo "budget: FAIL: no stack figure from the CAN node in QEMU" >&2; exit 1; }
larger() { if [ "$1" -ge "$2" ]; then echo "$1"; else echo "$2"; fi; }
deepest_f=$(larger "$stack" "$node_stack_f")
deepest_c=$(larger "$stack_c" "$node_stack_c")

# n "1234567 / 89012" -> "1,234,567 / 89,012": every number in the text with thousands commas
n() { echo "$1" | sed ':a;s/\B[0-9]\{3\}\>/,&/g;ta'; }
# the budgets (bytes, instructions), checked below and written into docs/results/budget.md
ram_limit=245760 flash_limit=131072 stack_limit=8192 learn_limit=150000 control_limit=60000
compact_ram_limit=131072 compact_free_min=2048 compact_flash_limit=262144
fail=0
check() { # name value limit unit
    if [ "$2" -le "$3" ]; then verdict=ok; else verdict=FAIL; fail=1; fi
    printf '%-58s %10s %10s %-12s %s\n' "$1" "$2" "$3" "$4" "$verdict"
}
echo
printf '%-58s %10s %10s %-12s %s\n' "budget (thumbv7em-none-eabihf, firmware/)" "measured" "limit" "unit" ""
check "static RAM, firmware with the CAN node (.data+.bss)" "$ram_pil" $ram_limit bytes
check "flash, firmware with the CAN node" "$flash_pil" $flash_limit bytes
check "static RAM, benchmark firmware (.data+.bss)" "$ram" $ram_limit bytes
check "flash, benchmark firmware" "$flash" $flash_limit bytes
check "stack high-water mark" "$stack" $stack_limit bytes
check "stack high-water mark, CAN node in a short session" "$node_stack_f" $stack_limit bytes
check "stage-1 learning step, max (coarse + 2 fine + updates)" "$learn_max" $learn_limit instructions
printf '%-58s %10s\n' "stage-1 learning step, mean" "$learn_mean"
check "stage-1 control step, mean" "$control_mean" $control_limit instructions
printf '%-58s %10s\n' "stage-1 control step (rank + coarse), max" "$control_max"
printf '%-58s %10s\n' "thumbv6m-none-eabi: static RAM / flash (bytes)" "$ram6 / $flash6"
printf '%-58s %10s\n' "thumbv6m (soft float): control step, mean / max" "$control6"
printf '%-58s %10s\n' "thumbv6m (soft float): learning step, mean / max" "$learn6"
echo
printf '%-58s %10s %10s %-12s %s\n' "compact build (i16 tables, --features compact)" "measured" "limit" "unit" ""
check "compact: static RAM, firmware with the CAN node" "$ram_pc" $compact_ram_limit bytes
printf '%-58s %10s\n' "compact: stack high-water mark, benchmark / CAN node" "$stack_c / $node_stack_c"
check "compact: static RAM + stack high-water mark (2 KiB free)" "$((ram_pc + deepest_c))" $((compact_ram_limit - compact_free_min)) bytes
printf '%-58s %10s\n' "compact: RAM left free of 131,072 B with the stack" "$((compact_ram_limit - ram_pc - deepest_c))"
check "compact: flash, firmware with the CAN node" "$flash_pc" $compact_flash_limit bytes
printf '%-58s %10s\n' "compact: static RAM / flash, benchmark firmware" "$ram_c / $flash_c"
printf '%-58s %10s\n' "compact: stage-1 control step, mean / max" "$control_c"
printf '%-58s %10s\n' "compact: stage-1 learning step, mean / max" "$learn_c"
# the board images: NAME, the controller build whose stack it has, the part's RAM region and
# the flash the image may take (the part's less its tables' store)
echo
echo "board images (firmware/boards): RAM = static (.data+.bss+.uninit) + the larger stack high-water mark QEMU measured above for the same controller build"
symbol() { echo $((16#$(arm-none-eabi-nm "$1" | awk -v s="$2" '$3==s{print $1}'))); }
board_rows=""
for board in "stm32h743 f32 524288 1572864" "stm32g474 compact 131072 262144"; do
    read -r name build ram_size flash_size <<< "$board"
    if ! board_elf=$(build_board "$name"); then
        echo "board $name: FAIL: the image did not build" >&2
        fail=1
        continue
    fi
    read -r ram_b flash_b < <(sections "$board_elf")
    stack_b=$deepest_f
    [ "$build" = compact ] && stack_b=$deepest_c
    region=$(($(symbol "$board_elf" _stack_start) - $(symbol "$board_elf" __sdata)))
    if [ "$region" -ne "$ram_size" ]; then
        echo "board $name: FAIL: the link's RAM region is $region B, not the part's $ram_size B" >&2
        fail=1
        continue
    fi
    # the stack guard (an MPU region of 32 B at the stack's bottom, aligned to 32 B) is RAM
    # the stack cannot use
    stack_end=$(symbol "$board_elf" _stack_end)
    guard_b=$(( (stack_end + 31) / 32 * 32 + 32 - stack_end ))
    used=$((ram_b + stack_b + guard_b))
    line="board $name: RAM $used of $ram_size B (stack guard $guard_b B), flash $flash_b of $flash_size B"
    board_rows+="| $name | $(n "$ram_b") + $(n "$stack_b") + $(n "$guard_b") = **$(n "$used")** of $(n "$ram_size") | **$(n "$flash_b")** of $(n "$flash_size") |"$'\n'
    if [ $used -le "$ram_size" ] && [ "$flash_b" -le "$flash_size" ]; then
        echo "$line: ok"
    else
        echo "$line: FAIL (over: RAM by $((used - ram_size)) B, flash by $((flash_b - flash_size)) B; a negative figure is room left)"
        fail=1
    fi
done
echo
broyden=$(echo "$out" | sed -n 's/^phase broyden servo step.*: mean \([0-9]*\) max \([0-9]*\) instructions$/\1 \/ \2/p')
printf '%-58s %10s\n' "Broyden servo baseline: stage-1 servo step, mean / max" "${broyden:-missing}"
[ -n "$broyden" ] || { echo "budget: FAIL: no Broyden figures" >&2; fail=1; }
echo
printf '%-90s %8s %8s %8s %8s\n' "stage-1 phase (instructions)" "mean" "max" "compact" "max"
phase_lines() { sed -n 's/^phase \(.*\): mean \([0-9]*\) max \([0-9]*\) instructions$/\1\t\2\t\3/p'; }
phase_rows=$(paste <(echo "$out" | phase_lines) <(echo "$out_c" | phase_lines | cut -f2,3))
echo "$phase_rows" | while IFS=$'\t' read -r name mean max cmean cmax; do
    printf '%-90s %8s %8s %8s %8s\n' "$name" "$mean" "$max" "${cmean:--}" "${cmax:--}"
done

# the tables (docs/results/budget*.md)
tables=$(mktemp -d)
trap 'rm -rf "$tables"' EXIT
{
    echo "| | measured | budget |"
    echo "|---|---|---|"
    echo "| static RAM, firmware with the CAN node (.data + .bss + .uninit) | **$(n "$ram_pil")** B | $(n "$ram_limit") B ($((ram_limit / 1024)) KiB) |"
    echo "| static RAM, benchmark firmware | $(n "$ram") B | $(n "$ram_limit") B |"
    echo "| flash, firmware with the CAN node / benchmark firmware (.vector_table + .text + .rodata + .data) | **$(n "$flash_pil")** / $(n "$flash") B | $(n "$flash_limit") B ($((flash_limit / 1024)) KiB) |"
    echo "| stack high-water mark, benchmark / CAN node in a short session | $(n "$stack") / $(n "$node_stack_f") B | $(n "$stack_limit") B |"
    echo "| stage-1 learning step (coarse + 2 fine moves, all updates), max / mean | **$(n "$learn_max")** / $(n "$learn_mean") instructions | max $(n "$learn_limit") |"
    echo "| stage-1 control step (rank + coarse output), mean / max | **$(n "$control_mean")** / $(n "$control_max") instructions | mean $(n "$control_limit") |"
    echo "| the Broyden servo baseline: stage-1 servo step (Broyden update + damped least squares), mean / max | $(n "$broyden") instructions | reported |"
    echo "| thumbv6m-none-eabi (no FPU, soft float): static RAM / flash, benchmark firmware | $(n "$ram6") / $(n "$flash6") B | reported |"
    echo "| thumbv6m-none-eabi, its benchmark run on the Cortex-M4 board: control step mean / max; learning step mean / max | $(n "$control6"); $(n "$learn6") instructions | reported |"
    echo "| **compact build** (i16 tables, no Broyden servo): static RAM, firmware with the CAN node | **$(n "$ram_pc")** B | $(n "$compact_ram_limit") B ($((compact_ram_limit / 1024)) KiB) |"
    echo "| compact build: stack high-water mark, benchmark / CAN node in a short session | $(n "$stack_c") / $(n "$node_stack_c") B | |"
    echo "| compact build: static RAM with the larger stack high-water mark; left free of $((compact_ram_limit / 1024)) KiB | $(n "$((ram_pc + deepest_c))") B; **$(n "$((compact_ram_limit - ram_pc - deepest_c))") B free** | at least $(n "$compact_free_min") B free |"
    echo "| compact build: flash, firmware with the CAN node / benchmark firmware | **$(n "$flash_pc")** / $(n "$flash_c") B | $(n "$compact_flash_limit") B ($((compact_flash_limit / 1024)) KiB) |"
    echo "| compact build: static RAM, benchmark firmware | $(n "$ram_c") B | reported |"
    echo "| compact build: stage-1 control step, mean / max; learning step, mean / max | $(n "$control_c"); $(n "$learn_c") instructions | reported |"
} > "$tables/budget.md"
{
    echo "| stage-1 phase (instructions) | mean / max | compact build: mean / max |"
    echo "|---|---|---|"
    echo "$phase_rows" | while IFS=$'\t' read -r name mean max cmean cmax; do
        c="–"
        [ -n "$cmean" ] && c="$(n "$cmean") / $(n "$cmax")"
        echo "| $name | $(n "$mean") / $(n "$max") | $c |"
    done
} > "$tables/budget-phases.md"
{
    echo "| board image | RAM: static + stack high-water mark + stack guard, of the part's (B) | flash, of what the image may take (B) |"
    echo "|---|---|---|"
    printf '%s' "$board_rows"
} > "$tables/budget-boards.md"
results="$root/docs/results"
if [ $write -eq 1 ]; then
    cp "$tables"/budget*.md "$results/"
    echo "budget: wrote docs/results/budget.md, budget-phases.md and budget-boards.md"
else
    for t in budget.md budget-phases.md budget-boards.md; do
        if ! diff -u "$results/$t" "$tables/$t"; then
            echo "budget: FAIL: docs/results/$t differs from this run's figures (above); bash scripts/cross/budget.sh --write, then python3 scripts/readme_sections.py" >&2
            fail=1
        fi
    done
fi
[ $fail -eq 0 ] || { echo "budget: FAIL" >&2; exit 1; }
echo "budget: all within limits"
