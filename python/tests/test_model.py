"""The arm's URDF and MJCF (``trn_softarm.arm_model``) read by MuJoCo's own loaders, their
forward kinematics against the plant's (``trn_softarm.arm_frames``) at 1,000 seeded random
joint configurations: every frame within 0.1 mm, the gripper's axes within 1e-6; the URDF
read by rerun's own URDF loader (what ``rerun softarm.urdf`` shows).

The MuJoCo tests are skipped when MuJoCo is not installed, the rerun one without the rerun
SDK (``pip install mujoco``; scripts/python-package.sh
installs it).

    pytest python/tests/test_model.py
"""

import json
import math
import pathlib
import re

import numpy as np
import pytest

import trn_softarm
from trn_softarm import model as model_command

try:
    import mujoco
except ImportError:
    mujoco = None

needs_mujoco = pytest.mark.skipif(mujoco is None, reason="MuJoCo is not installed (pip install mujoco)")

try:
    import rerun
    from rerun.recording import load_recording
except ImportError:
    rerun = None

needs_rerun = pytest.mark.skipif(rerun is None, reason="the rerun SDK is not installed (the [live] extra)")

FRAMES = ["upper_arm", "forearm", "wrist", "gripper_centre", "light_p", "light_q"]
JOINTS = ["base", "shoulder", "elbow", "wrist_pitch", "wrist_roll"]
SIM_TOML = pathlib.Path(__file__).resolve().parents[2] / "host" / "plant" / "sim.toml"


def random_angles(config, n, seed):
    """`n` plant joint-angle vectors (radians), each joint uniform over its configured range
    widened by 10 degrees either way (overshoot and drift leave the range)."""
    joints = json.loads(trn_softarm.config_json(config))["joints"]
    lo = np.radians([min(j["min_deg"], j["max_deg"]) - 10.0 for j in joints])
    hi = np.radians([max(j["min_deg"], j["max_deg"]) + 10.0 for j in joints])
    return np.random.default_rng(seed).uniform(lo, hi, size=(n, 5))


def description_angles(q):
    """The differential wrist: joints A and B as the gripper's pitch and roll."""
    return [q[0], q[1], q[2], 0.5 * (q[3] + q[4]), 0.5 * (q[3] - q[4])]


class Described:
    """A description loaded by MuJoCo, posed at plant angles: its frames (mm) and the
    gripper centre's axes."""

    def __init__(self, text):
        self.model = mujoco.MjModel.from_xml_string(text)
        self.data = mujoco.MjData(self.model)
        self.adr = [self.model.joint(n).qposadr[0] for n in JOINTS]

    def pose(self, q):
        self.data.qpos[:] = 0.0
        self.data.qpos[self.adr] = description_angles(q)
        mujoco.mj_kinematics(self.model, self.data)

    def frame(self, name):
        """(origin in mm, axes as columns): a body of the URDF, else a site of the MJCF."""
        try:
            b = self.model.body(name).id
            return 1000.0 * self.data.xpos[b], self.data.xmat[b].reshape(3, 3)
        except KeyError:
            s = self.model.site(name).id
            return 1000.0 * self.data.site_xpos[s], self.data.site_xmat[s].reshape(3, 3)


def worst_errors(text, config, n=1000, seed=39):
    """The largest position error (mm) of any frame and axis error of the gripper over `n`
    random configurations."""
    d = Described(text)
    worst_mm, worst_axis = 0.0, 0.0
    for q in random_angles(config, n, seed):
        want = trn_softarm.arm_frames(list(q), config)
        d.pose(q)
        for name in FRAMES:
            got, _ = d.frame(name)
            worst_mm = max(worst_mm, float(np.linalg.norm(got - want[name])))
        _, axes = d.frame("gripper_centre")
        for col, name in enumerate(["approach", "finger_axis", "normal"]):
            worst_axis = max(worst_axis, float(np.linalg.norm(axes[:, col] - want[name])))
    return worst_mm, worst_axis


def odd_config(tmp_path):
    """sim.toml with every length changed (a length written from the wrong key shows)."""
    text = SIM_TOML.read_text()
    for key, value in [
        ("shoulder_height_mm", 310.0),
        ("upper_arm_mm", 455.0),
        ("forearm_mm", 377.0),
        ("hand_mm", 123.0),
        ("light_offset_mm", 61.0),
    ]:
        text, n = re.subn(rf"(?m)^{key} = .*$", f"{key} = {value}", text)
        assert n == 1, key
    path = tmp_path / "odd.toml"
    path.write_text(text)
    return str(path)


@needs_mujoco
@pytest.mark.parametrize("fmt", ["urdf", "mjcf"])
@pytest.mark.parametrize("config", ["realistic", "odd"])
def test_mujoco_forward_kinematics_match_the_plants(fmt, config, tmp_path):
    if config == "odd":
        if not SIM_TOML.exists():
            pytest.skip("sim.toml is the repository's (not in the wheel)")
        config = odd_config(tmp_path)
    worst_mm, worst_axis = worst_errors(trn_softarm.arm_model(config, fmt), config)
    print(f"{fmt} {pathlib.Path(config).name}: worst frame {worst_mm:.2e} mm, axis {worst_axis:.2e}")
    assert worst_mm < 0.1
    assert worst_axis < 1e-6


@needs_mujoco
def test_a_wrong_description_is_caught():
    """The check trips on a description one sign off (the roll axis reversed)."""
    text = trn_softarm.arm_model("realistic", "urdf")
    wrong = text.replace('<axis xyz="1 0 0"/>', '<axis xyz="-1 0 0"/>')
    assert wrong != text
    worst_mm, _ = worst_errors(wrong, "realistic", n=50)
    assert worst_mm > 1.0


@needs_mujoco
def test_urdf_keeps_the_led_frames_and_limits():
    m = mujoco.MjModel.from_xml_string(trn_softarm.arm_model("realistic", "urdf"))
    for name in ["gripper_centre", "light_p", "light_q"]:
        assert m.body(name).id > 0
    joints = json.loads(trn_softarm.config_json("realistic"))["joints"]
    lo, hi = m.joint("shoulder").range
    assert math.isclose(math.degrees(lo), joints[1]["min_deg"])
    assert math.isclose(math.degrees(hi), joints[1]["max_deg"])
    # the wrist's pitch spans (A + B) / 2
    lo, hi = m.joint("wrist_pitch").range
    assert math.isclose(math.degrees(hi), 0.5 * (joints[3]["max_deg"] + joints[4]["max_deg"]))


@needs_mujoco
def test_mjcf_cameras_are_the_plants():
    config = json.loads(trn_softarm.config_json("realistic"))
    m = mujoco.MjModel.from_xml_string(trn_softarm.arm_model("realistic", "mjcf"))
    d = mujoco.MjData(m)
    mujoco.mj_kinematics(m, d)
    mujoco.mj_camlight(m, d)
    for i, cam in enumerate(config["cameras"]):
        c = m.camera(f"camera_{i}").id
        pos = np.array(cam["position_mm"]) / 1000.0
        np.testing.assert_allclose(d.cam_xpos[c], pos, atol=1e-9)
        # MuJoCo's camera looks along its -z
        look = -d.cam_xmat[c].reshape(3, 3)[:, 2]
        want = np.array(cam["look_at_mm"]) / 1000.0 - pos
        np.testing.assert_allclose(look, want / np.linalg.norm(want), atol=1e-9)
        fovy = 2 * math.degrees(math.atan(0.5 * cam["resolution"][1] / cam["focal_px"]))
        assert math.isclose(m.cam_fovy[c], fovy)


def test_bad_requests_are_refused():
    with pytest.raises(ValueError):
        trn_softarm.arm_model("realistic", "sdf")
    with pytest.raises(ValueError):
        trn_softarm.arm_model("no-such-plant")
    with pytest.raises(ValueError):
        trn_softarm.arm_frames([0.0] * 4)
    with pytest.raises(ValueError):
        trn_softarm.arm_frames([0.0, 0.0, float("nan"), 0.0, 0.0])


def test_the_command_writes_the_description(tmp_path, capsys):
    out = tmp_path / "arm.xml"
    assert model_command.main(["--config", "ideal", "--format", "mjcf", "--out", str(out)]) == 0
    assert out.read_text() == trn_softarm.arm_model("ideal", "mjcf")
    assert model_command.main(["--config", "ideal"]) == 0
    assert capsys.readouterr().out == trn_softarm.arm_model("ideal", "urdf")
    with pytest.raises(SystemExit) as e:
        model_command.main(["--config", str(tmp_path / "missing.toml")])
    assert e.value.code == 1


@needs_rerun
def test_rerun_loads_the_urdf(tmp_path):
    """rerun's URDF loader reads every link and joint, the links' cylinders and the LEDs'
    spheres."""
    urdf = tmp_path / "softarm.urdf"
    urdf.write_text(trn_softarm.arm_model("realistic", "urdf"))
    rec = rerun.RecordingStream("trn_softarm_urdf_test")
    rec.save(str(tmp_path / "arm.rrd"))
    rec.log_file_from_path(urdf, static=True)
    rec.flush()
    rec.disconnect()
    columns = [(str(c.entity_path), str(c.component)) for c in load_recording(str(tmp_path / "arm.rrd")).schema().component_columns()]
    leaves = {e.rsplit("/", 1)[-1] for e, _ in columns}
    for name in ["base_link", "turntable", "upper_arm", "forearm", "wrist", "hand", *FRAMES[3:], *JOINTS]:
        assert name in leaves, (name, sorted(leaves))
    for link in ["light_p", "light_q"]:
        assert any(e.endswith(f"/{link}/visual_0") and "Ellipsoids3D" in c for e, c in columns), link
    cylinders = {e.split("/")[-2] for e, c in columns if "Cylinders3D" in c}
    assert cylinders == {"turntable", "upper_arm", "forearm", "hand"}, cylinders
