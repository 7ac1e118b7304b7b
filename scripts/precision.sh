#!/usr/bin/env bash
# The candidates for fewer fine moves (studies/precision.toml), measured on tuning seeds
# (below 100) against the project preset: docs/results/precision.md and .json, copied into
# docs/diagnosis.md by scripts/readme_sections.py. Extra arguments go to `trn study`
# (`--resume` keeps the runs an interrupted call finished; `--jobs N`).
#   bash scripts/precision.sh            about 20 minutes on 2 cores
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --quiet -p trn-sim --bins
res=docs/results
mkdir -p "$res" out/runs
./target/release/trn study studies/precision.toml --runs out/runs/precision --quiet "$@" \
    --report "$res/precision.json" > "$res/precision.md"
