#!/usr/bin/env python3
"""What a study's wall time would be on P cores, from the run times of its runs.

    study_scaling.py RUNS...   run files or run folders of a study (`--runs DIR`), or a
                               `trn compare --report` JSON (its seeds' wall_s)

Each run is single-threaded and independent, so a study on P workers is a list schedule:
every idle worker takes the next run in the study's order (what rayon's work stealing does
with one run per task, up to the order in which idle workers find them). The schedule's
length over the sum of the run times is the study's wall-time ratio against one worker, if
the cores run as fast as one core alone (no memory-bandwidth or clock limits: each run's
tables fit a core's cache). Also printed: the longest-first (LPT) schedule, what sorting the
runs by cost would give.
"""
import heapq
import json
import pathlib
import sys


def run_times(paths):
    times = []
    for p in map(pathlib.Path, paths):
        files = sorted(p.glob("*.json")) if p.is_dir() else [p]
        for f in files:
            d = json.load(open(f))
            if isinstance(d, dict) and d.get("format", "").startswith("trn-study-run/"):
                times.append((d["index"], d["report"]["wall_s"]))
            elif isinstance(d, list):  # a compare report: rows of seeds
                for row in d:
                    times.extend((len(times), s["wall_s"]) for s in row["seeds"])
    return [t for _, t in sorted(times)]


def makespan(times, workers):
    free = [0.0] * workers
    for t in times:
        start = heapq.heappop(free)
        heapq.heappush(free, start + t)
    return max(free)


def main():
    times = run_times(sys.argv[1:])
    if not times:
        sys.exit("study_scaling: no run times")
    total = sum(times)
    print(f"{len(times)} runs, {total:.0f} s of runs in all, the longest {max(times):.1f} s")
    print("| workers | wall, study order (s) | ratio to 1 worker | speedup | wall, longest first (s) |")
    print("|---|---|---|---|---|")
    for p in (1, 2, 4, 8, 16, 32, 64):
        m = makespan(times, p)
        lpt = makespan(sorted(times, reverse=True), p)
        print(f"| {p} | {m:.0f} | {m / total:.3f} | {total / m:.1f} | {lpt:.0f} |")


if __name__ == "__main__":
    main()
