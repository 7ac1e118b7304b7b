#!/usr/bin/env bash
# Processor-in-the-loop: the simulator trains the firmware (thumbv7em, in QEMU mps2-an386,
# CAN frames as SLCAN over UART0) for N trials, and the same run with the host build of the
# controller on the in-process bus; the learning curves must match within f32 tolerance
# (the largest difference is printed; bit-identical is what is expected: the same Rust code,
# IEEE-754 single precision on both, software libm on both).
#   scripts/cross/pil.sh [TRIALS]      scripts/cross/pil.sh --build-only
set -euo pipefail
source "$(dirname "$0")/env.sh"
bash "$root/scripts/cross/install-toolchain.sh" >/dev/null
(cd "$root/firmware" && CARGO_TARGET_DIR=target/pil $CARGO build --quiet --release --target thumbv7em-none-eabihf --features pil)
[ "${1:-}" = "--build-only" ] && exit 0
trials="${1:-30}"
out="$root/out/pil"
mkdir -p "$out"
cd "$root"
cargo build --quiet --release -p trn-sim --bin trn
args=(train --seed 1 --trials "$trials" --eval-targets 5 --grasps 3 --quiet)
start=$SECONDS
TRN_QEMU_ARM="$QEMU_ARM" ./target/release/trn "${args[@]}" --bus slcan:qemu --report "$out/firmware.json" > "$out/firmware.txt"
pil_s=$((SECONDS - start))
./target/release/trn "${args[@]}" --bus inproc --report "$out/host.json" > "$out/host.txt"
stack=$(sed -n 's/^trn-firmware pil: stack high-water mark: \([0-9]*\) bytes/\1/p' "$out/firmware.txt")
echo "pil: firmware stack high-water mark ${stack:-unknown} bytes (limit 8192)"
[ -n "$stack" ] && [ "$stack" -le 8192 ] || { echo "pil: FAIL: stack high-water mark" >&2; exit 1; }
python3 - "$out/firmware.json" "$out/host.json" "$trials" "$pil_s" <<'PY'
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
print(f"pil: {sys.argv[3]} trials per network on the firmware in QEMU ({sys.argv[4]} s) against the host build: "
      f"largest curve difference {worst} ({'bit-identical' if same else 'within f32 tolerance'}); "
      f"final error {a['final_error_px']:.4f} px firmware, {b['final_error_px']:.4f} px host")
sys.exit(0 if ok else 1)
PY
