#!/usr/bin/env bash
# Candidates for a better fine move that are not in the controller on main: they live on
# commit 384a8bc (tagged exp-jacobian-field) and its ancestors 7df5470 (exp-forward-jacobian)
# and e5b988a (exp-probe), all merged into main's history without their changes, which add
# options to the controller and their rows to studies/precision.toml:
# - `probe`: persistent excitation of the Jacobian rule (8.15): each fine move of an
#   unsupervised learning trial is pushed across by a fraction of its own length, in a
#   pseudo-random direction, so the secants the rule learns from cover every direction;
# - `fine_gain`: a mature trial's fine steps (8.14) lengthened or shortened by a factor;
# - `forward`, `forward_ridge`: forward Jacobians dv/dp learned beside the inverse ones from
#   the same secants, regressed on the commanded dp instead of the measured dv, and a mature
#   trial's fine moves solving the ridge least squares with their rank average;
# - `jac_field`: a mature trial's averaged Jacobian moved from its ranks' weighted centroid to
#   the midpoint of the reading and the target, along the ridge-regressed gradient of the
#   ranks' Jacobians over their centres.
# This builds 384a8bc in a temporary worktree, runs the rows against the project preset on
# the tuning seeds 1-4 and writes docs/results/precision-fine-move.md (copied into
# docs/diagnosis.md by scripts/readme_sections.py). About 10 minutes on 2 cores after the build.
#   bash scripts/precision_fine_move.sh [--jobs N]
set -euo pipefail
cd "$(dirname "$0")/.."
source scripts/experiment_worktree.sh
rev=384a8bc47339b1343935b0ea341a4fd3c595d33f  # the commit tagged exp-jacobian-field
rows=project,probe-0.25,probe-0.5,probe-1,fine-gain-0.9,fine-gain-1.1,fine-gain-1.2
rows+=,forward-r0.001,forward-r0.01,forward-r0.1,forward-0.3-r0.01,forward-0.1-r0.01
rows+=,jac-field-0.1,jac-field-0.3,jac-field-1,jac-field-0.3-noise-0.5,jac-field-0.3-map-0.7-noise-0.5
rows+=,trials-1000-combined,c1000-jac-field-0.3,c1000-jac-field-0.3-r23
experiment_worktree "$rev"
"$trn" study studies/precision.toml --runs "$tmp/runs" --quiet --configs "$rows" "$@" > "$tmp/table.md"
mv "$tmp/table.md" "$root/docs/results/precision-fine-move.md"
