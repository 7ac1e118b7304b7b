"""The baseline table of SoftArm-v0: every agent on the same held-out targets, stage 1 and
stage 2, the same budget.

    python python/examples/baselines.py [--test 100] [--train 1000] [--rl-steps 100000]
        [--rl-seeds 3] [--out docs/python/baselines.md]

Agents: the TRN (trained from Python on ``--train`` episodes, then frozen), the Broyden
servo (no training), the calibrated model and the oracle (the physical limit: it solves on
an exact copy of the arm), random pressures, and PPO from stable-baselines3 (trained for
``--rl-steps`` environment steps on each of ``--rl-seeds`` seeds, on ``FlatObservation``
with ``VecNormalize``; its rows are left out, and the table says so, when stable-baselines3
is not installed or ``--rl-steps 0``).

Each held-out episode (seeds 10,000 on) is the realistic plant, a target drawn as the
project's evaluation draws it, and a budget of 7 moves (the coarse move and 6 fine moves)
with no early termination by the environment: the controllers stop by their own rule (the
TRN's tolerance), a policy uses every move. The figures are the noise-free error after the
last move (``info["error_true_px"]``): its median, 90th percentile and worst; the share
of episodes ending within the TRN's tolerance of the stage; the moves taken. Every seed is
fixed: the table is the same on every run (PPO's too, on one machine: torch's CPU kernels
are deterministic here with one thread).
"""

import argparse
import json
import os
import platform
import time

import numpy as np

from trn_softarm import Controller, FlatObservation, SoftArmEnv, run_episode

HELD_OUT = 10_000
BUDGET = 7


def episode_figures(infos):
    """(final noise-free error or NaN when a light was lost, moves) of one episode."""
    if not infos:
        return np.nan, 0
    e = infos[-1]["error_true_px"]
    return (np.nan if e is None else float(e)), len(infos)


def evaluate(env, run, n):
    """Runs ``run(seed)`` (an episode's infos) on the held-out seeds."""
    errors, moves = [], []
    for seed in range(HELD_OUT, HELD_OUT + n):
        e, m = episode_figures(run(seed))
        errors.append(e)
        moves.append(m)
    return np.array(errors), np.array(moves)


def row(name, errors, moves, tolerance, note=""):
    ok = errors[np.isfinite(errors)]
    return {
        "agent": name,
        "episodes": int(len(errors)),
        "median_px": float(np.median(ok)) if len(ok) else None,
        "p90_px": float(np.percentile(ok, 90)) if len(ok) else None,
        "worst_px": float(np.max(ok)) if len(ok) else None,
        "success": float(np.mean(np.isfinite(errors) & (np.nan_to_num(errors, nan=np.inf) <= tolerance))),
        "moves": float(np.mean(moves)),
        "lost": int(len(errors) - len(ok)),
        "note": note,
    }


def policy_episode(env, act):
    """An episode of a policy ``act(obs) -> action`` over the whole budget."""

    def run(seed):
        obs, _ = env.reset(seed=seed)
        infos = []
        while True:
            obs, _, terminated, truncated, info = env.step(act(obs))
            infos.append(info)
            if terminated or truncated:
                return infos

    return run


def train_ppo(stage, steps, seed):
    """PPO (stable-baselines3's defaults) on the flat observation with VecNormalize; the
    trained policy as ``act(obs_dict)`` and its training time."""
    import torch
    from stable_baselines3 import PPO
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    torch.set_num_threads(1)

    def make():
        return FlatObservation(SoftArmEnv(config="realistic", stage=stage, max_moves=BUDGET))

    venv = VecNormalize(DummyVecEnv([make]))
    venv.seed(seed)
    t0 = time.perf_counter()
    model = PPO("MlpPolicy", venv, seed=seed, verbose=0, device="cpu")
    model.learn(total_timesteps=steps)
    seconds = time.perf_counter() - t0
    venv.training = False
    flat = make()

    def act(obs):
        x = venv.normalize_obs(flat.observation(obs)[None, :])
        action, _ = model.predict(x, deterministic=True)
        return action[0]

    return act, seconds


def stage_rows(stage, a, rl):
    env = SoftArmEnv(config="realistic", stage=stage, max_moves=BUDGET, tolerance_px=0.0)
    joints = 5 if stage == 1 else 3

    trn = Controller("trn", stage=stage, seed=1)
    t0 = time.perf_counter()
    for episode in range(a.train):
        run_episode(env, trn, seed=episode, learn=True)
    train_s = time.perf_counter() - t0
    tolerance = trn.tolerance_px

    broyden = Controller("broyden", stage=stage)
    model = Controller("model", env=env)
    oracle = Controller("oracle", env=env)
    rng = np.random.default_rng(0)
    agents = [
        (f"TRN ({a.train:,} training episodes, then frozen)", lambda s: run_episode(env, trn, seed=s, learn=False)),
        ("Broyden servo (no training)", lambda s: run_episode(env, broyden, seed=s)),
        ("calibrated model", lambda s: run_episode(env, model, seed=s)),
        ("oracle (the physical limit)", lambda s: run_episode(env, oracle, seed=s)),
        ("random pressures", policy_episode(env, lambda obs: rng.uniform(-1, 1, joints).astype(np.float32))),
    ]
    rows = [row(name, *evaluate(env, run, a.test), tolerance) for name, run in agents]
    seconds = {"trn": train_s, "ppo": []}
    for k in range(rl["seeds"]):
        act, s = train_ppo(stage, rl["steps"], seed=k)
        seconds["ppo"].append(s)
        errors, moves = evaluate(env, policy_episode(env, act), a.test)
        rows.append(row(f"PPO, seed {k} ({rl['steps']:,} training steps)", errors, moves, tolerance))
    return rows, tolerance, seconds


def fmt(x):
    return "-" if x is None else f"{x:.2f}"


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--test", type=int, default=100, help="held-out episodes per agent and stage")
    ap.add_argument("--train", type=int, default=1000, help="training episodes of the TRN per stage")
    ap.add_argument("--rl-steps", type=int, default=100_000, help="PPO's environment steps per seed (0: no PPO rows)")
    ap.add_argument("--rl-seeds", type=int, default=3, help="PPO's seeds")
    ap.add_argument("--stages", default="1,2")
    ap.add_argument("--out", default="out/baselines.md", help="the table (Markdown); the figures beside it as .json")
    a = ap.parse_args()
    for name, v in (("--test", a.test), ("--train", a.train), ("--rl-steps", a.rl_steps), ("--rl-seeds", a.rl_seeds)):
        if v < 0 or (name == "--test" and v == 0):
            ap.error(f"{name} {v}: a count, at least {1 if name == '--test' else 0}")
    stages = [int(s) for s in a.stages.split(",")]
    if any(s not in (1, 2) for s in stages):
        ap.error("--stages: 1, 2 or 1,2")

    try:
        import stable_baselines3

        sb3 = stable_baselines3.__version__
    except ImportError:
        sb3 = None
    rl = {"steps": a.rl_steps, "seeds": a.rl_seeds if (sb3 and a.rl_steps > 0) else 0}

    t0 = time.perf_counter()
    results = {}
    for stage in stages:
        rows, tolerance, seconds = stage_rows(stage, a, rl)
        results[stage] = {"tolerance_px": tolerance, "rows": rows, "training_s": seconds}
        for r in rows:
            print(f"stage {stage}: {r['agent']}: median {fmt(r['median_px'])} px, p90 {fmt(r['p90_px'])}, "
                  f"success {100 * r['success']:.0f} %, {r['moves']:.2f} moves")

    out = a.out
    if os.path.dirname(out):
        os.makedirs(os.path.dirname(out), exist_ok=True)
    lines = [
        "# SoftArm-v0: baselines on the same held-out targets",
        "",
        f"Written by `python python/examples/baselines.py --test {a.test} --train {a.train} "
        f"--rl-steps {a.rl_steps} --rl-seeds {a.rl_seeds} --out {out}` "
        f"({time.perf_counter() - t0:.0f} s on {os.cpu_count()} cores, {platform.machine()}).",
        "",
        f"{a.test} held-out episodes per agent and stage (seeds {HELD_OUT:,} to {HELD_OUT + a.test - 1:,}), the "
        f"realistic plant, a budget of {BUDGET} moves (the coarse move and 6 fine moves); the "
        "controllers stop by their own rule, a policy uses every move. Errors are the noise-free "
        "pixel error after the last move; success is the share of episodes ending within the "
        "TRN's tolerance of the stage; moves count the coarse move.",
        "",
    ]
    if rl["seeds"] == 0:
        if a.rl_steps == 0:
            why = "--rl-steps 0"
        elif a.rl_seeds == 0:
            why = "--rl-seeds 0"
        else:
            why = "stable-baselines3 is not installed"
        lines += [f"No reinforcement-learning rows in this run: {why}.", ""]
    else:
        lines += [
            f"PPO: stable-baselines3 {sb3}, its default hyperparameters, the `MlpPolicy` on "
            "`FlatObservation` with `VecNormalize` (observations and rewards), trained on "
            f"episodes of {BUDGET} moves with the environment's default tolerance "
            "(2 px, measured) ending them; evaluated deterministically.",
            "",
        ]
    for stage in stages:
        r = results[stage]
        what = "stage 1: 5 pressures, lights p and q" if stage == 1 else "stage 2: 3 pressures, the gripper centre"
        lines += [
            f"## {what.capitalize()}",
            "",
            f"| agent | median px | p90 px | worst px | success (<= {r['tolerance_px']:.1f} px) | moves | lights lost |",
            "|---|---:|---:|---:|---:|---:|---:|",
        ]
        for x in r["rows"]:
            lines.append(
                f"| {x['agent']} | {fmt(x['median_px'])} | {fmt(x['p90_px'])} | {fmt(x['worst_px'])} | "
                f"{100 * x['success']:.0f} % | {x['moves']:.2f} | {x['lost']} |"
            )
        t = r["training_s"]
        ppo = ", ".join(f"{s:.0f} s" for s in t["ppo"])
        lines += ["", f"Training time in this run: the TRN {t['trn']:.1f} s" + (f", PPO {ppo}" if ppo else "") + ".", ""]
    with open(out, "w") as f:
        f.write("\n".join(lines))
    with open(os.path.splitext(out)[0] + ".json", "w") as f:
        json.dump({"stages": results, "test": a.test, "train": a.train, "rl": rl, "sb3": sb3}, f, indent=1)
    print(f"wrote {out}")


if __name__ == "__main__":
    main()
