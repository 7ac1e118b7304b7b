#!/usr/bin/env bash
# Experiments for fewer fine moves whose options are not in the controller on main: they live
# on the commit tagged exp-approach-smooth (and its ancestors exp-approach, exp-loopstate,
# exp-rls, exp-loopside, exp-blend, exp-deadband, exp-avg, exp-prank, exp-proj, exp-anchor,
# exp-replay and exp-trial-estimate; all merged into main's history without their changes),
# which add them to the controller (the last two to the plant's servo drives) and their rows
# to studies/precision.toml. This builds that commit in a
# temporary worktree, runs its rows on the tuning seeds 1-4 (the rows whose controller
# reads the drives' pressures from the harness one run at a time, `--jobs 1`: that side
# channel is one per process) and writes docs/results/precision-experiments.md, then the
# best five with the 1,000-trial row they change on the reporting seeds 100-109 into
# docs/results/precision-experiments-heldout.md, and the 25 % loop with and without the
# drives' approach from below on the reporting seeds with 50 grasps each into
# docs/results/precision-experiments-loop25.md (all three copied into docs/diagnosis.md by
# scripts/readme_sections.py). About 70 + 20 minutes on 2 cores after the build (estimated
# from a whole run of 69 minutes with fewer rows, its first 47 beside the test suite at a
# higher priority, and the newest rows run alone).
#   bash scripts/precision_experiments.sh [--jobs N]
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/experiment_worktree.sh
rev=6f1c3c3bf45cb0c1b870e433f96e4007a48a25e7  # the commit tagged exp-approach-smooth
rows=project,trials-1000-combined,loop-25
rows+=,rev-0.3,rev-0.6,rev-m0.3,rev-m0.5,loop-25-rev-1,loop-25-rev-3,c1000-rev-m0.3,c1000-rev-m0.5
rows+=,est-0.42-0.15,est-0.42-0.3,est-0.42-0.5,est-f0.3-b1,est-f0.3-b2,est-f0.3-b3,est-f0.5-b1
rows+=,c1000-est-f0.3-b2,tol-1.1,tol-1.2
rows+=,fine-p-1,fine-p-0.5,replay-1,replay-3,neurons-500,neurons-250
rows+=,c1000-replay-1,c1000-fine-p-1,c1000-neurons-250,anchor-1-r8,anchor-0.5-r8,anchor-1-r32
rows+=,stop-proj,stop-proj-tol-0.9,stop-proj-tol-0.8,tol-0.9,stop-pca8-tol-0.9,stop-pca16-tol-1.0
rows+=,stop-pca16-tol-0.9,step-pca16-tol-0.9,c1000-stop-pca8-tol-1.0,c1000-stop-pca8-tol-0.9
rows+=,jac-pressure-9,jac-pressure-9-half,jac-pressure-24
rows+=,avg-1.5,avg-2,avg-3,c1000-avg-2,avg-1,avg-1.5-nosec,c1000-avg-1.5
rows+=,dead-0.003,dead-0.01,dead-0.03
rows+=,blend-0.25,blend-0.5,blend-1,c1000-blend-0.5
rows+=,side-0.02,side-0.05,side-learn-1,side-learn-3,loop-25-side-0.1,loop-25-side-learn-1
rows+=,loop-25-side-learn-3,rls-0.99,rls-0.99-init-0.1,rls-0.9-init-0.1,rls-0.8-init-0.1
rows+=,rls-0.8-min-5
rows+=,approach-0.5,approach-1.0,approach-1.2,approach-1.0-min-0.05,approach-1.0-min-0.15
rows+=,approach-smooth-1.0-1.0,approach-smooth-1.0-1.5,approach-settle-2.5,approach-1.0-settle-2.5
rows+=,approach-no-creep,approach-1.0-no-creep,loop-25-approach-1.0,loop-25-approach-1.2
rows+=,loop-25-approach-1.2-map-step-0.7,loop-25-approach-1.0-min-0.05
rows+=,loop-25-approach-1.0-min-0.15,loop-25-approach-smooth-1.0-1.0
rows+=,loop-25-approach-smooth-1.0-1.5,loop-25-approach-1.0-settle-2.5
rows+=,loop-25-approach-1.0-step-noise-0.5,loop-25-approach-1.0-c1000
rows+=,loop-25-approach-1.0-settle-2.5-c1000
# read the drives' pressures through the harness's side channel: one run at a time
drives=drives-side-0.02,drives-side-0.05,drives-side-learn-1,loop-25-drives-side-0.1
drives+=,loop-25-drives-side-learn-1
experiment_worktree "$rev"
"$trn" study studies/precision.toml --runs "$tmp/runs" \
    --quiet --configs "$rows" "$@" > "$tmp/table.md"
"$trn" study studies/precision.toml --runs "$tmp/drives" \
    --quiet --configs "$drives" --jobs 1 | tail -n +3 >> "$tmp/table.md"
"$trn" study studies/precision.toml --runs "$tmp/heldout" \
    --quiet --configs trials-1000-combined,c1000-rev-m0.3,c1000-est-f0.3-b2,c1000-replay-1,c1000-stop-pca8-tol-0.9 \
    --first-seed 100 --seeds 10 "$@" > "$tmp/heldout.md"
"$trn" study studies/precision.toml --runs "$tmp/loop25" \
    --quiet --configs loop-25,loop-25-approach-1.0,loop-25-approach-1.0-settle-2.5,loop-25-approach-1.0-settle-2.5-c1000 \
    --first-seed 100 --seeds 10 --grasps 50 "$@" > "$tmp/loop25.md"
mv "$tmp/table.md" "$root/docs/results/precision-experiments.md"
mv "$tmp/heldout.md" "$root/docs/results/precision-experiments-heldout.md"
mv "$tmp/loop25.md" "$root/docs/results/precision-experiments-loop25.md"
