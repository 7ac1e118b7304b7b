#!/usr/bin/env bash
# The cluster drivers against the unsharded command, on a tiny study (the project preset
# and the Broyden servo, seeds 100-102, 8 training trials, 3 held-out targets, 2 grasps:
# 6 runs of about half a second):
#   bash scripts/cluster-test.sh slurm  the SLURM script's shard arithmetic (its shard
#                                       computation with SLURM_ARRAY_TASK_ID set, no SLURM),
#                                       then its 4 tasks run one after another here and
#                                       merged: the unsharded JSON (wall times aside). ~10 s.
#   bash scripts/cluster-test.sh ray    cluster/ray_study.py on a local Ray started by the
#                                       driver (ray.init()): 3 shards as Ray tasks, merged:
#                                       the unsharded JSON; then --resume runs nothing again.
#                                       Installs Ray 2.60.0 from PyPI into out/ray-venv on
#                                       first use (a download of about 70 MB, 1-2 minutes;
#                                       about 0.5 GB installed); then ~30 s.
set -euo pipefail
cd "$(dirname "$0")/.."
cargo build --release --quiet -p trn-sim --bin trn
trn=$(pwd)/target/release/trn
work=out/cluster-test
rm -rf "$work"
mkdir -p "$work"
study=(compare --configs project,broyden --seeds 3 --trials 8 --eval-targets 3 --grasps 2)

# JSON files equal but for their wall times
same_json() {
    python3 - "$1" "$2" <<'EOF'
import json, sys
def clean(v):
    if isinstance(v, dict):
        return {k: (0 if k == "wall_s" else clean(x)) for k, x in v.items() if k != "provenance"}
    if isinstance(v, list):
        return [clean(x) for x in v]
    return v
a, b = (clean(json.load(open(p))) for p in sys.argv[1:3])
if a != b:
    sys.exit(f"{sys.argv[1]} and {sys.argv[2]} differ")
print(f"same results: {sys.argv[1]} and {sys.argv[2]}")
EOF
}

"$trn" "${study[@]}" --quiet --jobs 2 --runs "$work/whole-runs" --out "$work/whole" \
    --report "$work/whole.json" > "$work/whole.md"

slurm() {
    local s=cluster/slurm_study.sh
    # the shard of every task of arrays from 0 and from 1, and of one with a step
    for n in 1 4 7; do
        for min in 0 1; do
            seen=""
            for ((id = min; id < min + n; id++)); do
                got=$(SLURM_ARRAY_TASK_ID=$id SLURM_ARRAY_TASK_MIN=$min SLURM_ARRAY_TASK_COUNT=$n bash $s --print-shard)
                [ "$got" = "$((id - min))/$n" ] || { echo "task $id of $min..: $got"; return 1; }
                seen="$seen ${got%/*}"
            done
            [ "$seen" = "$(for ((i = 0; i < n; i++)); do printf ' %d' $i; done)" ] || return 1
        done
    done
    [ "$(SLURM_ARRAY_TASK_ID=6 SLURM_ARRAY_TASK_MIN=0 SLURM_ARRAY_TASK_COUNT=4 TRN_SHARDS=8 bash $s --print-shard)" = 6/8 ]
    if SLURM_ARRAY_TASK_ID=4 SLURM_ARRAY_TASK_COUNT=4 bash $s --print-shard 2>/dev/null; then
        echo "task 4 of 4 tasks from 0 was given a shard"
        return 1
    fi
    if env -u SLURM_ARRAY_TASK_ID bash $s --print-shard 2>/dev/null; then
        echo "a shard outside a job array"
        return 1
    fi
    echo "slurm: shard arithmetic ok"
    # the array's 4 tasks, one after another, then the merge job
    for id in 0 1 2 3; do
        SLURM_ARRAY_TASK_ID=$id SLURM_ARRAY_TASK_MIN=0 SLURM_ARRAY_TASK_COUNT=4 SLURM_CPUS_PER_TASK=1 \
            TRN="$trn" bash $s "$work/slurm" -- "${study[@]}" --quiet
    done
    TRN="$trn" bash $s --merge "$work/slurm" > "$work/slurm.md"
    same_json "$work/whole.json" "$work/slurm/study.json"
    cmp "$work/whole.md" "$work/slurm.md"
}

ray_study() {
    local venv=out/ray-venv
    if ! "$venv/bin/python" -c "import ray" 2>/dev/null; then
        python3 -m venv "$venv"
        "$venv/bin/pip" install --quiet --disable-pip-version-check "ray==2.60.0"
    fi
    export RAY_USAGE_STATS_ENABLED=0
    "$venv/bin/python" cluster/ray_study.py --trn "$trn" --shards 3 --num-cpus 2 \
        --out "$work/ray" -- "${study[@]}" > "$work/ray.md"
    same_json "$work/whole.json" "$work/ray/study.json"
    cmp "$work/whole.md" "$work/ray.md"
    "$venv/bin/python" cluster/ray_study.py --trn "$trn" --shards 3 --num-cpus 2 --resume \
        --out "$work/ray" -- "${study[@]}" > "$work/ray-again.md" 2> "$work/ray-again.log"
    grep -q "ray_study: 0 runs written" "$work/ray-again.log" ||
        { cat "$work/ray-again.log"; echo "--resume ran again"; return 1; }
    same_json "$work/whole.json" "$work/ray/study.json"
    echo "ray: 3 shards as Ray tasks give the unsharded study; --resume runs nothing again"
}

case "${1:-}" in
slurm) slurm ;;
ray) ray_study ;;
*) echo "usage: $0 slurm|ray" >&2; exit 2 ;;
esac
