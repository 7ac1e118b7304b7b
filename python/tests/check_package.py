"""The Python package as a user meets it, for the test suite (scripts/python-package.sh):

    python python/tests/check_package.py [--log TRAINING.log] [--recording RUN.rrd]

- the Gymnasium environment passes ``check_env``, takes 200 random steps (stage 1 and 2),
  resets reproducibly, renders both cameras, and works as a vector environment;
- the TRN and the Broyden controllers act on numpy arrays: trained for a few episodes, the
  TRN ends closer to its targets than where it started;
- the decoder decodes a training's candump log whole (0 undecoded), segments included, and
  frames given one by one;
- a rerun recording of a run (``trn train --rerun-save``) reads back with rerun's own
  reader: its entities and as many learning-curve points as training trials.

Every check raises on failure; the last line is ``N passed, 0 failed``.
"""

import argparse
import sys

import numpy as np

import gymnasium as gym
from gymnasium.utils.env_checker import check_env

import trn_softarm
from trn_softarm import Controller, SoftArmEnv, decode_candump, decode_frames, run_episode

passed = 0


def check(name):
    def wrap(f):
        global passed
        f()
        passed += 1
        print(f"ok   {name}")
        return f

    return wrap


def environment():
    @check("check_env(SoftArmEnv()) and 200 random steps, stage 1")
    def _():
        env = SoftArmEnv()
        check_env(env)
        env.action_space.seed(0)
        obs, info = env.reset(seed=7)
        steps = 0
        for _ in range(200):
            obs, reward, terminated, truncated, info = env.step(env.action_space.sample())
            assert obs in env.observation_space
            assert np.isfinite(reward) and reward <= 0
            steps += 1
            if terminated or truncated:
                obs, info = env.reset()
        assert steps == 200

    @check("stage 2: 3 pressures, the gripper-centre light")
    def _():
        env = SoftArmEnv(stage=2, config="ideal")
        check_env(env)
        obs, _ = env.reset(seed=1)
        assert env.action_space.shape == (3,) and obs["lights"].shape == (2, 2)

    @check("reset(seed) is reproducible and seeds differ")
    def _():
        env = SoftArmEnv()
        a, _ = env.reset(seed=3)
        b, _ = env.reset(seed=3)
        c, _ = env.reset(seed=4)
        assert np.array_equal(a["target"], b["target"]) and np.array_equal(a["lights"], b["lights"])
        assert not np.array_equal(a["target"], c["target"])

    @check("render(): both camera images, the target and the lights drawn")
    def _():
        env = SoftArmEnv(render_mode="rgb_array", render_scale=4)
        env.reset(seed=2)
        img = env.render()
        assert img.dtype == np.uint8 and img.ndim == 3 and img.shape[2] == 3
        assert img.shape[1] > 2 * img.shape[0], "two images side by side"
        green = (img[:, :, 1] > 150) & (img[:, :, 0] < 80)
        red = (img[:, :, 0] > 180) & (img[:, :, 1] < 60)
        assert green.sum() > 20 and red.sum() > 20, (green.sum(), red.sum())

    @check("gym.make and a vector environment of 4 arms")
    def _():
        env = gym.make(trn_softarm.ENV_ID, max_moves=5)
        env.reset(seed=0)
        envs = gym.make_vec(trn_softarm.ENV_ID, num_envs=4, vectorization_mode="sync")
        obs, _ = envs.reset(seed=0)
        assert obs["lights"].shape == (4, 4, 2)
        obs, rewards, term, trunc, _ = envs.step(envs.action_space.sample())
        assert rewards.shape == (4,) and len(set(np.round(rewards, 3))) > 1
        envs.close()


def controllers():
    @check("the TRN trains from Python and gets closer; the Broyden servo acts")
    def _():
        env = SoftArmEnv(config="ideal", tolerance_px=0.0, max_moves=12)
        trn = Controller("trn", seed=1)
        errors = []
        for episode in range(40):
            infos = run_episode(env, trn, seed=100 + episode, learn=True)
            errors.append((infos[0]["error_true_px"], infos[-1]["error_true_px"]))
        first, last = np.array(errors[-10:], dtype=float).T
        assert np.nanmean(last) < np.nanmean(first), errors[-10:]
        broyden = Controller("broyden")
        infos = run_episode(env, broyden, seed=5, learn=False)
        assert broyden.done and len(infos) >= 2, broyden.outcome
        assert broyden.outcome.get("stage1") is not None

    @check("the calibrated model and the oracle on an environment's arm; other laws refused")
    def _():
        # no termination by the environment: the controllers stop by their own rule
        env = SoftArmEnv(max_moves=10, tolerance_px=0.0)
        for law, fine in (("model", 2.0), ("oracle", 1.0)):
            ctrl = Controller(law, env=env)
            infos = run_episode(env, ctrl, seed=5, learn=False)
            assert ctrl.done and ctrl.outcome["stage1"]["fine_moves"] <= 8, ctrl.outcome
            assert infos[-1]["error_true_px"] < 3.0 * fine, (law, infos[-1]["error_true_px"])
        for law, says in (("model", "pass env="), ("oracle", "pass env="), ("trm", '"trn", "broyden", "model" and "oracle"')):
            try:
                Controller(law)
            except ValueError as e:
                assert law in str(e) and says in str(e), e
            else:
                raise AssertionError(f"Controller({law!r}) was accepted")


def decoder(log):
    @check(f"the decoder: every frame of {log} decoded")
    def _():
        d = decode_candump(log)
        s = d.summary
        assert s["undecoded"] == 0 and not d.bad_lines, (s, d.undecoded[:3])
        kinds = {m["kind"] for m in d.messages}
        assert {"Observation", "Stage1Target", "TrialReport", "Heartbeat"} <= kinds, kinds
        assert any(f["what"] == "segment" for f in d.frames)
        obs = next(m for m in d.messages if m["kind"] == "Observation")
        assert isinstance(obs["fields"]["seq"], int) and len(obs["fields"]["points"]) == 4
        # the same frames one by one
        frames = [(f["id"], bytes.fromhex(f["data"]), f["fd"], f["timestamp_us"]) for f in d.frames]
        again = decode_frames(frames)
        assert again.summary == s and again.messages == d.messages


def recording(path, trials):
    @check(f"the recording {path} reads back with rerun's reader")
    def _():
        from rerun.recording import load_recording

        rec = load_recording(path)
        entities = {str(c.entity_path) for c in rec.schema().component_columns()}
        for e in ("/world/arm/links", "/world/target/lights", "/error/measured_px", "/curve/stage1_px"):
            assert e in entities, sorted(entities)
        table = rec.view(index="trial", contents="/curve/stage1_px").select().read_all()
        assert table.num_rows == trials, (table.num_rows, trials)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--log", help="a training's candump log (CAN 2.0)")
    ap.add_argument("--recording", help="a rerun recording of a training")
    ap.add_argument("--trials", type=int, default=0, help="its training trials per network")
    a = ap.parse_args()
    environment()
    controllers()
    if a.log:
        decoder(a.log)
    if a.recording:
        recording(a.recording, a.trials)
    print(f"{passed} passed, 0 failed")
    return 0


if __name__ == "__main__":
    sys.exit(main())
