#!/usr/bin/env python3
"""Headline figures of the project preset across seeds, and the check against them.

record COMPARE.json BANDS.json   mean and sample sd over the seeds of the project row
check BANDS.json COMPARE.json    every seed of the project row within mean +- 4 sd
"""
import json
import math
import sys

K = 4.0


def headline(seed):
    t = seed["combined_true_px"]
    return {
        "combined_true_coarse_px": t[0],
        "combined_true_after_2_fine_px": t[2],
        "combined_true_after_budget_px": t[-1],
        "combined_measured_after_budget_px": seed["combined_measured_px"][-1],
        "moves_to_2px": seed["moves_to_2px"],
        "fine_moves_stop_rule": seed["fine_moves_stop_rule"],
        "grasp_success": seed["grasp_success"],
    }


def project(rows):
    # `trn compare --report` writes {"provenance": .., "results": rows}; older files the rows
    if isinstance(rows, dict):
        rows = rows["results"]
    for r in rows:
        if r["name"] == "project":
            return r["seeds"]
    sys.exit("bands: no project row")


def record(compare, bands):
    seeds = [headline(s) for s in project(json.load(open(compare)))]
    out = {"seeds": len(seeds), "k_sd": K, "figures": {}}
    for key in seeds[0]:
        xs = [s[key] for s in seeds if s[key] is not None]
        m = sum(xs) / len(xs)
        sd = math.sqrt(sum((x - m) ** 2 for x in xs) / (len(xs) - 1))
        out["figures"][key] = {"mean": m, "sd": sd}
    json.dump(out, open(bands, "w"), indent=1)
    print(f"bands: recorded {len(out['figures'])} figures over {len(seeds)} seeds in {bands}")


def check(bands, compare):
    b = json.load(open(bands))
    bad = 0
    for seed in project(json.load(open(compare))):
        for key, x in headline(seed).items():
            f = b["figures"][key]
            lo, hi = f["mean"] - K * f["sd"], f["mean"] + K * f["sd"]
            ok = x is not None and lo <= x <= hi
            bad += not ok
            print(f"seed {seed['seed']} {key:36} {x!s:>10}  band [{lo:.3f}, {hi:.3f}]  {'ok' if ok else 'OUT'}")
    if bad:
        sys.exit(f"bands: {bad} figures outside mean +- {K} sd: a regression (or re-record the bands with scripts/results.sh)")
    print("bands: every headline figure within its band")


if __name__ == "__main__":
    {"record": record, "check": check}[sys.argv[1]](sys.argv[2], sys.argv[3])
