#!/usr/bin/env python3
"""Run a trn study's shards as Ray tasks, then merge them: the same table and JSON as the
unsharded command.

    python cluster/ray_study.py --shards 64 --cpus-per-shard 4 --out out/big --address auto \\
        -- compare --seeds 1000 --configs project

Everything after `--` is a study command of `trn` (compare, sweep, lifelong or study FILE,
with its own options but --shard, --runs, --jobs, --out and --report, which this driver
sets). Each Ray task runs `trn ... --shard I/N --jobs C` in a folder of its own on whatever
node Ray gives it and sends back its run files; the driver writes them to OUT/runs as they
arrive (a shard that fails loses only its own runs) and runs `trn merge OUT/runs --report
OUT/study.json`. The `trn` binary goes to the nodes through Ray's object store, so the nodes
need no shared file system, only the same architecture. A study file and the plant files it
names must be readable at the same path on every node (the driver gives the tasks the full
paths of the files the command names). The plants a study makes of keys are named
`out/KEY.toml` in the run files (each task writes them in its own folder).

--resume: the run files already in OUT/runs go to every task, whose `trn --resume` skips
the runs they hold (recognised by their run specification).

Usage statistics of Ray are off unless RAY_USAGE_STATS_ENABLED is set.
"""
import argparse
import os
import pathlib
import shutil
import subprocess
import sys
import tempfile
import time

os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")

import ray  # noqa: E402  (after the environment above)

# options this driver sets for every shard: refused in the command
OWN = ("--shard", "--runs", "--jobs", "--out", "--report")


def run_files(folder):
    """The run files of a folder: name -> bytes."""
    p = pathlib.Path(folder)
    return {f.name: f.read_bytes() for f in sorted(p.glob("*.json"))} if p.is_dir() else {}


@ray.remote
def shard(binary, command, index, count, jobs, finished):
    """One shard on a Ray worker: its runs, in a folder of its own; returns the run files it
    wrote (name -> bytes), its stderr and its exit code."""
    with tempfile.TemporaryDirectory(prefix=f"trn-shard-{index}-") as tmp:
        trn = os.path.join(tmp, "trn")
        with open(trn, "wb") as f:
            f.write(binary)
        os.chmod(trn, 0o755)
        runs = os.path.join(tmp, "runs")
        os.makedirs(runs)
        for name, data in finished.items():
            with open(os.path.join(runs, name), "wb") as f:
                f.write(data)
        # `--out out` in the task's folder: the plants a study writes are named `out/KEY.toml`
        # in every task and every call, so a resumed run's specification is the same
        args = [trn, *command, "--shard", f"{index}/{count}", "--jobs", str(jobs),
                "--runs", runs, "--out", "out"]
        if finished:
            args.append("--resume")
        p = subprocess.run(args, cwd=tmp, capture_output=True, text=True)
        new = {n: d for n, d in run_files(runs).items() if finished.get(n) != d}
        return new, p.stderr, p.returncode


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--trn", default="target/release/trn", help="the trn binary (default: %(default)s)")
    ap.add_argument("--shards", type=int, required=True, help="Ray tasks, one shard each")
    ap.add_argument("--cpus-per-shard", type=int, default=1, help="cores per task: its --jobs (default 1)")
    ap.add_argument("--out", required=True, help="OUT/runs gets the run files, OUT/study.json the study's JSON")
    ap.add_argument("--address", default=None, help="a Ray cluster (auto: the one this node belongs to); default: a local Ray")
    ap.add_argument("--num-cpus", type=int, default=None, help="cores of the local Ray (default: all)")
    ap.add_argument("--resume", action="store_true", help="keep the runs already in OUT/runs")
    ap.add_argument("command", nargs=argparse.REMAINDER, help="-- and a trn study command")
    a = ap.parse_args()
    command = a.command[1:] if a.command[:1] == ["--"] else a.command
    if not command or command[0] not in ("compare", "sweep", "lifelong", "study"):
        ap.error("give a study command after --: compare, sweep, lifelong or study FILE")
    if a.shards < 1 or a.cpus_per_shard < 1:
        ap.error("--shards and --cpus-per-shard are at least 1")
    for arg in command:
        if arg.split("=")[0] in OWN:
            ap.error(f"{arg}: the driver sets {', '.join(OWN)} itself")
    # the tasks run in folders of their own: files the command names, by their full path
    command = [str(pathlib.Path(c).resolve()) if not c.startswith("-") and pathlib.Path(c).is_file() else c
               for c in command]
    out = pathlib.Path(a.out)
    runs = out / "runs"
    runs.mkdir(parents=True, exist_ok=True)
    finished = run_files(runs) if a.resume else {}

    if a.address:
        ray.init(address=a.address)
    else:
        ray.init(num_cpus=a.num_cpus, include_dashboard=False, _node_ip_address="127.0.0.1")
    binary = ray.put(pathlib.Path(a.trn).read_bytes())
    given = ray.put(finished)
    started = time.monotonic()
    pending = {
        shard.options(num_cpus=a.cpus_per_shard).remote(binary, command, i, a.shards, a.cpus_per_shard, given): i
        for i in range(a.shards)
    }
    failed, written = [], 0
    while pending:
        ready, _ = ray.wait(list(pending), num_returns=1)
        i = pending.pop(ready[0])
        try:
            new, err, code = ray.get(ready[0])
        except Exception as e:  # a node lost, a task killed: only this shard's runs are lost
            new, err, code = {}, str(e), -1
        for name, data in new.items():
            tmp = runs / f".{name}.tmp-{os.getpid()}"
            tmp.write_bytes(data)
            os.replace(tmp, runs / name)
        written += len(new)
        done = a.shards - len(pending)
        print(f"[{done}/{a.shards}] shard {i}/{a.shards}: {len(new)} runs, exit {code} "
              f"({time.monotonic() - started:.0f} s)", file=sys.stderr, flush=True)
        if code != 0:
            failed.append(i)
            sys.stderr.write(err[-4000:])
    print(f"ray_study: {written} runs written to {runs}", file=sys.stderr)
    if failed:
        sys.exit(f"ray_study: shards {failed} failed; their finished runs are kept: run again with --resume")
    merge = [a.trn, "merge", str(runs), "--report", str(out / "study.json")]
    sys.exit(subprocess.run(merge).returncode)


if __name__ == "__main__":
    main()
