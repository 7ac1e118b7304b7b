#!/usr/bin/env bash
# Processor-in-the-loop: the simulator trains the firmware (thumbv7em, in QEMU mps2-an386,
# CAN frames as SLCAN over UART0) for N trials, and the same run with the host build of the
# controller on the in-process bus; the learning curves must match within f32 tolerance
# (the largest difference is printed; bit-identical is what is expected: the same Rust code,
# IEEE-754 single precision on both, software libm on both). The firmware takes its run
# parameters from the bus (`SessionConfig`), so one firmware image runs every case:
# seed 1 project preset on CAN 2.0, seed 100 paper preset on CAN 2.0, seed 101 project
# preset on CAN FD; then the conformance suite against the firmware; then tables written in
# and read out through the firmware's store, in the f32 build and in the compact build; then
# the watchdog resetting a firmware that stopped feeding it. The checks run in two lanes at
# once (see the end), each lane's output printed when both have ended.
#   scripts/cross/pil.sh [TRIALS]      scripts/cross/pil.sh --build-only
set -euo pipefail
source "$(dirname "$0")/env.sh"
bash "$root/scripts/cross/install-toolchain.sh" >/dev/null
build_firmware pil thumbv7em-none-eabihf pil >/dev/null
[ "${1:-}" = "--build-only" ] && exit 0
trials="${1:-30}"
out="$root/out/pil"
mkdir -p "$out"
cd "$root"
cargo build --quiet --release -p trn-sim --bin trn
# every image the checks run, built before they start (the two lanes below share cargo's lock)
compact_elf=$(build_firmware pil-compact thumbv7em-none-eabihf pil,compact --no-default-features)
watchdog_elf=$(build_firmware pil-watchdog-test thumbv7em-none-eabihf pil,watchdog-test)
# the three cases: the firmware's learning curves against the host build's
curves_check() {
    local status=0 case seed preset fd name args start pil_s stack
    for case in "1 project" "100 paper" "101 project --fd"; do
        read -r seed preset fd <<< "$case"
        name="seed$seed-$preset${fd:+-fd}"
        args=(train --seed "$seed" --preset "$preset" ${fd:+"$fd"} --trials "$trials" --eval-targets 5 --grasps 3 --quiet)
        start=$SECONDS
        # (a function run under `||` does not stop at a failed command: each run says so itself,
        # and no report of an earlier run is left to be compared)
        rm -f "$out/$name-firmware.json" "$out/$name-host.json"
        TRN_QEMU_ARM="$QEMU_ARM" ./target/release/trn "${args[@]}" --bus slcan:qemu --report "$out/$name-firmware.json" > "$out/$name-firmware.txt" ||
            { echo "pil $name: FAIL: the run on the firmware" >&2; status=1; continue; }
        pil_s=$((SECONDS - start))
        ./target/release/trn "${args[@]}" --bus inproc --report "$out/$name-host.json" > "$out/$name-host.txt" ||
            { echo "pil $name: FAIL: the run on the host build" >&2; status=1; continue; }
        # the firmware prints its mark at every session's end: the largest
        stack=$(sed -n 's/^trn-firmware pil: stack high-water mark: \([0-9]*\) bytes/\1/p' "$out/$name-firmware.txt" | sort -n | tail -n 1)
        echo "pil $name: firmware stack high-water mark ${stack:-unknown} bytes (limit 8192)"
        [ -n "$stack" ] && [ "$stack" -le 8192 ] || { echo "pil $name: FAIL: stack high-water mark" >&2; status=1; }
        python3 - "$out/$name-firmware.json" "$out/$name-host.json" "$trials" "$pil_s" "$name" <<'PY' || status=1
import json, sys
a, b = json.load(open(sys.argv[1])), json.load(open(sys.argv[2]))
worst, ok = 0.0, True
for key in ["stage1_error_px", "stage2_error_px", "combined_error_px", "fine_moves", "fine_moves_stage2"]:
    va, vb = a[key], b[key]
    if len(va) != len(vb) or not va:
        print(f"FAIL {key}: {len(va)} vs {len(vb)} trials"); ok = False; continue
    d = max(abs(x - y) for x, y in zip(va, vb))
    worst = max(worst, d)
    # f32 tolerance: a relative 1e-5 of the error, or the same fine-move count
    tol = 0 if key.startswith("fine_moves") else 1e-5 * max(1.0, max(abs(x) for x in vb))
    if d > tol:
        print(f"FAIL {key}: largest difference {d} > {tol}"); ok = False
same = all(a[k] == b[k] for k in ["stage1_error_px", "stage2_error_px", "combined_error_px"])
print(f"pil {sys.argv[5]}: {sys.argv[3]} trials per network on the firmware in QEMU ({sys.argv[4]} s) against the host build: "
      f"largest curve difference {worst} ({'bit-identical' if same else 'within f32 tolerance'}); "
      f"final error {a['final_error_px']:.4f} px firmware, {b['final_error_px']:.4f} px host")
sys.exit(0 if ok else 1)
PY
    done
    return $status
}
# the conformance suite against the firmware (protocol/SPEC.md 3, 3.2), over the same SLCAN link
conformance_check() {
    local status=0
    TRN_QEMU_ARM="$QEMU_ARM" ./target/release/trn conformance --bus slcan:qemu --seed 100 > "$out/conformance.txt" || status=1
    echo "pil conformance (firmware in QEMU): $(tail -n 1 "$out/conformance.txt")"
    # the Broyden servo baseline on the same firmware image (SessionConfig law 1)
    TRN_QEMU_ARM="$QEMU_ARM" ./target/release/trn conformance --bus slcan:qemu --seed 101 --controller broyden > "$out/conformance-broyden.txt" || status=1
    echo "pil conformance, Broyden servo (firmware in QEMU): $(tail -n 1 "$out/conformance-broyden.txt")"
    grep -A 1 "^  FAIL  " "$out/conformance-broyden.txt" || true
    grep -A 1 "^  FAIL  " "$out/conformance.txt" || true
    return $status
}
# the learned tables through the firmware's store (protocol/SPEC.md 3.4, 3.5): a checkpoint
# of a short host training written into the firmware over the link (staged in its emulated
# flash, checked there, applied from there) and read back out: bit-identical; then the
# firmware evaluates it, as the host build does (the same report, bit for bit)
tables_check() {
    ./target/release/trn train --bus inproc --seed 5 --trials "$trials" --eval-targets 2 --grasps 0 --snapshot-every 0 --quiet \
        --checkpoint-out "$out/tables.ckpt" > /dev/null || return 1
    local start=$SECONDS
    TRN_QEMU_ARM="$QEMU_ARM" ./target/release/trn eval --bus slcan:qemu --eval-targets 0 --grasps 0 --quiet \
        --checkpoint-in "$out/tables.ckpt" --checkpoint-out "$out/tables-back.ckpt" > "$out/tables.txt" || return 1
    cmp "$out/tables.ckpt" "$out/tables-back.ckpt" || { echo "pil tables: FAIL: read back differs"; return 1; }
    local rt_s=$((SECONDS - start))
    TRN_QEMU_ARM="$QEMU_ARM" ./target/release/trn eval --bus slcan:qemu --seed 7 --eval-targets 5 --grasps 0 --quiet \
        --checkpoint-in "$out/tables.ckpt" --report "$out/tables-eval-firmware.json" > "$out/tables-eval.txt" || return 1
    ./target/release/trn eval --bus inproc --seed 7 --eval-targets 5 --grasps 0 --quiet \
        --checkpoint-in "$out/tables.ckpt" --report "$out/tables-eval-host.json" > /dev/null || return 1
    python3 - "$out/tables-eval-firmware.json" "$out/tables-eval-host.json" <<'PY' || return 1
import json, sys
a, b = json.load(open(sys.argv[1])), json.load(open(sys.argv[2]))
keys = ["final_error_px", "final_error_true_px", "fine_moves_mean", "sim_time_per_target_s"]
bad = [k for k in keys if a.get(k) != b.get(k)]
if bad or not a.get("final_error_px"):
    print(f"pil tables: FAIL: the firmware's evaluation of the loaded tables differs from the host's in {bad}")
    sys.exit(1)
PY
    echo "pil tables: $(wc -c < "$out/tables.ckpt") bytes written into the firmware's flash store and read back bit-identical (${rt_s} s); evaluated on the firmware as on the host build, bit-identical"
}
# the compact build keeps compact images (checkpoint format 3, as the STM32G474 board): the
# same f32 checkpoint written in is refused as too large for its slots, written again
# compact (trn says so), applied, and read back out as f32: each value the original rounded
# to its table's step (weights 2^-5, pressures 2^-13, Jacobians 2^-18)
compact_tables_check() {
    local elf=$compact_elf start=$SECONDS
    TRN_QEMU_ARM="$QEMU_ARM" TRN_FIRMWARE="$elf" ./target/release/trn eval --bus slcan:qemu --eval-targets 0 --grasps 0 \
        --checkpoint-in "$out/tables.ckpt" --checkpoint-out "$out/tables-compact-back.ckpt" > "$out/tables-compact.txt" 2>&1 || return 1
    grep -q "compact tables only" "$out/tables-compact.txt" || { echo "pil compact tables: FAIL: no notice of the compact write"; return 1; }
    python3 - "$out/tables.ckpt" "$out/tables-compact-back.ckpt" <<'PY' || return 1
import struct, sys
a, b = open(sys.argv[1], "rb").read(), open(sys.argv[2], "rb").read()
n = 56_800
va = struct.unpack(f"<{n}f", a[-4 - 4 * n:-4])
vb = struct.unpack(f"<{n}f", b[-4 - 4 * n:-4])
tables = [(8_000, 5), (5_000, 13), (40_000, 18), (800, 5), (600, 13), (2_400, 18)]
steps = [bits for count, bits in tables for _ in range(count)]
def rounded(x, bits):
    q = max(-32768, min(32767, round(x * 2**bits)))
    return q / 2**bits
bad = [i for i in range(n) if vb[i] != rounded(va[i], steps[i])]
if bad or len(b) != len(a):
    print(f"pil compact tables: FAIL: {len(bad)} values are not the originals rounded to their steps (first {bad[:3]})")
    sys.exit(1)
PY
    echo "pil compact tables: the $(wc -c < "$out/tables.ckpt")-byte checkpoint written into the compact firmware's store as a compact image and read back: every value the original rounded to its step ($((SECONDS - start)) s)"
}
# the watchdog (the QEMU machine's CMSDK watchdog, fed once a turn by the node's loop in
# every run above; each run's firmware printed its reset cause at boot and announced it on
# the bus): an image that stops feeding it after a power-on is reset by it, and the next boot
# reads the cause the watchdog's NMI recorded
watchdog_check() {
    local elf=$watchdog_elf start=$SECONDS
    timeout 300 "$QEMU_ARM" -machine mps2-an386 -cpu cortex-m4 -nographic \
        -semihosting-config enable=on,target=native -icount shift=0 -kernel "$elf" > "$out/watchdog.txt" 2>&1 || true
    grep -q "reset cause 1 " "$out/watchdog.txt" && grep -q "reset cause 3 " "$out/watchdog.txt" &&
        grep -q "reset by the watchdog" "$out/watchdog.txt" || { cat "$out/watchdog.txt"; return 1; }
    grep -q "reset cause 1 " "$out/seed1-project-firmware.txt" || { echo "pil watchdog: FAIL: the PIL run printed no reset cause"; return 1; }
    echo "pil watchdog: a firmware that stopped feeding it was reset by the watchdog and read the cause its NMI recorded: 3 (watchdog) ($((SECONDS - start)) s)"
}
# Two lanes at once, each one QEMU with the host's side beside it: the curves and the
# watchdog (which reads the first case's output), and the conformance suites and the tables
# (the compact build reads the tables' checkpoint). Nothing is shared between them but the
# images, and each run waits on its firmware with the QEMU profile's patience (replies within
# 20 s of the wall clock), far above what a shared core costs; the conformance suites spend
# most of their time waiting for silences, so the lanes together take about as long as the
# longer one. Each lane's output is printed whole when both have ended.
lane_curves() {
    local status=0
    curves_check || status=1
    watchdog_check || { echo "pil watchdog: FAIL" >&2; status=1; }
    return $status
}
lane_protocol() {
    local status=0
    conformance_check || status=1
    tables_check || { echo "pil tables: FAIL" >&2; status=1; }
    compact_tables_check || { echo "pil compact tables: FAIL" >&2; status=1; }
    return $status
}
status=0
lane_curves > "$out/lane-curves.txt" 2>&1 &
curves=$!
lane_protocol > "$out/lane-protocol.txt" 2>&1 &
protocol=$!
wait "$curves" || status=1
wait "$protocol" || status=1
cat "$out/lane-curves.txt" "$out/lane-protocol.txt"
exit $status
