"""SoftArmEnv: reaching with the simulated SoftArm, as a Gymnasium environment;
SoftArmVectorEnv: many arms stepped in one call (the registered id's vector entry point);
FlatObservation: the observation as one float vector.

An episode is one held-out trial of the project's evaluation: the target is where a twin
arm (the same state of drift and wear) ended after its own random path, as both cameras saw
it; the arm starts from a pose of its own. Each step commands the pressures and reads both
cameras as the camera processor does (the arm settles 1.2 s, the readings are checked for
stereo consistency, a hidden light is filled in from the marker fit): one move.

- Stage 1 (``stage=1``): the action is the 5 joints' normalised pressure differences in
  [-1, 1]; the lights are p and q in camera 0 and camera 1 (rows p0, p1, q0, q1).
- Stage 2 (``stage=2``): the action is the pressures of joints 0..2 (the wrist holds the
  target's); the light is the gripper centre in both cameras (rows g0, g1).

The observation is a dict: ``lights`` (pixels, one row a light in one camera; 0, 0 when not
read), ``status`` (0 valid, 1 out of view, 2 occluded, 3 not detected, 4 estimated: placed by
the camera processor, not read), ``target`` (the target's lights as measured, the same
rows). The reward is minus the measured error (pixels: the distance of ``lights`` to
``target``), or minus the image diagonal when a light is not read. An episode terminates
when the measured error is at most ``tolerance_px`` and is truncated after ``max_moves``.
``python/README.md`` documents every key of the observation and ``info``.
"""

import importlib.util
import os
import sys

import numpy as np
import gymnasium as gym
from gymnasium import spaces
from gymnasium.utils import seeding
from gymnasium.vector import AutoresetMode, VectorEnv
from gymnasium.vector.utils import batch_space

from ._native import Arm, ArmVec

STATUS = ("valid", "out of view", "occluded", "not detected", "estimated")


def _human_can_work():
    """The live view needs the rerun SDK and a screen for its viewer."""
    if importlib.util.find_spec("rerun") is None:
        return False
    if sys.platform in ("darwin", "win32"):
        return True
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


# "human" is offered only where it can work (the [live] extra installed, a display)
RENDER_MODES = ["rgb_array"] + (["human"] if _human_can_work() else [])


class _Layout:
    """The spaces of a stage on cameras of a size, and the conversions of the native
    arm's lists to observations and infos (shared by the single and the vector env)."""

    def __init__(self, stage, image_size, joints, tolerance_px, max_moves):
        self.n = 4 if stage == 1 else 2
        w, h = image_size
        # readings lie in the image; a centroid's noise may carry one a little beyond it
        margin = 16.0
        self.bounds = [-margin, -margin, w + margin, h + margin]
        self.low = np.tile(np.array([-margin, -margin], dtype=np.float32), (self.n, 1))
        self.high = np.tile(np.array([w + margin, h + margin], dtype=np.float32), (self.n, 1))
        self.observation_space = spaces.Dict(
            {
                "lights": spaces.Box(self.low, self.high, dtype=np.float32),
                "status": spaces.MultiDiscrete(np.full(self.n, len(STATUS))),
                "target": spaces.Box(self.low, self.high, dtype=np.float32),
            }
        )
        self.action_space = spaces.Box(-1.0, 1.0, shape=(joints,), dtype=np.float32)
        self.diagonal = float(np.hypot(w, h))
        tolerance, moves = float(tolerance_px), int(max_moves)
        if np.isnan(tolerance):
            raise ValueError("tolerance_px is a number of pixels (below 0: never reached), got NaN")
        if moves < 1:
            raise ValueError(f"max_moves is at least 1, got {max_moves!r}")
        # how the native arms score a move (Arm.outcome, ArmVec.step_batch)
        self.rule = (tolerance, moves, self.diagonal)

    def obs(self, lights, status, target, arms=None):
        """An observation from the native bytes: one arm's (``Arm.observation_clipped``) or,
        ``arms`` given, that many stacked (``ArmVec.observation_batch``); pixels and target
        already clipped to the space's bounds (``bounds``), the arrays writable."""
        shape = (self.n, 2) if arms is None else (arms, self.n, 2)
        return {
            "lights": np.frombuffer(lights, dtype=np.float32).reshape(shape),
            "status": np.frombuffer(status, dtype=np.uint8).astype(np.int64).reshape(shape[:-1]),
            "target": np.frombuffer(target, dtype=np.float32).reshape(shape),
        }

    # the info's keys whose values are points (x, y)
    POINTS = ("lights_true", "target_true")

    @staticmethod
    def info(info):
        n = len(info["lights_true"]) // 2
        for k in _Layout.POINTS:
            info[k] = np.asarray(info[k], dtype=np.float64).reshape(n, 2)
        for k in ("lights_true_in_view", "pressures", "joint_angles_deg", "gripper_mm", "target_gripper_mm"):
            info[k] = np.asarray(info[k])
        return info


class _InfoBatch:
    """The infos of ``n`` arms as Gymnasium's vector environments give them
    (``VectorEnv._add_info`` for each arm in turn, every arm present: each key an array over
    the arms of the first arm's type, a None among floats NaN, and its mask ``_key``), from
    the native ``ArmVec.info_batch()``: an array a buffer, each key's array a slice of its
    buffer, laid out by ``ArmVec.info_layout()``."""

    def __init__(self, layout, n):
        """``layout``: a function that gives ``ArmVec.info_layout()`` (read again whenever
        the buffers' sizes are not the plan's: an arm not yet reset has no lights)."""
        self.layout, self.n = layout, n
        self.plan, self.sizes = [], None

    def _make_plan(self):
        ends = [0, 0, 0]  # floats, flags, counts
        self.plan = []
        for key, kind, width in self.layout():
            src = {"flags": 1, "count": 2}.get(kind, 0)
            start = ends[src]
            ends[src] += width * self.n
            shape = {"floats": (self.n, width), "points": (self.n, width // 2, 2), "flags": (self.n, width)}.get(kind)
            self.plan.append((key, "_" + key, src, slice(start, ends[src]), shape, kind == "maybe"))
        self.sizes = (ends[0] * 8, ends[1], ends[2] * 8)

    def __call__(self, floats, flags, counts, first_none):
        """The batched infos of ``ArmVec.info_batch()``'s buffers."""
        if (len(floats), len(flags), len(counts)) != self.sizes:
            self._make_plan()
        buffers = (np.frombuffer(floats, np.float64), np.frombuffer(flags, np.bool_), np.frombuffer(counts, np.int64))
        masks = list(np.ones((len(self.plan), self.n), dtype=np.bool_))
        infos = {}
        for k, (key, mask_key, src, part, shape, maybe) in enumerate(self.plan):
            array = buffers[src][part]
            if shape is not None:
                array = array.reshape(shape)
            elif maybe and first_none[k]:
                # the first arm's None makes it an array of objects
                array = np.array([None if v != v else v for v in array.tolist()], dtype=object)
            infos[key] = array
            infos[mask_key] = masks[k]
        return infos


def _arm_seed(rng):
    return int(rng.integers(0, 2**63 - 1))


class SoftArmEnv(gym.Env):
    """The simulated SoftArm reaching a held-out target (see the module).

    ``config``: ``realistic`` (the project's default plant), ``ideal``, ``aging`` or a TOML
    file of the simulator's configuration. The options below change the plant the project's
    runs use only when set:

    - ``dt_s``: the physics step (s) of the settle instead of the plant's 1 ms (at most
      0.05), each joint's dynamics solved exactly over a step: fewer steps, faster, and
      within a fraction of the camera noise of the lab's plant (``python/README.md`` gives
      the measured difference).
    - ``persistent``: the arm carries over from one episode to the next (its time, drift,
      wear, hysteresis history); ``reset(seed)`` then draws only a new target and start pose.
      With ``config="aging"`` drift and wear build up across episodes.
    - ``randomise``: a fraction r in [0, 0.5]: every plant built (each reset, or the first
      one when persistent) has each joint's natural frequency, damping ratio, pressure lag
      and hysteresis width multiplied by factors drawn uniformly from [1 - r, 1 + r], from
      the episode's seed (``info["plant_seed"]``).

    ``build_ahead`` (default True): as soon as an episode begins, the next one (the one a
    ``reset()`` without a seed gives) is built on a thread of the lowest priority, in the
    cores' idle time, and that reset takes it ready: the same episode bit for bit, the
    generator's draws unchanged. False builds every episode in its reset, on the caller's
    thread alone (many environments on few cores, where no core is idle). A persistent arm's
    next episode depends on this one and is always built in its reset.

    ``render_scale``: each camera image is drawn at 1/scale of its resolution.

    ``frames``: the observation gains ``frames``, the camera frames of the arm's lights as
    the camera processor takes them: uint8, shape (2 cameras, F, H, W), one light lit per
    frame (stage 1: F = 2, p then q; stage 2: F = 1, the centre light), rendered from the
    geometry (the LEDs' spots, the links hiding them, the sensor's noise: the plant's
    ``[pixels]`` section) and binned by ``frame_scale`` (each block of frame_scale x
    frame_scale pixels averaged). ``render()`` in ``rgb_array`` mode then shows those
    frames (each camera's frames overlaid, the cameras side by side) instead of the drawing.
    """

    metadata = {"render_modes": RENDER_MODES, "render_fps": 2}

    def __init__(
        self,
        stage=1,
        config="realistic",
        max_moves=20,
        tolerance_px=2.0,
        render_mode=None,
        render_scale=2,
        dt_s=None,
        persistent=False,
        randomise=0.0,
        frames=False,
        frame_scale=4,
        build_ahead=True,
    ):
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(
                f"render_mode {render_mode!r} is not one of {self.metadata['render_modes']}"
                + ("" if "human" in RENDER_MODES else " (human needs the [live] extra and a display)")
            )
        self._arm = Arm(config, stage, dt_s, bool(persistent), float(randomise))
        self._build_next = bool(build_ahead) and not persistent
        self.stage = stage
        self.config = config
        self.max_moves = int(max_moves)
        self.tolerance_px = float(tolerance_px)
        self.render_mode = render_mode
        self.render_scale = int(render_scale)
        self._layout = _Layout(stage, self._arm.image_size, self._arm.joints, tolerance_px, max_moves)
        self.observation_space = self._layout.observation_space
        self.action_space = self._layout.action_space
        self.frames = bool(frames)
        self.frame_scale = int(frame_scale)
        if self.frames:
            if not 1 <= self.frame_scale <= 16:
                raise ValueError(f"frame_scale is 1 to 16, got {frame_scale!r}")
            w, h = self._arm.image_size
            shape = (2, 2 if stage == 1 else 1, h // self.frame_scale, w // self.frame_scale)
            self.observation_space = spaces.Dict(
                {**self.observation_space.spaces, "frames": spaces.Box(0, 255, shape, dtype=np.uint8)}
            )
        self._live = None

    def _obs(self):
        obs = self._layout.obs(*self._arm.observation_clipped(self._layout.bounds))
        if self.frames:
            obs["frames"] = self.camera_frames()
        return obs

    def camera_frames(self):
        """The cameras' frames of the arm's lights now (see ``frames``), whatever the
        options: uint8, (2, F, H, W)."""
        w, h, n, data = self._arm.frames(self.frame_scale)
        return np.frombuffer(data, dtype=np.uint8).reshape(2, n, h, w).copy()

    def _info(self):
        return _Layout.info(self._arm.info())

    def reset(self, *, seed=None, options=None):
        """A new held-out target and start pose; reproducible from ``seed``."""
        super().reset(seed=seed)
        self._arm.reset(_arm_seed(self.np_random))
        if self._build_next:
            self._build_ahead()
        obs, info = self._obs(), self._info()
        if self.render_mode == "human":
            self._show(obs, info, reward=None)
        return obs, info

    def _build_ahead(self):
        """Has the native side build the episode that the next reset without a seed gives
        (``Arm.prepare``), in the cores' idle time: its seed drawn from ``np_random``, whose
        state is then put back as it was, so that the draws are the same as without."""
        bits = self.np_random.bit_generator
        state = bits.state
        seed = _arm_seed(self.np_random)
        bits.state = state
        self._arm.prepare(seed)

    def step(self, action):
        """One move: command ``action`` (clipped to [-1, 1]), read the cameras."""
        action = np.asarray(action, dtype=np.float32).reshape(self.action_space.shape)
        self._arm.step(action.tolist())
        obs, info = self._obs(), self._info()
        reward, terminated, truncated = self._arm.outcome(*self._layout.rule)
        if self.render_mode == "human":
            self._show(obs, info, reward)
        return obs, reward, terminated, truncated, info

    def render(self):
        """``rgb_array``: both camera images side by side (H x W x 3, uint8): the arm's
        links, the lights as read (red), the target (green rings); with ``frames``, the
        camera frames instead (gray). ``human``: the live view
        (rerun) is updated by every reset and step; nothing is returned."""
        if self.render_mode == "rgb_array":
            if self.frames:
                # each camera's frames overlaid (every light shows), the cameras side by side
                both = self.camera_frames().max(axis=1)
                return np.repeat(np.concatenate(list(both), axis=1)[:, :, None], 3, axis=2)
            return self.camera_images()
        return None

    def camera_images(self):
        """Both camera images side by side (H x W x 3, uint8), whatever the render mode."""
        w, h, data = self._arm.render(self.render_scale)
        return np.frombuffer(bytes(data), dtype=np.uint8).reshape(h, w, 3).copy()

    def geometry(self):
        """The scene in 3-D (mm): the arm's joints from the base to the gripper centre, its
        lights, the target's, the cameras."""
        return {k: np.asarray(v, dtype=np.float64) for k, v in self._arm.geometry().items()}

    def _show(self, obs, info, reward):
        if self._live is None:
            from .live import LiveView

            self._live = LiveView("trn_softarm SoftArmEnv", spawn=True)
        self._live.env_step(self, obs, info, reward)

    def close(self):
        self._live = None

    def __getstate__(self):
        # the arm pickles its whole state; a live view is a connection, not state
        state = self.__dict__.copy()
        state["_live"] = None
        return state


class SoftArmVectorEnv(VectorEnv):
    """``num_envs`` arms stepped in one call, in parallel with the GIL released (the
    ``vector_entry_point`` of ``trn_softarm/SoftArm-v0``: ``gym.make_vec(id, num_envs=N)``).

    Arm ``i`` behaves as ``SoftArmEnv(**kwargs)`` would in ``SyncVectorEnv`` with the same
    seeds (``reset(seed=s)`` seeds arm ``i`` with ``s + i``); an arm whose episode ended is
    reset by the next ``step`` (``AutoresetMode.NEXT_STEP``: its reward is 0, its
    observation and info those of the reset). Takes the arguments of :class:`SoftArmEnv`
    except the rendering ones and ``frames``.
    """

    metadata = {"autoreset_mode": AutoresetMode.NEXT_STEP, "render_modes": []}

    def __init__(
        self,
        num_envs=2,
        stage=1,
        config="realistic",
        max_moves=20,
        tolerance_px=2.0,
        dt_s=None,
        persistent=False,
        randomise=0.0,
        render_mode=None,
        frames=False,
        build_ahead=True,
    ):
        if render_mode is not None:
            raise ValueError("the native vector environment does not render; use SoftArmEnv")
        if frames:
            raise ValueError(
                "the native vector environment observes the lights only; for frames use SoftArmEnv"
                " (vectorised with gymnasium's SyncVectorEnv or AsyncVectorEnv)"
            )
        self._arms = ArmVec(int(num_envs), config, stage, dt_s, bool(persistent), float(randomise))
        self.num_envs = int(num_envs)
        one = Arm(config, stage, dt_s)
        self._layout = _Layout(stage, one.image_size, one.joints, tolerance_px, max_moves)
        self.single_observation_space = self._layout.observation_space
        self.single_action_space = self._layout.action_space
        self.observation_space = batch_space(self.single_observation_space, self.num_envs)
        self.action_space = batch_space(self.single_action_space, self.num_envs)
        self.render_mode = None
        self._rngs = [None] * self.num_envs
        # each arm's next seed, drawn ahead (see _build_ahead)
        self._ahead = [None] * self.num_envs
        self._autoreset = np.zeros(self.num_envs, dtype=np.bool_)
        self._build_next = bool(build_ahead)
        self._infos = _InfoBatch(self._arms.info_layout, self.num_envs)

    def _seed_for(self, i, seed=None):
        if seed is not None or self._rngs[i] is None:
            self._rngs[i], _ = seeding.np_random(seed)
            self._ahead[i] = None
        if self._ahead[i] is not None:
            drawn, self._ahead[i] = self._ahead[i], None
            return drawn
        return _arm_seed(self._rngs[i])

    def _build_ahead(self, arms):
        """Draws the seed of each arm's next reset now (nothing else draws from an arm's
        generator, so it is the seed that reset would draw) and has the native side build
        that episode meanwhile, in the cores' idle time."""
        if not self._build_next:
            return
        for i in arms:
            self._ahead[i] = _arm_seed(self._rngs[i])
            self._arms.prepare(int(i), self._ahead[i])

    def _obs(self):
        return self._layout.obs(*self._arms.observation_batch(self._layout.bounds), self.num_envs)

    def reset(self, *, seed=None, options=None):
        """Resets every arm (or those of ``options["reset_mask"]``); ``seed``: an int (arm
        ``i`` gets ``seed + i``), a list of ints or Nones, or None."""
        if seed is None or isinstance(seed, (int, np.integer)):
            seeds = [None if seed is None else int(seed) + i for i in range(self.num_envs)]
        else:
            seeds = list(seed)
            if len(seeds) != self.num_envs:
                raise ValueError(f"{len(seeds)} seeds for {self.num_envs} environments")
        mask = np.ones(self.num_envs, dtype=np.bool_)
        if options and "reset_mask" in options:
            mask = np.asarray(options["reset_mask"], dtype=np.bool_)
        arm_seeds = [self._seed_for(i, seeds[i]) if mask[i] else None for i in range(self.num_envs)]
        self._arms.run(arm_seeds, [None] * self.num_envs)
        self._build_ahead(np.flatnonzero(mask))
        infos = {}
        for i in np.flatnonzero(mask):
            infos = self._add_info(infos, _Layout.info(self._arms.info(int(i))), int(i))
        self._autoreset[mask] = False
        return self._obs(), infos

    def step(self, actions):
        """One move of every arm (or the reset of an arm whose episode ended)."""
        actions = np.ascontiguousarray(actions, dtype=np.float32).reshape(self.action_space.shape)
        seeds = None
        if self._autoreset.any():
            resetting = self._autoreset.tolist()
            seeds = [self._seed_for(i) if r else None for i, r in enumerate(resetting)]
        # one native call: the moves (and resets), the observations, the infos' buffers, and
        # the rewards and ends (an arm reset by this step has reward 0 and goes on)
        *obs, floats, flags, counts, first_none, rewards, ends = self._arms.step_batch(
            seeds, actions.tobytes(), self._layout.bounds, *self._layout.rule
        )
        if seeds is not None:
            self._build_ahead([i for i, s in enumerate(seeds) if s is not None])
        infos = self._infos(floats, flags, counts, first_none)
        ends = np.frombuffer(ends, dtype=np.bool_)
        terminated, truncated = ends[: self.num_envs], ends[self.num_envs :]
        self._autoreset = terminated | truncated
        rewards = np.frombuffer(rewards, dtype=np.float64)
        return self._layout.obs(*obs, self.num_envs), rewards, terminated, truncated, infos


class FlatObservation(gym.ObservationWrapper):
    """The observation as one float32 vector, for learners that take a ``Box`` (SB3's
    ``VecNormalize`` with its defaults, MLP policies): ``lights`` (n x 2, row by row), then
    ``target`` (n x 2), then each light's status one-hot (n x 5, in the order of
    ``STATUS``). Stage 1: 8 + 8 + 20 = 36 values; stage 2: 4 + 4 + 10 = 18."""

    def __init__(self, env):
        super().__init__(env)
        d = env.observation_space
        self._n = d["lights"].shape[0]
        k = len(STATUS)
        low = np.concatenate([d["lights"].low.ravel(), d["target"].low.ravel(), np.zeros(self._n * k, np.float32)])
        high = np.concatenate([d["lights"].high.ravel(), d["target"].high.ravel(), np.ones(self._n * k, np.float32)])
        self.observation_space = spaces.Box(low, high, dtype=np.float32)

    def observation(self, obs):
        onehot = np.zeros((self._n, len(STATUS)), dtype=np.float32)
        onehot[np.arange(self._n), obs["status"]] = 1.0
        return np.concatenate([obs["lights"].ravel(), obs["target"].ravel(), onehot.ravel()]).astype(np.float32)
