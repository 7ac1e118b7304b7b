"""SoftArmEnv: reaching with the simulated SoftArm, as a Gymnasium environment.

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
the camera processor, not read), ``target`` (the
target's lights as measured, the same rows). The reward is minus the measured error (pixels:
the distance of ``lights`` to ``target``), or minus the image diagonal when a light is not
read. An episode terminates within ``tolerance_px`` and is truncated after ``max_moves``.
``info`` has the noise-free truth: ``lights_true``, ``target_true``, ``error_true_px``,
``pose_error_mm``/``_deg``, the commanded pressures, the joint angles, the simulated time.
"""

import numpy as np
import gymnasium as gym
from gymnasium import spaces

from ._native import Arm

STATUS = ("valid", "out of view", "occluded", "not detected", "estimated")


class SoftArmEnv(gym.Env):
    """The simulated SoftArm reaching a held-out target (see the module)."""

    metadata = {"render_modes": ["rgb_array", "human"], "render_fps": 2}

    def __init__(
        self,
        stage=1,
        config="realistic",
        max_moves=20,
        tolerance_px=2.0,
        render_mode=None,
        render_scale=2,
    ):
        """``config``: ``realistic`` (the project's default plant), ``ideal``, ``aging`` or a
        TOML file of the simulator's configuration; ``render_scale``: each camera image is
        drawn at 1/scale of its resolution."""
        if render_mode is not None and render_mode not in self.metadata["render_modes"]:
            raise ValueError(f"render_mode {render_mode!r} is not one of {self.metadata['render_modes']}")
        self._arm = Arm(config, stage)
        self.stage = stage
        self.config = config
        self.max_moves = int(max_moves)
        self.tolerance_px = float(tolerance_px)
        self.render_mode = render_mode
        self.render_scale = int(render_scale)
        n = 4 if stage == 1 else 2
        w, h = self._arm.image_size
        # readings lie in the image; a centroid's noise may carry one a little beyond it
        margin = 16.0
        low = np.tile(np.array([-margin, -margin], dtype=np.float32), (n, 1))
        high = np.tile(np.array([w + margin, h + margin], dtype=np.float32), (n, 1))
        self.observation_space = spaces.Dict(
            {
                "lights": spaces.Box(low, high, dtype=np.float32),
                "status": spaces.MultiDiscrete(np.full(n, len(STATUS))),
                "target": spaces.Box(low, high, dtype=np.float32),
            }
        )
        self.action_space = spaces.Box(-1.0, 1.0, shape=(self._arm.joints,), dtype=np.float32)
        self._diagonal = float(np.hypot(w, h))
        self._live = None
        self._low, self._high = low, high

    def _obs(self):
        lights, status, target = self._arm.observation()
        n = len(status)
        clip = lambda v: np.clip(np.asarray(v, dtype=np.float32).reshape(n, 2), self._low, self._high)
        return {
            "lights": clip(lights),
            "status": np.array(list(status), dtype=np.int64),
            "target": clip(target),
        }

    def _info(self):
        info = self._arm.info()
        n = len(info["lights_true"]) // 2
        info["lights_true"] = np.asarray(info["lights_true"], dtype=np.float64).reshape(n, 2)
        info["target_true"] = np.asarray(info["target_true"], dtype=np.float64).reshape(n, 2)
        for k in ("lights_true_in_view", "pressures", "joint_angles_deg", "gripper_mm", "target_gripper_mm"):
            info[k] = np.asarray(info[k])
        return info

    def reset(self, *, seed=None, options=None):
        """A new held-out target and start pose; reproducible from ``seed``."""
        super().reset(seed=seed)
        self._arm.reset(int(self.np_random.integers(0, 2**63 - 1)))
        obs, info = self._obs(), self._info()
        if self.render_mode == "human":
            self._show(obs, info, reward=None)
        return obs, info

    def step(self, action):
        """One move: command ``action`` (clipped to [-1, 1]), read the cameras."""
        action = np.asarray(action, dtype=np.float32).reshape(self.action_space.shape)
        self._arm.step(action.tolist())
        obs, info = self._obs(), self._info()
        err = info["error_px"]
        reward = -float(err) if err is not None else -self._diagonal
        terminated = err is not None and err <= self.tolerance_px
        truncated = not terminated and info["moves"] >= self.max_moves
        if self.render_mode == "human":
            self._show(obs, info, reward)
        return obs, reward, terminated, truncated, info

    def render(self):
        """``rgb_array``: both camera images side by side (H x W x 3, uint8): the arm's
        links, the lights as read (red), the target (green rings). ``human``: the live view
        (rerun) is updated by every reset and step; nothing is returned."""
        if self.render_mode == "rgb_array":
            return self.camera_images()
        if self.render_mode == "human":
            return None
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
