#!/usr/bin/env bash
# The candidates for fewer fine moves (studies/precision.toml), measured on tuning seeds
# (below 100) against the project preset: docs/results/precision.md and .json, copied into
# docs/diagnosis.md by scripts/readme_sections.py. Extra arguments go to `trn study`
# (`--resume` keeps the runs an interrupted call finished; `--jobs N`).
# Then the project preset and the best candidates again on the reporting seeds 100-109
# (`--first-seed 100 --seeds 10`): docs/results/precision-heldout.md and .json.
#   bash scripts/precision.sh            about 20 minutes on 2 cores, and 10 for the reporting seeds
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --quiet -p trn-sim --bins
res=docs/results
mkdir -p "$res" out/runs
./target/release/trn study studies/precision.toml --runs out/runs/precision --quiet "$@" \
    --report "$res/precision.json" > "$res/precision.md"
./target/release/trn study studies/precision.toml --runs out/runs/precision-heldout --quiet "$@" \
    --configs project,trials-1000-combined,trials-2000-combined --first-seed 100 --seeds 10 \
    --report "$res/precision-heldout.json" > "$res/precision-heldout.md"
