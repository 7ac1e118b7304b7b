#!/usr/bin/env bash
# The map's error (docs/diagnosis.md, "The map and its Jacobians"): trains the project preset
# on a copy of the ideal plant without hysteresis (seeds 100-102, 300 trials), then measures
# each network's coarse move and first fine move on the same plant at rest, and its pieces
# against the plant's exact tangents
# (host/bench/examples/map_error.rs). Prints the table (docs/results/diagnosis-map.md).
# About 2 minutes of one core.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --quiet -p trn-sim --bins
cargo build --release --quiet -p trn-bench --example map_error
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
plant="$tmp/no-hysteresis.toml"
sed -e 's/^hysteresis_width = .*/hysteresis_width = 0.0/' \
    -e 's/^hysteresis_asymmetry = .*/hysteresis_asymmetry = 0.0/' host/plant/sim.toml > "$plant"
# every joint's loop, and nothing else, changed (the ideal plant has no skew or widening)
[ "$(grep -c '^hysteresis_width = 0.0$' "$plant")" = 5 ] || { echo "diagnosis_map: sim.toml changed shape" >&2; exit 1; }
grep -q '^hysteresis_skew = 0.0$' "$plant" && grep -q '^load_width_gain = 0.0$' "$plant" \
    || { echo "diagnosis_map: sim.toml has a skewed or widening loop" >&2; exit 1; }
nets=()
for seed in 100 101 102; do
    ./target/release/trn train --seed "$seed" --config "$plant" --quiet \
        --checkpoint-out "$tmp/seed$seed.ckpt" > /dev/null
    nets+=("$seed=$tmp/seed$seed.ckpt")
done
./target/release/examples/map_error "$plant" "${nets[@]}"
