"""The live view's recording as the viewer opens it: a run's events (as ``trn train
--rerun-save`` sends them) and an environment's steps, saved to a file in a temporary folder
and read back with rerun's own reader and its ``rerun rrd print``: every entity on the
timelines ``trial`` and ``move``, each move on ``sim_time`` too, and the blueprint (the arm in
3-D, one view a camera framed on its image, the errors, the log, the time panel on ``move``).

Skipped without the rerun SDK (the [live] extra).

    pytest python/tests/test_live.py
"""

import io
import json
import subprocess
import time
import sys

import numpy as np
import pytest

try:
    import rerun
    from rerun.recording import load_recording

    from trn_softarm import live
except ImportError:
    rerun = None

from trn_softarm import SoftArmEnv

needs_rerun = pytest.mark.skipif(rerun is None, reason="the rerun SDK is not installed (the [live] extra)")

LINKS = [[0, 0, 0], [0, 0, 400], [380, 50, 560], [540, 70, 200], [610, 80, 60]]
LIGHTS = [[655, 93, 80], [572, 62, 33]]


CYLINDER = {"centre": [600.0, 80.0, 40.0], "axis": [0.0, 1.0, 0.0], "radius": 20.0, "length": 120.0}


def run_events(cameras=None):
    """A short run's events, shaped as host/cli/src/live.rs sends them: two training trials
    (stage 1: four rows a reading, one light not read; stage 2: two rows), an evaluation and
    a grasp; the start gives the ``cameras`` (as pinholes) when given."""

    def move(t, seen, err):
        return {"time_s": t, "links": LINKS, "lights": LIGHTS, "seen": seen, "target": [500.0] * len(seen),
                "measured_px": err, "true_px": err - 0.5}

    stage1 = [510.0, 520.0, None, None, 530.0, 540.0, 550.0, 560.0]
    start = {"event": "start", "trials": 4, "title": "trn train"}
    if cameras is not None:
        start["cameras"] = cameras
    return [
        start,
        {"event": "phase", "name": "training"},
        {"event": "trial", "trial": 1, "phase": "training", "moves": [move(4.8, stage1, 30.0), move(6.0, stage1, 12.0)],
         "target_lights": LIGHTS, "stage1_final_px": 12.0, "stage2_final_px": None, "failure": None},
        {"event": "trial", "trial": 2, "phase": "training", "moves": [move(10.8, [505.0, 515.0, 525.0, 535.0], 8.0)],
         "target_lights": LIGHTS, "stage1_final_px": None, "stage2_final_px": 8.0, "failure": None},
        {"event": "message", "text": "combined error (last 20) 10.00 px"},
        {"event": "phase", "name": "evaluation"},
        {"event": "trial", "trial": 3, "phase": "evaluation", "moves": [move(16.8, stage1, 40.0)],
         "target_lights": None, "stage1_final_px": 40.0, "stage2_final_px": None, "failure": "no convergence"},
        {"event": "phase", "name": "grasping"},
        {"event": "trial", "trial": 4, "phase": "grasping", "moves": [move(22.8, [505.0, 515.0, 525.0, 535.0], 2.0)],
         "target_lights": None, "stage1_final_px": None, "stage2_final_px": 2.0, "failure": None,
         "cylinder": CYLINDER, "grasp": {"distance_mm": 3.5, "perpendicular_error_deg": 4.0, "success": True}},
        {"event": "finish"},
    ]


def blueprint_of(path):
    """The blueprint a recording carries, from ``rerun rrd print``: its views as
    (kind, origin), the 2-D views' visual bounds, the time panel's timeline."""
    out = subprocess.run(
        [sys.executable, "-m", "rerun_cli", "rrd", "print", "-vvv", str(path)],
        capture_output=True, text=True, check=True,
    ).stdout
    rows, entity = {}, None
    for line in out.splitlines():
        if line.startswith("Chunk("):
            entity = line.split(" - ")[1].strip()
        elif "row_" in line and entity is not None:
            cells = [c.strip(" │") for c in line.split("┆")]
            rows.setdefault(entity, []).append(cells)
    views = {(r[-3], r[-1]) for e, rs in rows.items() if e.count("/") == 2 and e.startswith("/view/") for r in rs}
    bounds = [r[-1] for e, rs in rows.items() if e.endswith("/VisualBounds2D") for r in rs]
    timeline = [r[-1] for r in rows.get("/time_panel", [])]
    return views, bounds, timeline


def assert_on_the_timelines(rec, entities):
    """Each of ``entities`` has rows, each row on ``trial`` and ``move``: the entities logged
    one call a row (the log, a trial's figures) by their log tick, those sent as a move's
    columns (which have no log tick) by ``sim_time``, which every move here has."""
    assert {"trial", "move", "sim_time"} <= {c.name for c in rec.schema().index_columns()}
    for e in entities:
        table = rec.view(index="log_tick", contents=e).select().read_all()
        if table.num_rows == 0:
            table = rec.view(index="sim_time", contents=e).select().read_all()
        assert table.num_rows > 0, e
        for timeline in ("trial", "move"):
            assert table.column(timeline).null_count == 0, (e, timeline)


@needs_rerun
def test_a_runs_recording_has_its_blueprint_and_timelines(tmp_path, monkeypatch):
    path = tmp_path / "run.rrd"
    monkeypatch.setattr(sys, "stdin", io.StringIO("".join(json.dumps(e) + "\n" for e in run_events())))
    assert live.main(["--save", str(path)]) == 0

    rec = load_recording(str(path))
    entities = {str(c.entity_path) for c in rec.schema().component_columns()}
    for e in ("/world/arm/links", "/world/cameras", "/world/camera_0", "/world/camera_0/image",
              "/world/camera_1/lights", "/curve/stage1_px",
              "/eval/evaluation/stage1_px", "/log"):
        assert e in entities, sorted(entities)
    assert_on_the_timelines(
        rec, ["/log", "/world/arm/links", "/world/camera_0/lights", "/error/measured_px", "/curve/stage2_px"]
    )
    moves = rec.view(index="sim_time", contents="/error/measured_px").select().read_all()
    assert moves.num_rows == 5
    # each camera's rows of a reading (stage 1: p and q, stage 2: the centre), the light not
    # read (camera 1's p in stage 1) left out; the colour is the entity's, logged once
    for cam, counts in [(0, [2, 2, 1, 2, 1]), (1, [1, 1, 1, 1, 1])]:
        lights = rec.view(index="move", contents=f"/world/camera_{cam}/lights").select().read_all()
        assert [len(p) for p in lights.column(f"/world/camera_{cam}/lights:Points2D:positions").to_pylist()] == counts
    r, g, b = live.LIGHT
    assert lights.column("/world/camera_1/lights:Points2D:colors").to_pylist()[0] == [r << 24 | g << 16 | b << 8 | 255]

    views, bounds, timeline = blueprint_of(path)
    assert {("[3D]", "[world]"), ("[2D]", "[world/camera_0]"), ("[2D]", "[world/camera_1]"), ("[TimeSeries]", "[error]"),
            ("[TextLog]", "[log]")} <= views, views
    assert bounds == ["[{x_range: [0.0, 1024.0], y_range: [0.0, 768.0]}]"] * 2, bounds
    assert timeline == ["[move]"]

    # the grasp trial's cylinder, in the colour of a grasp that succeeded, turned onto its
    # axis (y: a quarter turn about x), and its result in the log
    cyl = rec.view(index="trial", contents="/world/cylinder").select().read_all()
    assert cyl.column("trial").to_pylist() == [4]
    r, g, b = live.GRASPED
    assert cyl.column("/world/cylinder:Cylinders3D:colors").to_pylist() == [[r << 24 | g << 16 | b << 8 | 255]]
    q = np.array(cyl.column("/world/cylinder:Cylinders3D:quaternions").to_pylist()[0][0])
    assert np.allclose(q, [-np.sqrt(0.5), 0.0, 0.0, np.sqrt(0.5)]), q
    texts = rec.view(index="log_tick", contents="/log").select().read_all().column("/log:TextLog:text").to_pylist()
    assert any(t and "grasp grasped: 3.5 mm" in t[0] for t in texts), texts


@needs_rerun
def test_a_run_is_laid_out_for_the_cameras_its_start_gives(tmp_path, monkeypatch):
    path = tmp_path / "run.rrd"
    # camera 0 looks along -x from x = 2 m (its image x towards +y), camera 1 straight down
    # from 3 m (its image x towards -y)
    cameras = [
        {"resolution": [640, 480], "focal_px": 500.0, "position_mm": [2000.0, 0.0, 500.0],
         "axes": [[0.0, 1.0, 0.0], [0.0, 0.0, -1.0], [-1.0, 0.0, 0.0]]},
        {"resolution": [800, 600], "focal_px": 700.0, "position_mm": [0.0, 0.0, 3000.0],
         "axes": [[0.0, -1.0, 0.0], [-1.0, 0.0, 0.0], [0.0, 0.0, -1.0]]},
    ]
    events = run_events(cameras)
    monkeypatch.setattr(sys, "stdin", io.StringIO("".join(json.dumps(e) + "\n" for e in events)))
    assert live.main(["--save", str(path)]) == 0
    _, bounds, _ = blueprint_of(path)
    assert sorted(bounds) == ["[{x_range: [0.0, 640.0], y_range: [0.0, 480.0]}]",
                      "[{x_range: [0.0, 800.0], y_range: [0.0, 600.0]}]"], bounds
    # each camera a pinhole of its focal length and image, placed and turned as the start
    # gives it, its centre among the cameras' points
    rec = load_recording(str(path))
    centres = rec.view(index=None, contents="/world/cameras").select().read_all().to_pydict()
    assert np.allclose(centres["/world/cameras:Points3D:positions"][0], [[2000, 0, 500], [0, 0, 3000]])
    for k, f, (w, h), axes, pos in [(0, 500.0, (640, 480), [[0, 1, 0], [0, 0, -1], [-1, 0, 0]], [2000, 0, 500]),
                                    (1, 700.0, (800, 600), [[0, -1, 0], [-1, 0, 0], [0, 0, -1]], [0, 0, 3000])]:
        cam = rec.view(index=None, contents=f"/world/camera_{k}").select().read_all().to_pydict()
        assert np.allclose(cam[f"/world/camera_{k}:Pinhole:image_from_camera"][0], [f, 0, 0, 0, f, 0, w / 2, h / 2, 1])
        assert cam[f"/world/camera_{k}:Pinhole:resolution"][0] == [[w, h]]
        assert np.allclose(cam[f"/world/camera_{k}:Transform3D:translation"][0], pos)
        # the rotation's columns (column-major) are the image's x, y and the optical axis
        assert np.allclose(np.reshape(cam[f"/world/camera_{k}:Transform3D:mat3x3"][0], (3, 3)), axes, atol=1e-3)


def env_in_a_view(path):
    """An environment (stage 2, the ideal plant) reset with seed 5, and a live view saving to
    ``path`` that has shown the reset."""
    env = SoftArmEnv(stage=2, config="ideal")
    view = live.LiveView("trn_softarm_live_test", save=path)
    obs, info = env.reset(seed=5)
    view.env_step(env, obs, info, None)
    return env, view


@needs_rerun
def test_an_environments_recording_has_its_blueprint_and_timelines(tmp_path):
    path = tmp_path / "env.rrd"
    env, view = env_in_a_view(path)
    for a in np.zeros((3, 3), dtype=np.float32):
        obs, reward, _, _, info = env.step(a)
        view.env_step(env, obs, info, reward)
    view.close()

    rec = load_recording(str(path))
    assert_on_the_timelines(rec, ["/world/arm/joints", "/world/target/lights", "/world/camera_1/target", "/error/true_px"])
    times = rec.view(index="sim_time", contents="/world/arm/joints").select().read_all()
    assert times.num_rows == 4
    w, h = env._arm.image_size
    views, bounds, timeline = blueprint_of(path)
    assert ("[2D]", "[world/camera_1]") in views and ("[TimeSeries]", "[error]") in views, views
    assert bounds == [f"[{{x_range: [0.0, {w:.1f}], y_range: [0.0, {h:.1f}]}}]"] * 2, bounds
    assert timeline == ["[move]"]


@needs_rerun
def test_the_pinholes_project_the_lights_where_the_cameras_read_them():
    # the live view's cameras (camera_pinholes) against the plant's own: its lights
    # projected through each pinhole land where the camera read them
    # (the ideal plant: no lens distortion worth a pixel here, centroid noise under a pixel)
    env = SoftArmEnv(stage=1, config="ideal")
    for seed in range(3):
        obs, _ = env.reset(seed=seed)
        g = env.geometry()
        read = np.asarray(obs["lights"])
        for k, c in enumerate(live.camera_pinholes("ideal")):
            rotation, position = np.asarray(c["axes"]).T, np.asarray(c["position_mm"])
            for j, x in enumerate(g["lights"]):
                p = rotation.T @ (np.asarray(x) - position)
                u, v = c["focal_px"] * p[:2] / p[2] + np.asarray(c["resolution"]) / 2
                # readings interleave the cameras: light j in camera k is row 2 j + k
                assert obs["status"][2 * j + k] == 0
                assert np.hypot(u - read[2 * j + k][0], v - read[2 * j + k][1]) < 3.0, (seed, k, j)


@needs_rerun
def test_a_move_reaches_the_recording_without_waiting_for_the_next(tmp_path):
    # a move gathered for a batch is sent within the batch's time even when no other move
    # follows (an environment stepped by hand): read back before the view is closed
    path = tmp_path / "env.rrd"
    _, view = env_in_a_view(path)
    time.sleep(4 * live.BATCH_S)
    view.rec.flush()  # the recording's own buffer to the file, not the view's batch
    rec = load_recording(str(path))
    joints = rec.view(index="move", contents="/world/arm/joints").select().read_all()
    assert joints.column("move").to_pylist() == [1]
    view.close()
