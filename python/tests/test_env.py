"""The Gymnasium environment as a learner meets it: the registered id passes check_env, its
state pickles bit for bit, it terminates at its tolerance, the native vector env steps as
Gymnasium's own SyncVectorEnv would, the options (dt_s, persistent, randomise) do what the
README says, and the flat observation suits SB3's VecNormalize (when SB3 is installed).

    pytest python/tests
"""

import copy
import gc
import importlib.util
import os
import pickle
import time

import numpy as np
import pytest

import gymnasium as gym
from gymnasium.utils.env_checker import check_env, data_equivalence

import trn_softarm
from trn_softarm import FlatObservation, SoftArmEnv, SoftArmVectorEnv
from trn_softarm._native import Arm


def steps(env, actions):
    """(obs, reward, terminated, truncated, info) of each action in turn."""
    return [env.step(a) for a in actions]


def random_actions(space, n, seed):
    space.seed(seed)
    return [space.sample() for _ in range(n)]


def _wait_until(ready, seconds=60):
    # an episode built ahead on a thread of the lowest priority: polled, not assumed; the
    # caller's assertions say what a timeout means
    deadline = time.monotonic() + seconds
    while not ready() and time.monotonic() < deadline:
        time.sleep(0.001)


def test_check_env_on_the_registered_id():
    env = gym.make(trn_softarm.ENV_ID)
    check_env(env.unwrapped)
    check_env(gym.make(trn_softarm.ENV_ID, stage=2, config="ideal").unwrapped)


def test_human_mode_offered_only_when_it_can_work():
    modes = SoftArmEnv.metadata["render_modes"]
    assert "rgb_array" in modes
    if importlib.util.find_spec("rerun") is None:
        assert "human" not in modes
    if "human" not in modes:
        with pytest.raises(ValueError, match="human"):
            SoftArmEnv(render_mode="human")


@pytest.mark.parametrize("restore,dt_s", [("pickle", None), ("deepcopy", None), ("pickle", 0.05)])
def test_saved_state_restores_bit_for_bit(restore, dt_s):
    # with dt_s the restored arm goes on with the same exact steps (the options say them)
    env = SoftArmEnv(dt_s=dt_s)
    env.reset(seed=11)
    for a in random_actions(env.action_space, 3, seed=1):
        env.step(a)
    saved = pickle.loads(pickle.dumps(env)) if restore == "pickle" else copy.deepcopy(env)
    actions = random_actions(env.action_space, 6, seed=2)
    # the next episode too: the copy's seed generator was saved with it
    a, b = steps(env, actions), steps(saved, actions)
    a.append(env.reset()), b.append(saved.reset())
    for x, y in zip(a, b):
        assert data_equivalence(x, y, exact=True), (x, y)
    # and the copy is its own arm: stepping it leaves the original where it was
    before = env._arm.state()
    saved.step(actions[0])
    assert env._arm.state() == before


def test_a_bad_state_is_refused():
    with pytest.raises(ValueError, match="state"):
        Arm.from_state(b"\x01\x02\x03")


def test_terminates_exactly_at_the_tolerance():
    # the tolerance: the median error random moves reach, so both outcomes occur
    probe = SoftArmEnv(config="ideal", tolerance_px=-1.0, max_moves=5)
    probe.reset(seed=3)
    errors = []
    for a in random_actions(probe.action_space, 30, seed=4):
        _, _, terminated, truncated, info = probe.step(a)
        assert not terminated
        if info["error_px"] is not None:
            errors.append(info["error_px"])
        if truncated:
            probe.reset()
    tol = float(np.median(errors))
    env = SoftArmEnv(config="ideal", tolerance_px=tol, max_moves=5)
    env.reset(seed=3)
    outcomes = []
    for a in random_actions(env.action_space, 30, seed=4):
        _, reward, terminated, truncated, info = env.step(a)
        err = info["error_px"]
        assert terminated == (err is not None and err <= tol)
        assert truncated == (not terminated and info["moves"] >= 5)
        assert reward == (-err if err is not None else -env._layout.diagonal)
        outcomes.append(terminated)
        if terminated or truncated:
            env.reset()
    assert any(outcomes) and not all(outcomes), outcomes


def test_the_vector_entry_point_is_native():
    envs = gym.make_vec(trn_softarm.ENV_ID, num_envs=2)
    assert isinstance(envs.unwrapped, SoftArmVectorEnv)
    obs, _ = envs.reset(seed=0)
    assert obs in envs.observation_space and obs["lights"].shape == (2, 4, 2)


@pytest.mark.parametrize("stage", [1, 2])
def test_native_vector_env_steps_as_sync_vector_env(stage):
    kw = dict(stage=stage, config="ideal", max_moves=3)
    native = SoftArmVectorEnv(num_envs=3, **kw)
    sync = gym.vector.SyncVectorEnv([lambda: SoftArmEnv(**kw) for _ in range(3)])
    assert native.single_observation_space == sync.single_observation_space
    assert native.action_space == sync.action_space
    a, b = native.reset(seed=5), sync.reset(seed=5)
    assert data_equivalence(a, b, exact=True)
    resets = 0
    for actions in random_actions(native.action_space, 8, seed=6):
        a, b = native.step(actions), sync.step(actions)
        assert a[0] in native.observation_space
        assert data_equivalence(a, b, exact=True), (a, b)
        resets += int(np.sum(a[2] | a[3]))
    assert resets >= 3, "episodes ended and were reset on the next step"
    # a seed list, and a reset of some arms only
    a = native.reset(seed=[7, None, 9])
    b = sync.reset(seed=[7, None, 9])
    assert data_equivalence(a[0]["target"][[0, 2]], b[0]["target"][[0, 2]], exact=True)
    with pytest.raises(ValueError):
        native.step(np.zeros((2, native.single_action_space.shape[0])))


@pytest.mark.parametrize("persistent", [False, True])
def test_the_vector_env_builds_each_next_episode_ahead_as_its_reset_would(persistent):
    kw = dict(config="ideal", max_moves=2, persistent=persistent)
    native = SoftArmVectorEnv(num_envs=2, **kw)
    sync = gym.vector.SyncVectorEnv([lambda: SoftArmEnv(build_ahead=False, **kw) for _ in range(2)])
    assert data_equivalence(native.reset(seed=3), sync.reset(seed=3), exact=True)
    resets = 0
    for actions in random_actions(native.action_space, 9, seed=4):
        # a persistent arm's next episode depends on this one: nothing is built for it;
        # otherwise wait until every arm's is built, so that each reset takes it
        if not persistent:
            _wait_until(lambda: native._arms.ready_ahead == 2)
        ending = native._autoreset.copy()
        a, b = native.step(actions), sync.step(actions)
        assert data_equivalence(a, b, exact=True), (a, b)
        resets += int(ending.sum())
    assert resets >= 4, "every episode ends after two moves and resets on the next step"
    assert native._arms.resets_built_ahead == (0 if persistent else resets)


@pytest.mark.parametrize("persistent", [False, True])
def test_the_single_env_builds_its_next_episode_ahead_as_its_reset_would(persistent):
    # against an env that builds every episode in its reset: the same observations, infos
    # and generator draws; every reset took the episode built ahead (fails if the seed drawn
    # ahead were not the reset's, or the draw ahead moved the generator on)
    kw = dict(config="ideal", max_moves=2, persistent=persistent)
    ahead, plain = SoftArmEnv(**kw), SoftArmEnv(build_ahead=False, **kw)
    assert data_equivalence(ahead.reset(seed=3), plain.reset(seed=3), exact=True)
    resets = 0
    for action in random_actions(ahead.action_space, 9, seed=4):
        a, b = ahead.step(action), plain.step(action)
        assert data_equivalence(a, b, exact=True), (a, b)
        if a[2] or a[3]:
            if not persistent:
                _wait_until(lambda: ahead._arm.ready_ahead)
            assert data_equivalence(ahead.reset(), plain.reset(), exact=True)
            resets += 1
    assert resets >= 4, "every episode ends after two moves"
    assert ahead._arm.resets_built_ahead == (0 if persistent else resets)
    assert plain._arm.resets_built_ahead == 0
    assert ahead.np_random.integers(1 << 62) == plain.np_random.integers(1 << 62)
    # a seed given is not the one drawn ahead: that episode is built in the reset
    before = ahead._arm.resets_built_ahead
    assert data_equivalence(ahead.reset(seed=11), plain.reset(seed=11), exact=True)
    assert ahead._arm.resets_built_ahead == before


def _two_arms_with_their_episodes_built_ahead():
    native = SoftArmVectorEnv(num_envs=2, config="ideal")
    native.reset(seed=1)
    _wait_until(lambda: native._arms.ready_ahead == 2)
    assert native._arms.ready_ahead == 2
    return native


def test_a_vector_call_of_the_wrong_length_is_refused_keeping_the_episodes_built_ahead():
    native = _two_arms_with_their_episodes_built_ahead()
    with pytest.raises(ValueError, match="2 arms"):
        native._arms.run([5, None, None], [None, None, None])
    assert native._arms.ready_ahead == 2


def test_a_vector_step_of_the_wrong_size_is_refused_and_steps_no_arm():
    native = _two_arms_with_their_episodes_built_ahead()
    before = [native._arms.info(i)["moves"] for i in range(2)]
    rule = native._layout.rule
    with pytest.raises(ValueError, match="2 arms of 5 joints"):
        native._arms.step_batch(None, np.zeros(9, np.float32).tobytes(), native._layout.bounds, *rule)
    with pytest.raises(ValueError, match="2 arms of 5 joints"):
        native._arms.step_batch([None], np.zeros(10, np.float32).tobytes(), native._layout.bounds, *rule)
    assert [native._arms.info(i)["moves"] for i in range(2)] == before
    assert native._arms.ready_ahead == 2


@pytest.mark.parametrize("kw", [dict(max_moves=0), dict(max_moves=-3), dict(tolerance_px=float("nan"))])
def test_meaningless_episode_rules_are_refused(kw):
    for make in (SoftArmEnv, SoftArmVectorEnv):
        with pytest.raises(ValueError, match="max_moves|tolerance_px"):
            make(**kw)


def test_an_episode_built_ahead_for_an_arm_that_is_not_there_is_refused():
    native = _two_arms_with_their_episodes_built_ahead()
    with pytest.raises(ValueError, match="no arm 2 of 2"):
        native._arms.prepare(2, 7)
    # the arms' own episodes built ahead are untouched, and the next resets take them
    assert native._arms.ready_ahead == 2
    before = native._arms.resets_built_ahead
    native.reset()
    assert native._arms.resets_built_ahead == before + 2


def test_batched_infos_are_gymnasiums_for_any_first_arm():
    # what Gymnasium's VectorEnv._add_info makes of the arms' infos one after the other,
    # where the first arm's value sets each key's type: a None first gives objects, a None
    # after a float NaN
    arms = [
        {"error_px": None, "error_true_px": 0.5, "moves": 3, "pressures": [0.25, -1.0], "lights_true_in_view": [True]},
        {"error_px": 2.0, "error_true_px": None, "moves": 4, "pressures": [0.5, 1.0], "lights_true_in_view": [False]},
    ]
    # ArmVec.info_layout() and info_batch() of these: each key's values arm after arm in
    # the buffer of its kind, a None NaN, and whether the first arm's value is None
    layout = [
        ("error_px", "maybe", 1),
        ("error_true_px", "maybe", 1),
        ("moves", "count", 1),
        ("pressures", "floats", 2),
        ("lights_true_in_view", "flags", 1),
    ]
    floats = bytearray(np.array([np.nan, 2.0, 0.5, np.nan, 0.25, -1.0, 0.5, 1.0], dtype=np.float64).tobytes())
    counts = bytearray(np.array([3, 4], dtype=np.int64).tobytes())
    batch = (floats, bytearray([1, 0]), counts, bytes([1, 0, 0, 0, 0]))
    envs = SoftArmVectorEnv(num_envs=2)
    expected = {}
    for i, info in enumerate(arms):
        info = {k: np.asarray(v) if isinstance(v, list) else v for k, v in info.items()}
        expected = envs._add_info(expected, info, i)
    got = trn_softarm.env._InfoBatch(lambda: layout, 2)(*batch)
    assert list(got) == list(expected)
    for key, want in expected.items():
        have = got[key]
        assert have.dtype == want.dtype and have.shape == want.shape, key
        if want.dtype == object:
            assert have.tolist() == want.tolist(), key
        else:
            assert np.array_equal(have, want, equal_nan=want.dtype.kind == "f"), key
    assert got["error_px"].tolist() == [None, 2.0] and np.isnan(got["error_true_px"][1])


def test_a_bad_action_is_a_value_error():
    env = SoftArmEnv()
    env.reset(seed=0)
    with pytest.raises(ValueError):
        env._arm.step([0.0, float("nan"), 0.0, 0.0, 0.0])
    with pytest.raises(ValueError):
        env._arm.step([0.0, 0.0])


def test_dt_option_is_faithful_and_bounded():
    # 50 ms, its dynamics solved exactly, instead of the lab's 1 ms steps: the lights' true
    # pixels within a fraction of the camera noise (0.3 px) of the lab's plant (measured:
    # 0.06 px median, 0.16 p90; Euler's rule at 10 ms was 0.20 and 0.54)
    lab, fast = Arm("realistic", 1), Arm("realistic", 1, 0.05)
    rng = np.random.default_rng(0)
    diffs = []
    for episode in range(6):
        lab.reset(episode), fast.reset(episode)
        for _ in range(4):
            act = rng.uniform(-1, 1, 5).tolist()
            lab.step(act), fast.step(act)
            i, j = lab.info(), fast.info()
            seen = np.array(i["lights_true_in_view"]) & np.array(j["lights_true_in_view"])
            d = np.array(i["lights_true"]).reshape(-1, 2) - np.array(j["lights_true"]).reshape(-1, 2)
            diffs += list(np.hypot(*d.T)[seen])
    assert 0 < np.median(diffs) < 0.1 and np.percentile(diffs, 90) < 0.3, np.percentile(diffs, [50, 90])
    for bad in (0.06, 0.0, -0.01, float("nan")):
        with pytest.raises(ValueError, match="dt_s"):
            SoftArmEnv(dt_s=bad)


def test_persistent_arm_ages_across_resets():
    env = SoftArmEnv(config="aging", persistent=True, max_moves=2)
    _, first = env.reset(seed=1)
    for a in random_actions(env.action_space, 2, seed=1):
        _, _, _, _, info = env.step(a)
    _, again = env.reset(seed=2)
    # the clock goes on (the target's twin and the start move add to it), the plant is the same
    assert again["time_s"] > info["time_s"] > first["time_s"]
    assert again["plant_seed"] == first["plant_seed"]
    fresh = SoftArmEnv(config="aging", max_moves=2)
    _, f1 = fresh.reset(seed=1)
    _, f2 = fresh.reset(seed=2)
    assert f2["time_s"] == f1["time_s"] and f2["plant_seed"] != f1["plant_seed"]


def test_randomised_plant_is_reproducible_from_its_seed():
    def first_move(randomise, seed):
        env = SoftArmEnv(config="ideal", randomise=randomise)
        env.reset(seed=seed)
        return env.step(np.full(5, 0.4, dtype=np.float32))[4]["joint_angles_deg"]

    plain, r1, r1_again, r2 = first_move(0.0, 1), first_move(0.3, 1), first_move(0.3, 1), first_move(0.3, 2)
    assert np.array_equal(r1, r1_again)
    assert not np.allclose(r1, plain, atol=1e-3)
    assert not np.array_equal(r1, r2)
    with pytest.raises(ValueError, match="randomise"):
        SoftArmEnv(randomise=0.9)
    # the coarsest physics step solves each joint's dynamics exactly: the fastest and least
    # damped joints randomise may draw are stable at it
    env = SoftArmEnv(dt_s=0.05, randomise=0.5)
    for seed in range(5):
        env.reset(seed=seed)
        _, _, _, _, info = env.step(np.full(5, 0.4, dtype=np.float32))
        assert np.all(np.isfinite(info["joint_angles_deg"]))


def test_flat_observation():
    env = FlatObservation(SoftArmEnv(config="ideal"))
    check_env(env)
    obs, _ = env.reset(seed=0)
    assert obs.shape == (36,) and obs.dtype == np.float32 and obs in env.observation_space
    assert np.array_equal(obs[16:].reshape(4, 5).sum(axis=1), np.ones(4))
    assert FlatObservation(SoftArmEnv(stage=2)).observation_space.shape == (18,)


def test_vecnormalize_takes_the_flat_observation():
    sb3 = pytest.importorskip("stable_baselines3", reason="stable-baselines3 is not installed")
    from stable_baselines3.common.vec_env import DummyVecEnv, VecNormalize

    venv = VecNormalize(DummyVecEnv([lambda: FlatObservation(SoftArmEnv(config="ideal", max_moves=3))] * 2))
    venv.seed(0)
    venv.reset()
    for _ in range(4):
        obs, rewards, dones, infos = venv.step(np.zeros((2, 5), dtype=np.float32))
    assert obs.shape == (2, 36) and np.all(np.isfinite(obs)), sb3.__version__


def _centroid(frame, scale):
    """The intensity-weighted centre (full-resolution pixels) of what stands above the
    frame's background, or None when nothing does."""
    f = frame.astype(np.float64)
    background = np.median(f)
    w = np.clip(f - background - 3.0, 0.0, None)
    if w.sum() == 0:
        return None
    ys, xs = np.indices(f.shape)
    # a binned pixel (i, j) covers [i, i + 1) * scale: its centre at (i + 0.5) * scale
    return np.array([((xs + 0.5) * w).sum(), ((ys + 0.5) * w).sum()]) / w.sum() * scale


@pytest.mark.parametrize("stage", [1, 2])
def test_camera_frames_show_the_lights_where_they_are_read(stage):
    """Fails if the frames are not in the observation space, a frame does not show its
    light within 1.5 px of where the camera processor reads it (one light per frame, in
    the rows' order), a light not in view shows in its frame, the frames change with the
    seed but not on a restored state, or rgb_array does not show them."""
    env = gym.make(trn_softarm.ENV_ID, stage=stage, frames=True, frame_scale=4, render_mode="rgb_array")
    check_env(env.unwrapped)
    space = env.observation_space["frames"]
    assert space.shape == (2, 2 if stage == 1 else 1, 192, 256)
    seen = 0
    for seed in range(6):
        obs, info = env.reset(seed=seed)
        assert space.contains(obs["frames"])
        for light in range(space.shape[1]):
            for cam in range(2):
                row = 2 * light + cam
                c = _centroid(obs["frames"][cam, light], 4)
                if not info["lights_true_in_view"][row]:
                    continue
                assert c is not None, (seed, row)
                if obs["status"][row] == 0:
                    assert np.hypot(*(c - obs["lights"][row])) < 1.5, (seed, row, c, obs["lights"][row])
                    seen += 1
    assert seen >= 6 * space.shape[1]
    first = env.reset(seed=1)[0]["frames"]
    again = env.reset(seed=1)[0]["frames"]
    other = env.reset(seed=2)[0]["frames"]
    assert np.array_equal(first, again) and not np.array_equal(first, other)
    env.unwrapped.step(env.action_space.sample())
    restored = pickle.loads(pickle.dumps(env.unwrapped))
    assert np.array_equal(restored.camera_frames(), env.unwrapped.camera_frames())
    picture = env.render()
    assert picture.shape == (192, 512, 3) and picture.dtype == np.uint8
    with pytest.raises(ValueError, match="frames"):
        gym.make_vec(trn_softarm.ENV_ID, num_envs=2, frames=True)
    with pytest.raises(ValueError, match="frame_scale"):
        SoftArmEnv(frames=True, frame_scale=0)


def test_the_native_clip_is_numpys():
    # the observation's pixels and target clipped natively to bounds that cut through the
    # image on every side (so that most readings are clipped one way or the other), against
    # numpy's maximum then minimum of the unclipped reading: the same float32 bits, a NaN
    # kept (fails with an axis' bounds swapped, or a NaN clipped as Rust's f32::max would)
    arm = Arm("realistic", 1, 0.05)
    arm.reset(3)
    rng = np.random.default_rng(4)
    w, h = arm.image_size
    bounds = [w * 0.4, h * 0.3, w * 0.6, h * 0.7]
    low = np.array(bounds[:2], dtype=np.float32)
    high = np.array(bounds[2:], dtype=np.float32)
    clipped = 0
    for _ in range(40):
        arm.step(rng.uniform(-1, 1, 5).tolist())
        lights, status, target = arm.observation()
        got = arm.observation_clipped(bounds)
        for raw, native in ((lights, got[0]), (target, got[2])):
            want = np.minimum(np.maximum(np.array(raw, dtype=np.float32).reshape(-1, 2), low), high)
            have = np.frombuffer(native, dtype=np.float32).reshape(-1, 2)
            assert np.array_equal(have, want, equal_nan=True)
            clipped += int(np.sum(have != np.array(raw, dtype=np.float32).reshape(-1, 2)))
        assert bytes(got[1]) == bytes(status)
    assert clipped > 100
    # an arm not yet reset has no target: NaN, kept so by the clip
    target = np.frombuffer(Arm("realistic", 1).observation_clipped(bounds)[2], dtype=np.float32)
    assert target.size == 8 and np.isnan(target).all()


@pytest.mark.skipif(not hasattr(os, "fork"), reason="no fork on this system")
def test_a_forked_child_steps_and_drops_a_vector_env():
    # a process forked from one holding a vector env has none of its crew's threads, and
    # may have a copy of a lock one of them held: the child's crew knows it has no threads
    # and runs every arm on the child's own thread, touching none of the shared state, and
    # drops it (fails with the fork check removed: the child's crew then counts the
    # parent's threads; a child that hung would fail by the deadline)
    envs = SoftArmVectorEnv(num_envs=2, config="ideal", dt_s=0.05)
    envs.reset(seed=0)
    actions = random_actions(envs.action_space, 3, seed=1)
    envs.step(actions[0])
    threads = envs._arms.crew_threads
    pid = os.fork()
    if pid == 0:
        code = 1
        try:
            for a in actions[1:]:
                envs.step(a)
            assert envs._arms.crew_threads == 0
            del envs
            gc.collect()
            code = 0
        finally:
            os._exit(code)
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        done, status = os.waitpid(pid, os.WNOHANG)
        if done:
            break
        time.sleep(0.01)
    else:
        os.kill(pid, 9)
        os.waitpid(pid, 0)
        pytest.fail("the forked child hung")
    assert os.waitstatus_to_exitcode(status) == 0
    # the parent's crew goes on
    envs.step(actions[1])
    assert envs._arms.crew_threads == threads
