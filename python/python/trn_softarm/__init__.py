"""trn_softarm: the TRN soft-arm project from Python.

- :class:`SoftArmEnv`: a Gymnasium environment of the simulated SoftArm (registered as
  ``trn_softarm/SoftArm-v0``; ``gym.make_vec`` gives its native vector form,
  :class:`SoftArmVectorEnv`), :class:`FlatObservation` (its observation as one vector).
- :class:`Controller`: the project's controllers (the TRN, the Broyden servo; the
  calibrated model and the oracle of an environment's arm) on numpy arrays, to compare an
  agent with.
- :func:`decode_candump`, :func:`decode_frames`: the CAN protocol's frames and candump logs
  as messages, segmented ones included, through the Rust decoder.
- :func:`arm_model`: the arm as URDF or MuJoCo's MJCF (``python -m trn_softarm.model``
  writes it); :func:`arm_frames`: the plant's forward kinematics, to check it by.

The simulation, the controllers and the decoder are the project's Rust crates
(``trn_softarm._native``); this package adds numpy arrays, Gymnasium and the live view.
"""

from ._native import __version__, arm_frames, arm_model, config_json
from .controllers import Controller, run_episode
from .protocol import Listener, decode_candump, decode_frames

__all__ = [
    "__version__",
    "SoftArmEnv",
    "SoftArmVectorEnv",
    "FlatObservation",
    "Controller",
    "run_episode",
    "decode_candump",
    "decode_frames",
    "Listener",
    "config_json",
    "arm_model",
    "arm_frames",
    "register_envs",
]

ENV_ID = "trn_softarm/SoftArm-v0"


def register_envs():
    """Registers ``trn_softarm/SoftArm-v0`` with Gymnasium (done on import when Gymnasium
    is installed)."""
    import gymnasium

    if ENV_ID not in gymnasium.registry:
        gymnasium.register(
            id=ENV_ID,
            entry_point="trn_softarm.env:SoftArmEnv",
            vector_entry_point="trn_softarm.env:SoftArmVectorEnv",
        )


def __getattr__(name):
    # the environment needs Gymnasium: imported when asked for, so the decoder and the
    # controllers work without it
    if name in ("SoftArmEnv", "SoftArmVectorEnv", "FlatObservation"):
        from . import env

        return getattr(env, name)
    raise AttributeError(f"module 'trn_softarm' has no attribute {name!r}")


try:
    register_envs()
except ImportError:
    pass
