#!/usr/bin/env bash
# Two more candidates for fewer fine moves, not in the controller on main: they live on commit
# e5b988a (tagged exp-probe; merged into main's history without its changes), which adds two
# options to the controller and their rows to studies/precision.toml:
# - `probe`: persistent excitation of the Jacobian rule (8.15): each fine move of an
#   unsupervised learning trial is pushed across by a fraction of its own length, in a
#   pseudo-random direction, so the secants the rule learns from cover every direction;
# - `fine_gain`: a mature trial's fine steps (8.14) lengthened or shortened by a factor.
# This builds that commit in a temporary worktree, runs the rows against the project preset
# on the tuning seeds 1-4 and writes docs/results/precision-probe.md (copied into
# docs/diagnosis.md by scripts/readme_sections.py). About 3 minutes on 2 cores after the build.
#   bash scripts/precision_probe.sh [--jobs N]
set -euo pipefail
cd "$(dirname "$0")/.."
root=$PWD
rev=e5b988a831c14fc8c250d7efca74a0db06c4c7d3  # the commit tagged exp-probe
tmp=$(mktemp -d)
cleanup() { git -C "$root" worktree remove --force "$tmp/src" >/dev/null 2>&1 || true; rm -rf "$tmp"; }
trap cleanup EXIT
git worktree add --detach "$tmp/src" "$rev" >/dev/null
rows=project,probe-0.25,probe-0.5,probe-1,fine-gain-0.9,fine-gain-1.1,fine-gain-1.2
(
    cd "$tmp/src"
    CARGO_TARGET_DIR="$root/target/experiments" cargo build --release --quiet -p trn-sim --bins
    "$root/target/experiments/release/trn" study studies/precision.toml --runs "$tmp/runs" \
        --quiet --configs "$rows" "$@" > "$tmp/table.md"
)
mv "$tmp/table.md" "$root/docs/results/precision-probe.md"
