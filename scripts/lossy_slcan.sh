#!/usr/bin/env bash
# What a lossy serial SLCAN line costs a run: `trn train --bus slcan:PTY --external-controller`
# against the project's controller node on the other end of a pseudo-terminal, clean and with
# the host's fault layer dropping 5 % of the frames both ways (host/bench/examples/lossy_slcan.rs:
# 60 training trials, seeds 100-102, the line paced at 500 kbit/s and unpaced). About a minute.
#   bash scripts/lossy_slcan.sh          writes docs/results/lossy-slcan.md (docs/robustness.md)
#   bash scripts/lossy_slcan.sh --check  the test suite: fails when a paced run with the losses
#                                        takes more than 3 times its clean run, or its scores
#                                        differ; writes the table under out/ only
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --quiet -p trn-bench --example lossy_slcan
bench=./target/release/examples/lossy_slcan
if [ "${1:-}" = "--check" ]; then
    mkdir -p out
    exec "$bench" --check > out/lossy-slcan.md
fi
out=docs/results/lossy-slcan.md
"$bench" --check > "$out.tmp"
mv "$out.tmp" "$out"
python3 scripts/readme_sections.py
