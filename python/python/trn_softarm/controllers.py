"""The project's controllers on numpy arrays: the TRN (Sarkar & Schulten) and the Broyden
servo (uncalibrated visual servoing), the same Rust code the CAN node and the firmware run;
and the learning-free references the lab compares them with, the same Rust code as its
``--controller model`` and ``--controller oracle``: the calibrated model (the arm's links,
cameras and pressure curves without hysteresis, drift or wear; inverse kinematics, then
Gauss-Newton steps) and the oracle (it solves on an exact copy of the arm as it is at each
decision: the physical limit). These two are models of one environment's arm: they are
made with ``env=``.

A controller works in trials: ``act(obs)`` at the start of an episode gives the coarse move
towards ``obs["target"]``; each later ``act(obs)`` passes the reading after the last move
and gives the next (fine) move, until the controller's trial is done (``done``: within its
tolerance, at its cap of fine moves, or after ``fine_moves`` moves when a budget is set).
With ``learn=True`` the TRN updates its tables from every move (training); with
``learn=False`` it only acts (evaluation). ``reset()`` starts a new trial.
"""

import numpy as np

from ._native import Ctrl


class Controller:
    """A controller for one stage of the SoftArmEnv (see the module)."""

    def __init__(self, law="trn", stage=None, preset="project", ablation="none", seed=0, image=(1024, 768), env=None):
        """``law``: ``trn``, ``broyden``, ``model`` or ``oracle``; ``preset``: ``project``,
        ``paper`` or ``lifelong``; ``ablation``: ``none``, ``no-neighbourhood``,
        ``no-priming``, ``no-fine``, ``no-trial-secant``; ``seed``: the initial tables.
        ``stage``: 1 or 2 (default: the environment's, else 1). ``env``: the SoftArmEnv
        whose arm ``model`` and ``oracle`` model (the image size is then the environment's;
        the model and the oracle use the TRN's stop rule of ``preset``)."""
        self._arm = None
        if env is not None:
            env = getattr(env, "unwrapped", env)
            self._arm = getattr(env, "_arm", None)
            if self._arm is None:
                raise ValueError("env: a SoftArmEnv (the native vector environment has no single arm)")
            if stage not in (None, env.stage):
                raise ValueError(f"stage {stage}: the environment is of stage {env.stage}")
            stage, image = env.stage, tuple(self._arm.image_size)
        elif law in ("model", "oracle"):
            raise ValueError(f"law {law!r} is a model of an environment's arm: pass env=")
        stage = 1 if stage is None else stage
        if stage not in (1, 2):
            raise ValueError("stage is 1 or 2")
        self._ctrl = Ctrl(law, preset, ablation, int(seed), tuple(image), self._arm)
        # the oracle reads the arm at each decision
        self._look = self._arm if law == "oracle" else None
        self.stage = stage
        self.law = law
        self.joints = 5 if stage == 1 else 3
        self.reset()

    @property
    def tolerance_px(self):
        """The error (pixels) within which a trial that does not learn stops: the
        configuration's mature tolerance for this controller's stage."""
        return self._ctrl.mature_tolerance_px(self.stage)

    def reset(self):
        """Starts a new trial at the next ``act``."""
        self._ctrl.abort()
        self._pressures = None
        self.done = False
        self.outcome = None

    def act(self, obs, learn=True, fine_moves=None, supervised=None):
        """The next pressures (``joints`` values) for the reading ``obs`` (the environment's
        observation dict). ``supervised``: the target's pressures, for the TRN's supervised
        priming. A reading with a light not read ends the trial, as the CAN node ends it
        (nothing is learned from that move); so does an estimated light (status 4: placed by
        the camera processor) in a trial that learns, since the tables would take the
        estimate's error for the arm's; a trial that does not learn moves on with it. Then,
        and after ``done``, the last pressures are held."""
        status = np.asarray(obs["status"])
        if self.done:
            return self._hold()
        if self._pressures is None:
            target = np.asarray(obs["target"], dtype=np.float32).ravel()
            sup = None if supervised is None else np.asarray(supervised, dtype=np.float32).ravel().tolist()
            self._learns = bool(learn)
            what, value = self._ctrl.begin(self.stage, target.tolist(), bool(learn), fine_moves, sup, self._look)
        elif np.any((status != 0) & ((status != 4) | self._learns)):
            self._ctrl.abort()
            self.done, self.outcome = True, {"aborted": "a light was not read"}
            return self._hold()
        else:
            reading = np.asarray(obs["lights"], dtype=np.float32).ravel()
            what, value = self._ctrl.observe(reading.tolist(), self._look)
        if what == "move":
            self._pressures = np.asarray(value, dtype=np.float32)
        else:
            self.done, self.outcome = True, value
        return self._hold()

    def _hold(self):
        if self._pressures is None:
            return np.zeros(self.joints, dtype=np.float32)
        return self._pressures.copy()


def run_episode(env, policy, seed=None, **act):
    """One episode of ``env`` with ``policy`` (a :class:`Controller`, or any callable from an
    observation to an action) until it terminates, is truncated or the controller is done;
    returns the ``info`` of every step after the reset's (each with ``error_px``)."""
    obs, info = env.reset(seed=seed)
    if isinstance(policy, Controller):
        policy.reset()
    infos = []
    while True:
        if isinstance(policy, Controller):
            action = policy.act(obs, **act)
            if policy.done:
                break
        else:
            action = policy(obs)
        obs, _, terminated, truncated, info = env.step(action)
        infos.append(info)
        if terminated or truncated:
            # a controller still moving sees its last reading (it learns from the move)
            if isinstance(policy, Controller) and not policy.done:
                policy.act(obs, **act)
            break
    return infos
