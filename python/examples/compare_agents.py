"""Compare an agent with the project's controllers on the SoftArm, in a few lines.

    pip install ./python gymnasium matplotlib
    python python/examples/compare_agents.py --out docs/python

Trains the TRN from Python on the Gymnasium environment (stage 1: five pressures to place
the gripper's lights on the target's), then runs it, the Broyden servo (no training) and a
random agent on the same held-out episodes, and writes ``compare.md`` (the table),
``learning.png`` (the TRN's error after its trial, by training episode) and ``cameras.png``
(what both cameras see at the end of a TRN episode) to ``--out``. Every seed is fixed: the
figures are the same on every run.
"""

import argparse
import os

import numpy as np

from trn_softarm import Controller, SoftArmEnv, run_episode


def final_error(infos):
    """The noise-free error (pixels) after the last move of an episode, NaN if a light was lost."""
    e = infos[-1]["error_true_px"] if infos else None
    return np.nan if e is None else e


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--train", type=int, default=300, help="training episodes of the TRN")
    ap.add_argument("--test", type=int, default=30, help="held-out episodes per agent")
    ap.add_argument("--out", default="out/python-example")
    a = ap.parse_args()
    os.makedirs(a.out, exist_ok=True)

    # the environment: each episode a held-out target, at most 7 moves (the project's budget:
    # the coarse move and 6 fine moves), no early termination
    env = SoftArmEnv(config="realistic", max_moves=7, tolerance_px=0.0)

    trn = Controller("trn", seed=1)
    learning = []
    for episode in range(a.train):
        infos = run_episode(env, trn, seed=episode, learn=True)
        learning.append(final_error(infos))

    rng = np.random.default_rng(0)
    agents = {
        "TRN (trained above, frozen)": lambda seed: run_episode(env, trn, seed=seed, learn=False),
        "Broyden servo (no training)": lambda seed: run_episode(env, Controller("broyden"), seed=seed),
        "random pressures": lambda seed: run_episode(
            env, lambda obs: rng.uniform(-1, 1, 5).astype(np.float32), seed=seed
        ),
    }
    held_out = range(10_000, 10_000 + a.test)
    rows = []
    for name, run in agents.items():
        errors = np.array([final_error(run(seed)) for seed in held_out])
        ok = errors[np.isfinite(errors)]
        rows.append((name, np.median(ok), np.mean(ok), len(errors) - len(ok)))

    with open(os.path.join(a.out, "compare.md"), "w") as f:
        f.write(f"| agent ({a.test} held-out episodes, realistic plant) | median final error (px) | mean (px) | lights lost |\n")
        f.write("|---|---|---|---|\n")
        for name, med, mean, lost in rows:
            f.write(f"| {name} | {med:.2f} | {mean:.2f} | {lost} |\n")

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(8, 4))
    x = np.arange(1, len(learning) + 1)
    ax.semilogy(x, learning, ".", alpha=0.35, label="each episode")
    window = 21
    smooth = [np.nanmean(learning[max(0, i - window // 2) : i + window // 2 + 1]) for i in range(len(learning))]
    ax.semilogy(x, smooth, "-", label=f"mean over {window} episodes")
    ax.set_xlabel("training episode")
    ax.set_ylabel("noise-free error after the trial (px)")
    ax.set_title("The TRN learning from Python (SoftArmEnv, stage 1)")
    ax.xaxis.get_major_locator().set_params(integer=True)
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0))
    fig.tight_layout()
    fig.savefig(os.path.join(a.out, "learning.png"), dpi=110)

    view = SoftArmEnv(config="realistic", max_moves=7, tolerance_px=0.0, render_mode="rgb_array")
    run_episode(view, trn, seed=10_000, learn=False)
    fig, ax = plt.subplots(figsize=(10, 4))
    ax.imshow(view.render())
    ax.set_axis_off()
    ax.set_title("camera 0 and camera 1 after a TRN episode: lights read (red), target (green rings)")
    fig.tight_layout()
    fig.savefig(os.path.join(a.out, "cameras.png"), dpi=110)
    for name, med, mean, lost in rows:
        print(f"{name}: median {med:.2f} px, mean {mean:.2f} px, {lost} lost")


if __name__ == "__main__":
    main()
