"""How far the ``dt_s`` option's coarser physics lands from the lab's 1 ms steps:

    python python/examples/dt_fidelity.py [--episodes 25] [--moves 4] [--out FILE.md]

Two arms of the realistic plant, one at the lab's 1 ms steps and one at ``dt_s``, take the
same random moves from the same episodes; after each move the distance between their
lights' noise-free pixels (both cameras, lights in view of both) is recorded. One row per
``dt_s``: the median, 90th percentile and largest distance, and the mean time of a move
(``Arm.step``, this machine, not a budget).
"""

import argparse
import time

import numpy as np

from trn_softarm._native import Arm

STEPS = (0.005, 0.01, 0.02, 0.05)


def differences(dt, episodes, moves):
    lab, fast = Arm("realistic", 1), Arm("realistic", 1, dt)
    rng = np.random.default_rng(0)
    out, spent, n = [], 0.0, 0
    for episode in range(episodes):
        lab.reset(episode)
        fast.reset(episode)
        for _ in range(moves):
            act = rng.uniform(-1, 1, 5).tolist()
            lab.step(act)
            t = time.perf_counter()
            fast.step(act)
            spent, n = spent + time.perf_counter() - t, n + 1
            i, j = lab.info(), fast.info()
            seen = np.array(i["lights_true_in_view"]) & np.array(j["lights_true_in_view"])
            d = np.array(i["lights_true"]).reshape(-1, 2) - np.array(j["lights_true"]).reshape(-1, 2)
            out += list(np.hypot(*d.T)[seen])
    return np.array(out), spent / n


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--episodes", type=int, default=25)
    ap.add_argument("--moves", type=int, default=4)
    ap.add_argument("--out", help="also write the table here (markdown)")
    a = ap.parse_args()
    if a.episodes < 1 or a.moves < 1:
        ap.error("--episodes and --moves are at least 1")
    lines = [
        f"Realistic plant, {a.episodes} episodes of {a.moves} random moves, the lights' noise-free"
        " pixels after each move against the same moves at the lab's 1 ms steps (both cameras,"
        " each light in view of both; the camera noise is 0.3 px).",
        "",
        "| `dt_s` | physics steps a move | pixels compared | median px | p90 px | largest px | a move, ms |",
        "|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for dt in STEPS:
        d, per_move = differences(dt, a.episodes, a.moves)
        q50, q90 = np.percentile(d, [50, 90])
        lines.append(f"| {dt:g} | {round(1.2 / dt)} | {len(d)} | {q50:.4f} | {q90:.4f} | {d.max():.4f} |"
                     f" {per_move * 1e3:.2f} |")
    print("\n".join(lines))
    if a.out:
        with open(a.out, "w") as f:
            f.write("# The `dt_s` option against the lab's 1 ms steps\n\nWritten by"
                    f" `python python/examples/dt_fidelity.py --episodes {a.episodes} --moves {a.moves}"
                    f" --out {a.out}`.\n\n")
            f.write("\n".join(lines) + "\n")


if __name__ == "__main__":
    main()
