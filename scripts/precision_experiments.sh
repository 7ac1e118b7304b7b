#!/usr/bin/env bash
# Experiments for fewer fine moves whose options are not in the controller on main: they live
# on the commit tagged exp-trial-estimate (merged into main's history without its changes),
# which adds them to the controller and their rows to studies/precision.toml. This builds that
# commit in a temporary worktree, runs its rows on the tuning seeds 1-4 and writes
# docs/results/precision-experiments.md, then the best two with the 1,000-trial row they
# change on the reporting seeds 100-109 into docs/results/precision-experiments-heldout.md
# (both copied into docs/diagnosis.md by scripts/readme_sections.py). About 6 + 7 minutes on
# 2 cores after the build.
#   bash scripts/precision_experiments.sh [--jobs N]
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
rev=ed740c32a3d43ec17ef7ddae066af90b328beb50  # the commit tagged exp-trial-estimate
tmp=$(mktemp -d)
cleanup() { git -C "$root" worktree remove --force "$tmp/src" >/dev/null 2>&1 || true; rm -rf "$tmp"; }
trap cleanup EXIT
git worktree add --detach "$tmp/src" "$rev" >/dev/null
rows=project,trials-1000-combined,loop-25
rows+=,rev-0.3,rev-0.6,rev-m0.3,rev-m0.5,loop-25-rev-1,loop-25-rev-3,c1000-rev-m0.3,c1000-rev-m0.5
rows+=,est-0.42-0.15,est-0.42-0.3,est-0.42-0.5,est-f0.3-b1,est-f0.3-b2,est-f0.3-b3,est-f0.5-b1
rows+=,c1000-est-f0.3-b2,tol-1.1,tol-1.2
(
    cd "$tmp/src"
    CARGO_TARGET_DIR="$root/target/experiments" cargo build --release --quiet -p trn-sim --bins
    "$root/target/experiments/release/trn" study studies/precision.toml --runs "$tmp/runs" \
        --quiet --configs "$rows" "$@" > "$tmp/table.md"
    "$root/target/experiments/release/trn" study studies/precision.toml --runs "$tmp/heldout" \
        --quiet --configs trials-1000-combined,c1000-rev-m0.3,c1000-est-f0.3-b2 \
        --first-seed 100 --seeds 10 "$@" > "$tmp/heldout.md"
)
mv "$tmp/table.md" "$root/docs/results/precision-experiments.md"
mv "$tmp/heldout.md" "$root/docs/results/precision-experiments-heldout.md"
