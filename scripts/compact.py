#!/usr/bin/env python3
"""The compact build (i16 tables) against the f32 build, on the same seeds.

    compact.py table F32_REPORT COMPACT_REPORT      markdown table to stdout
    compact.py check F32_REPORT COMPACT_REPORT      fails when the compact build's measured
                                                    error after the fixed budget is more than
                                                    5 % above the f32 build's (seed means)

The reports are `trn compare --report` JSON; the row named `project` is compared, seed by
seed (the same seeds in both).
"""
import json
import statistics
import sys

LIMIT = 1.05


def project(path):
    data = json.load(open(path))
    # `trn compare --report` writes {"provenance": .., "results": rows}; older files the rows
    if isinstance(data, dict):
        data = data["results"]
    rows = [r for r in data if r["name"] == "project"]
    if not rows:
        sys.exit(f"compact: no project row in {path}")
    return {s["seed"]: s for s in rows[0]["seeds"]}


def paired(f32_path, compact_path):
    a, b = project(f32_path), project(compact_path)
    seeds = sorted(set(a) & set(b))
    if len(seeds) < 3:
        sys.exit(f"compact: {len(seeds)} seeds in common, need 3")
    return seeds, a, b


METRICS = [
    ("combined error after the coarse move, true (px)", lambda s: s["combined_true_px"][0]),
    ("after the coarse move + 2 fine moves, true (px)", lambda s: s["combined_true_px"][2]),
    ("after the coarse move + 6 fine moves, true (px)", lambda s: s["combined_true_px"][6]),
    ("after the coarse move + 6 fine moves, measured (px)", lambda s: s["combined_measured_px"][6]),
    ("camera-noise floor of the measured (px)", lambda s: s["noise_floor_px"]),
    ("fine moves per network trial, stop rule", lambda s: s["fine_moves_stop_rule"]),
    ("grasps (%)", lambda s: 100.0 * s["grasp_success"]),
]


def stats(xs):
    return statistics.mean(xs), (statistics.stdev(xs) if len(xs) > 1 else 0.0)


def table(f32_path, compact_path):
    seeds, a, b = paired(f32_path, compact_path)
    print(f"| seeds {seeds[0]}-{seeds[-1]} (realistic plant, project preset) | f32 tables | i16 tables (compact) | compact / f32 |")
    print("|---|---|---|---|")
    for name, get in METRICS:
        ma, sa = stats([get(a[s]) for s in seeds])
        mb, sb = stats([get(b[s]) for s in seeds])
        print(f"| {name} | {ma:.2f} ± {sa:.2f} | {mb:.2f} ± {sb:.2f} | {mb / ma:.3f} |")


def check(f32_path, compact_path):
    seeds, a, b = paired(f32_path, compact_path)
    get = METRICS[3][1]
    ma = statistics.mean(get(a[s]) for s in seeds)
    mb = statistics.mean(get(b[s]) for s in seeds)
    ratio = mb / ma
    verdict = "ok" if ratio <= LIMIT else "FAIL"
    print(
        f"compact: measured error after the fixed budget, {len(seeds)} seeds: "
        f"f32 {ma:.3f} px, compact {mb:.3f} px, ratio {ratio:.3f} (limit {LIMIT}): {verdict}"
    )
    return ratio <= LIMIT


if __name__ == "__main__":
    if len(sys.argv) != 4 or sys.argv[1] not in ("table", "check"):
        sys.exit(__doc__)
    if sys.argv[1] == "table":
        table(sys.argv[2], sys.argv[3])
    else:
        sys.exit(0 if check(sys.argv[2], sys.argv[3]) else 1)
