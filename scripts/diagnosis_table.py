#!/usr/bin/env python3
"""The table of docs/diagnosis.md ("Where the coarse move's error comes from") from the run
files of `trn study studies/diagnosis.toml` (default folder: out/diagnosis/runs).

Per row: the coarse move's combined noise-free error (px) on the held-out targets, as the
mean over seeds of each seed's mean, the mean over seeds of each seed's 95th percentile over
its targets, and the worst seed (its mean, and which seed); then the mean after 2 fine moves
and after the budget's 6 (noise-free), the fine moves per network trial with the stop rule,
each seed's 95th percentile of the measured error after the budget over its noise floor (the
mean over seeds and the worst; none when the cameras are noise-free), the noise floor and
the failed trials (of the held-out evaluation, and of the whole run: training, snapshots,
evaluations), for context. Rows in the study's order.
"""
import json
import pathlib
import sys


def p95_over_floor(dep: dict):
    """The 95th percentile of the measured error after the budget over the seed's noise
    floor (the study table's column), or None without a floor."""
    p95 = dep.get("combined_measured_p95_px") or [None]
    floor = dep["noise_floor_px"]
    if p95[-1] is None or not floor:
        return None
    return p95[-1] / floor


def main() -> int:
    folder = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else "out/diagnosis/runs")
    files = sorted(folder.glob("*.json"))
    if not files:
        print(f"error: no run files in {folder}", file=sys.stderr)
        return 1
    rows = {}
    order = []
    for f in files:
        run = json.loads(f.read_text())
        name = run["row"]["name"]
        dep = run["report"]["deployment"]
        if name not in rows:
            rows[name] = []
            order.append((run["index"], name))
        coarse = dep["combined_true_px"][0]
        p95 = dep["combined_true_p95_px"][0] if dep.get("combined_true_p95_px") else None
        if coarse is None:
            print(f"error: {f}: no valid trial after the coarse move", file=sys.stderr)
            return 1
        rows[name].append(
            {
                "seed": run["report"]["seed"],
                "coarse": coarse,
                "p95": p95,
                "fine2": dep["combined_true_px"][2] if len(dep["combined_true_px"]) > 2 else None,
                "budget": dep["combined_true_px"][-1],
                "moves": run["report"]["fine_moves_mean"],
                "p95_floor": p95_over_floor(dep),
                "floor": dep["noise_floor_px"],
                "failed": dep["failed_trials"],
                "failed_run": run["report"]["failed_trials"],
            }
        )
    print(
        "| configuration | seeds | coarse move: mean px | p95 over targets px (mean of seeds) "
        "| worst seed px (seed) | after 2 fine px | after 6 fine px | fine moves, stop rule "
        "| each seed's p95 after 6 / its floor: mean (worst) | noise floor px "
        "| failed trials: held-out / whole run |"
    )
    print("|---|---|---|---|---|---|---|---|---|---|---|")
    for _, name in sorted(order):
        runs = sorted(rows[name], key=lambda r: r["seed"])
        n = len(runs)
        mean = sum(r["coarse"] for r in runs) / n
        p95s = [r["p95"] for r in runs if r["p95"] is not None]
        p95 = f"{sum(p95s) / len(p95s):.1f}" if p95s else "-"
        worst = max(runs, key=lambda r: r["coarse"])
        f2 = [r["fine2"] for r in runs if r["fine2"] is not None]
        fine2 = f"{sum(f2) / len(f2):.2f}" if f2 else "-"
        floor = sum(r["floor"] for r in runs) / n
        b6 = [r["budget"] for r in runs if r["budget"] is not None]
        budget = f"{sum(b6) / len(b6):.2f}" if b6 else "-"
        moves = sum(r["moves"] for r in runs) / n
        ratios = [r["p95_floor"] for r in runs if r["p95_floor"] is not None]
        tail = f"{sum(ratios) / len(ratios):.2f} ({max(ratios):.2f})" if ratios else "-"
        seeds = f"{runs[0]['seed']}-{runs[-1]['seed']}" if n > 1 else str(runs[0]["seed"])
        print(
            f"| {name} | {seeds} | {mean:.1f} | {p95} | {worst['coarse']:.1f} ({worst['seed']}) "
            f"| {fine2} | {budget} | {moves:.2f} | {tail} | {floor:.2f} "
            f"| {sum(r['failed'] for r in runs)} / "
            f"{sum(r['failed_run'] for r in runs)} |"
        )
    return 0


if __name__ == "__main__":
    sys.exit(main())
