#!/usr/bin/env bash
# The compact build (i16 fixed-point tables, `--features compact`: the firmware's 128 KiB
# build) against the f32 build on the honest protocol: the project preset trained
# and evaluated on seeds 100-109 (realistic plant) with i16 tables, paired seed by seed with
# the f32 build's figures recorded by scripts/results.sh (docs/results/compare.json).
#   bash scripts/compact.sh          writes docs/results/compact.json and compact.md (docs/performance.md)
#   bash scripts/compact.sh --resume the same, keeping the runs an interrupted call finished
#   bash scripts/compact.sh --check  the test suite: fails when the compact build's measured
#                                    error after the fixed budget is more than 5 % above the
#                                    f32 build's (means over the 10 seeds)
set -euo pipefail
cd "$(dirname "$0")/.."
res=docs/results
# a target directory of its own: the f32 binary in target/release stays what it is
CARGO_TARGET_DIR=target/compact cargo build --release --quiet -p trn-sim --bin trn --features compact
trn=./target/compact/release/trn
# the compact build's runs in folders of their own (a run file records its build: neither
# build resumes the other's runs)
if [ "${1:-}" = "--check" ]; then
    mkdir -p out
    "$trn" compare --seeds 10 --project-only --runs out/runs/compact-check \
        --report out/compact-check.json > out/compact-check.md
    exec python3 scripts/compact.py check "$res/compare.json" out/compact-check.json
fi
resume=()
[ "${1:-}" = "--resume" ] && resume=(--resume)
"$trn" compare --seeds 10 --project-only --runs out/runs/compact "${resume[@]}" \
    --report "$res/compact.json" > /dev/null
python3 scripts/compact.py table "$res/compare.json" "$res/compact.json" > "$res/compact.md"
python3 scripts/compact.py check "$res/compare.json" "$res/compact.json"
