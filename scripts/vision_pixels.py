#!/usr/bin/env python3
"""The table of scripts/vision_pixels.sh: `trn train` with --vision pixels against the
geometric camera model, from the runs' JSON reports (DIR/{geometric,pixels}-SEED.json).

  python3 scripts/vision_pixels.py DIR SEEDS
"""
import json
import statistics
import sys


def main():
    d, n = sys.argv[1], int(sys.argv[2])
    seeds = range(100, 100 + n)
    runs = {
        (v, s): json.load(open(f"{d}/{v}-{s}.json"))
        for v in ("geometric", "pixels")
        for s in seeds
    }
    for (v, s), r in runs.items():
        got = r["spec"]["plant"].get("vision", "geometric")
        if got != v:
            sys.exit(f"{d}/{v}-{s}.json: the run's plant reads vision = {got!r}")
    w = 100
    print("```")
    print(f"The main job on pixels against the geometric camera model (`bash scripts/vision_pixels.sh {n}`)")
    print("=" * w)
    print("trn train: project preset, realistic plant, 300 trials, 100 held-out targets per network, 50 grasps")
    print("final: the combined error (px) where the controller's stop rule ends, measured; floor: its camera-noise")
    print("floor (the measured target against the true one); after budget: the combined error after the coarse")
    print("move and 6 fine moves over the held-out targets, 95th percentile, measured and noise-free")
    print("-" * w)
    head = f"{'vision':<10}{'seed':>5}{'final px':>10}{'floor px':>10}{'ratio':>8}{'p95 meas':>10}{'p95 true':>10}{'grasps %':>10}{'wall s':>9}"
    print(head)
    rows = {}
    for v in ("geometric", "pixels"):
        for s in seeds:
            r = runs[(v, s)]
            dep = r["deployment"]
            row = dict(
                final=r["final_error_px"],
                floor=r["noise_floor_px"],
                ratio=r["final_error_px"] / r["noise_floor_px"],
                p95m=dep["combined_measured_p95_px"][-1],
                p95t=dep["combined_true_p95_px"][-1],
                grasps=100.0 * r["grasp_success_rate"],
                wall=r["wall_s"],
            )
            rows[(v, s)] = row
            print(
                f"{v:<10}{s:>5}{row['final']:>10.2f}{row['floor']:>10.3f}{row['ratio']:>8.2f}"
                f"{row['p95m']:>10.2f}{row['p95t']:>10.2f}{row['grasps']:>10.1f}{row['wall']:>9.1f}"
            )
    print("-" * w)
    print(f"{'mean':<15}{'final px':>10}{'floor px':>10}{'ratio':>8}{'p95 meas':>10}{'p95 true':>10}{'grasps %':>10}{'wall s':>9}")
    mean = {}
    for v in ("geometric", "pixels"):
        m = {k: statistics.mean(rows[(v, s)][k] for s in seeds) for k in rows[(v, 100)]}
        mean[v] = m
        print(
            f"{v:<15}{m['final']:>10.2f}{m['floor']:>10.3f}{m['ratio']:>8.2f}"
            f"{m['p95m']:>10.2f}{m['p95t']:>10.2f}{m['grasps']:>10.1f}{m['wall']:>9.1f}"
        )
    g, p = mean["geometric"], mean["pixels"]
    print("-" * w)
    print(f"pixels / geometric: final error {p['final'] / g['final']:.2f}, noise floor {p['floor'] / g['floor']:.2f}, "
          f"ratio to the floor {p['ratio'] / g['ratio']:.2f}, after-budget p95 (noise-free) {p['p95t'] / g['p95t']:.2f}")
    walls = [rows[("pixels", s)]["wall"] / rows[("geometric", s)]["wall"] for s in seeds]
    print(f"wall time of trn train --vision pixels / geometric, run by run: "
          + ", ".join(f"{x:.2f}" for x in walls) + f" (mean {statistics.mean(walls):.2f})")
    print("```")


if __name__ == "__main__":
    main()
