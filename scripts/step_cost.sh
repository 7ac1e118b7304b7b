#!/usr/bin/env bash
# What one move and one reset of the environment's arm cost in instructions, which do not
# depend on the machine's load (valgrind's callgrind on python/examples/step_cost.py, the
# realistic plant from Python):
#   PYTHON=venv/bin/python bash scripts/step_cost.sh [--out docs/python/step-cost.md]
# PYTHON is a Python with the trn_softarm package installed (default: python3). Each cost
# is the difference of two runs' counts over the difference of their moves (or resets), so
# Python's start and the package's import cancel; numpy's BLAS and rayon run one thread
# each, as their idle threads' spinning would otherwise add to the counts.
set -euo pipefail
root="$(cd "$(dirname "$0")/.." && pwd)"
python="${PYTHON:-python3}"
out=""
if [ "${1:-}" = "--out" ]; then
    out="${2:?--out needs a file}"
elif [ -n "${1:-}" ]; then
    echo "usage: PYTHON=... bash scripts/step_cost.sh [--out FILE.md]" >&2
    exit 2
fi
command -v valgrind > /dev/null || { echo "step_cost.sh: valgrind is not installed" >&2; exit 1; }
"$python" -c 'import trn_softarm' || { echo "step_cost.sh: $python has no trn_softarm" >&2; exit 1; }
export OPENBLAS_NUM_THREADS=1 RAYON_NUM_THREADS=1
count() {
    valgrind --tool=callgrind --callgrind-out-file=/dev/null \
        "$python" "$root/python/examples/step_cost.py" "$@" 2>&1 |
        sed -n 's/.*Collected : \([0-9]*\).*/\1/p'
}
moves=200
resets=20
base=$(count 0 0)
step=$(count "$moves" 0)
base_fast=$(count 0 0 0.01)
step_fast=$(count "$moves" 0 0.01)
base_coarse=$(count 0 0 0.05)
step_coarse=$(count "$moves" 0 0.05)
reset=$(count 0 "$resets")
per() { python3 -c "print(f'{($2 - $1) / $3 / 1e6:.2f} M')"; }
table="# What a move and a reset cost

Written by \`bash scripts/step_cost.sh --out docs/python/step-cost.md\`: instructions counted
by valgrind's callgrind, which do not depend on the machine's load. Each figure is the
difference of two runs of \`python/examples/step_cost.py\` over the difference of their moves
($moves random moves) or resets ($resets), the realistic plant from Python.

| | instructions |
|---|---:|
| \`Arm.step\` (a move: 1,200 physics steps of 1 ms, both cameras) | $(per "$base" "$step" "$moves") |
| \`Arm.step\` with \`dt_s=0.01\` (120 physics steps; hidden lights by the analytic fit) | $(per "$base_fast" "$step_fast" "$moves") |
| \`Arm.step\` with \`dt_s=0.05\` (24 physics steps; the same fit) | $(per "$base_coarse" "$step_coarse" "$moves") |
| \`Arm.reset\` (the twin's path to the target, the start move) | $(per "$base" "$reset" "$resets") |"
echo "$table"
if [ -n "$out" ]; then
    printf '%s\n' "$table" > "$out.tmp"
    mv "$out.tmp" "$out"
fi
