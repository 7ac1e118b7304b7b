#!/usr/bin/env bash
# A trn study as a SLURM job array: task I of N runs shard I/N of the study (the runs whose
# index is I modulo N), each finished run written at once to OUT/runs on the cluster's
# shared file system; a merge job makes the table and JSON of the whole study.
#
#   sbatch --array=0-63 --cpus-per-task=4 cluster/slurm_study.sh OUT -- compare --seeds 1000
#   sbatch --dependency=afterok:JOBID cluster/slurm_study.sh --merge OUT
#
# (the README's "Studies on many cores and machines" runs 1,000 seeds this way). Everything
# after `--` is a study command of trn (compare, sweep, lifelong or study FILE) without
# --shard, --jobs, --runs and --out, which this script sets: --jobs from
# SLURM_CPUS_PER_TASK, --resume always (a requeued or resubmitted task skips the runs its
# shard finished: a run is recognised by its run specification). The shard of a task:
# I = SLURM_ARRAY_TASK_ID - SLURM_ARRAY_TASK_MIN, N = SLURM_ARRAY_TASK_COUNT (TRN_SHARDS
# overrides N, for arrays with a step). `--print-shard` prints I/N and does nothing else.
# TRN names the binary (default target/release/trn: build it first with
# `cargo build --release -p trn-sim --bin trn`).
#SBATCH --job-name=trn-study
#SBATCH --cpus-per-task=4
#SBATCH --output=trn-study-%A_%a.log
set -euo pipefail

shard_of() {
    local id=${SLURM_ARRAY_TASK_ID:-} min=${SLURM_ARRAY_TASK_MIN:-0}
    local count=${TRN_SHARDS:-${SLURM_ARRAY_TASK_COUNT:-}}
    if [ -z "$id" ] || [ -z "$count" ]; then
        echo "slurm_study: not a task of a job array (SLURM_ARRAY_TASK_ID and SLURM_ARRAY_TASK_COUNT unset)" >&2
        return 2
    fi
    local index=$((id - min))
    if [ "$count" -lt 1 ] || [ "$index" -lt 0 ] || [ "$index" -ge "$count" ]; then
        echo "slurm_study: task $id of an array from $min with $count tasks is no shard" >&2
        return 2
    fi
    echo "$index/$count"
}

trn=${TRN:-target/release/trn}
case "${1:-}" in
--print-shard)
    shard_of
    exit
    ;;
--merge)
    out=${2:?usage: $0 --merge OUT}
    exec "$trn" merge "$out/runs" --report "$out/study.json"
    ;;
"" | -*)
    echo "usage: $0 OUT -- compare|sweep|lifelong|study FILE [options]  |  $0 --merge OUT  |  $0 --print-shard" >&2
    exit 2
    ;;
esac
out=$1
shift
[ "${1:-}" = "--" ] && shift
shard=$(shard_of)
echo "slurm_study: shard $shard on $(hostname), ${SLURM_CPUS_PER_TASK:-1} cores" >&2
exec "$trn" "$@" --shard "$shard" --jobs "${SLURM_CPUS_PER_TASK:-1}" --runs "$out/runs" --out "$out" --resume
