#!/usr/bin/env bash
# The main job (`trn train`: the project preset on the realistic plant, 300 trials, 100
# held-out targets per network, 50 grasps) with the camera processor on pixels
# (`--vision pixels`) against the geometric camera model, on seeds from 100, one run at a
# time (their wall times are compared); writes docs/results/vision-pixels.md.
#   bash scripts/vision_pixels.sh [SEEDS]   SEEDS runs of each (default 3: seeds 100-102)
set -euo pipefail
cd "$(dirname "$0")/.."
n=${1:-3}
cargo build --release --quiet -p trn-sim --bins
out=out/vision-pixels
mkdir -p "$out"
for s in $(seq 100 $((100 + n - 1))); do
    for v in geometric pixels; do
        ./target/release/trn train --seed "$s" --vision "$v" --report "$out/$v-$s.json" \
            > "$out/$v-$s.md"
    done
done
python3 scripts/vision_pixels.py "$out" "$n" > docs/results/vision-pixels.md
cat docs/results/vision-pixels.md
