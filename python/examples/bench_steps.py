"""Environment steps per second: SoftArm-v0 (the lab's plant, and the ``dt_s`` option),
single and as the native vector env, beside MuJoCo's Reacher-v5 when MuJoCo is installed.

    python python/examples/bench_steps.py [--seconds 3] [--rounds 3] [--num-envs 2] [--frames] [--out FILE.md]

Random actions, episodes reset as they end (the reset counts: it is part of stepping an
environment); each figure is environment steps (moves) per second of wall-clock time in
this process. The single and vector figures are measured in one run, so they compare on
one machine under one load: each row is measured ``--rounds`` times, the rows taking turns,
and the table gives each row's median (and its lowest and highest round). ``--frames`` adds a row with the camera frames in the
observation (``frames=True``, the default ``frame_scale``). A second table gives one native
arm's move time alone (mean and percentiles), with and without ``dt_s``.
"""

import argparse
import os
import time

import numpy as np
import gymnasium as gym

import trn_softarm  # noqa: F401  (registers trn_softarm/SoftArm-v0)


def single(env, seconds, seed=0):
    env.action_space.seed(seed)
    env.reset(seed=seed)
    n, t0 = 0, time.perf_counter()
    while time.perf_counter() - t0 < seconds:
        _, _, terminated, truncated, _ = env.step(env.action_space.sample())
        n += 1
        if terminated or truncated:
            env.reset()
    rate = n / (time.perf_counter() - t0)
    env.close()
    return rate


def vector(envs, seconds, seed=0):
    envs.action_space.seed(seed)
    envs.reset(seed=seed)
    n, t0 = 0, time.perf_counter()
    while time.perf_counter() - t0 < seconds:
        envs.step(envs.action_space.sample())  # ended episodes reset on the next step
        n += envs.num_envs
    rate = n / (time.perf_counter() - t0)
    envs.close()
    return rate


def step_times(dt_s, steps=2000, episode=20, seed=0):
    """One native arm's move (``Arm.step``, no Python layer) timed one by one: random
    actions, a reset every ``episode`` moves (built in place, timed apart). Microseconds:
    ``(moves, resets)``."""
    from trn_softarm._native import Arm

    rng = np.random.default_rng(seed)
    arm = Arm("realistic", 1, dt_s, False, 0.0)
    arm.reset(seed)
    times, resets = [], []
    for i in range(steps):
        action = rng.uniform(-1, 1, 5).astype(np.float32).tolist()
        t0 = time.perf_counter()
        arm.step(action)
        times.append(time.perf_counter() - t0)
        if i % episode == episode - 1:
            t0 = time.perf_counter()
            arm.reset(seed + 1 + i)
            resets.append(time.perf_counter() - t0)
    return 1e6 * np.array(times), 1e6 * np.array(resets)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seconds", type=float, default=3.0, help="per measurement")
    ap.add_argument("--rounds", type=int, default=3, help="measurements of each row, taking turns")
    ap.add_argument("--num-envs", type=int, default=2, help="arms of the vector env")
    ap.add_argument("--fast-dt", type=float, nargs="+", default=[0.01, 0.05],
                    help="dt_s of the fast rows (one pair of rows each)")
    ap.add_argument("--frames", action="store_true", help="also SoftArm-v0 with frames=True")
    ap.add_argument("--out", help="also write the table here (markdown)")
    a = ap.parse_args()
    s, n = a.seconds, a.num_envs
    if s <= 0 or a.rounds < 1 or n < 1:
        ap.error("--seconds must be positive, --rounds and --num-envs at least 1")
    if not all(0.0001 <= dt <= 0.05 for dt in a.fast_dt):
        ap.error("--fast-dt: each dt_s between 0.0001 and 0.05 s")
    sid = "trn_softarm/SoftArm-v0"
    # (environment, mode, a function measuring it once)
    plan = []
    try:
        import mujoco  # noqa: F401

        plan.append(("Reacher-v5", "single", lambda: single(gym.make("Reacher-v5"), s)))
        plan.append(("Reacher-v5", f"sync x{n}",
                     lambda: vector(gym.make_vec("Reacher-v5", num_envs=n, vectorization_mode="sync"), s)))
    except ImportError:
        print("MuJoCo is not installed: Reacher-v5 not measured (pip install 'gymnasium[mujoco]')")
    plan.append(("SoftArm-v0", "single", lambda: single(gym.make(sid), s)))
    plan.append(("SoftArm-v0", f"native x{n}", lambda: vector(gym.make_vec(sid, num_envs=n), s)))
    for dt in a.fast_dt:
        plan.append((f"SoftArm-v0 dt_s={dt}", "single", lambda dt=dt: single(gym.make(sid, dt_s=dt), s)))
        plan.append((f"SoftArm-v0 dt_s={dt}", f"native x{n}",
                     lambda dt=dt: vector(gym.make_vec(sid, num_envs=n, dt_s=dt), s)))
    if a.frames:
        plan.append(("SoftArm-v0 frames=True", "single", lambda: single(gym.make(sid, frames=True), s)))
    runs = [[] for _ in plan]
    for _ in range(a.rounds):
        for k, (_, _, measure) in enumerate(plan):
            runs[k].append(measure())
    rows = [(env, mode, float(np.median(r)), min(r), max(r)) for (env, mode, _), r in zip(plan, runs)]
    ref = {mode.split()[0]: r for env, mode, r, _, _ in rows if env == "Reacher-v5"}
    singles = {env: r for env, mode, r, _, _ in rows if mode == "single"}
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    try:
        import mujoco
        engine = f"mujoco {mujoco.__version__}, "
    except ImportError:
        engine = ""
    lines = [
        f"{os.cpu_count()} cores, load average {load:.1f} at the end, {s:g} s a measurement,"
        f" {a.rounds} rounds of every row taking turns (the median; lowest and highest round),"
        f" {n} environments a vector; random actions, resets included;"
        f" {engine}gymnasium {gym.__version__}, numpy {np.__version__}.",
        "",
        "| environment | mode | steps/s | rounds | x its single | x Reacher-v5 (same mode) |",
        "|---|---|---:|---:|---:|---:|",
    ]
    for env, mode, r, lo, hi in rows:
        kind = mode.split()[0]
        vs_ref = ref.get("sync" if kind == "native" else kind)
        lines.append(f"| {env} | {mode} | {r:,.0f} | {lo:,.0f} to {hi:,.0f} | {r / singles[env]:.2f} | "
                     + (f"{r / vs_ref:.3f} |" if vs_ref else "- |"))
    episode = 20  # the default max_moves, which random actions reach
    cores = min(n, os.cpu_count() or 1)
    lines += [
        "",
        "One arm's move alone (`Arm.step`, without the Python layer; 2,000 random moves, "
        f"microseconds): a vector step waits for its slowest arm. The reset after every {episode}"
        " moves (`Arm.reset`, built in place) is timed apart; the last column is the most"
        f" {n} arms on {cores} cores can gain over one arm, {cores} x {episode} moves / ({episode}"
        " moves + a reset): every core steps an arm, so each arm's resets take time from the"
        " steps, while one arm's resets are built on a core it leaves idle (see below).",
        "",
        f"| plant | mean | p10 | median | p90 | p99 | worst | reset, mean | native x{n} / single at most |",
        "|---|---:|---:|---:|---:|---:|---:|---:|---:|",
    ]
    for name, dt in [("SoftArm-v0", None)] + [(f"SoftArm-v0 dt_s={dt}", dt) for dt in a.fast_dt]:
        t, r = step_times(dt, episode=episode)
        q = np.percentile(t, [10, 50, 90, 99])
        bound = cores * episode * t.mean() / (episode * t.mean() + r.mean())
        lines.append(f"| {name} | {t.mean():.0f} | {q[0]:.0f} | {q[1]:.0f} | {q[2]:.0f} | {q[3]:.0f} | {t.max():.0f}"
                     f" | {r.mean():.0f} | " + (f"{bound:.2f} |" if cores > 1 else "- |"))
    print("\n".join(lines))
    if a.out:
        with open(a.out, "w") as f:
            f.write("# Environment steps per second\n\nWritten by `python python/examples/bench_steps.py"
                    f" --seconds {s:g} --rounds {a.rounds} --out {a.out}` (SoftArm-v0 and MuJoCo's Reacher-v5"
                    " in one run).\n\n")
            f.write("\n".join(lines) + "\n")
            notes = os.path.join(os.path.dirname(os.path.abspath(__file__)), "bench_steps_notes.md")
            with open(notes) as g:
                f.write("\n" + g.read())

if __name__ == "__main__":
    main()
