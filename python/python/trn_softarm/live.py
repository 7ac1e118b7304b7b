"""The live view: a run or an environment shown in the rerun viewer while it goes on, or
saved as a recording (.rrd) to open later (``rerun run.rrd``).

What it shows, everything that changes on the timelines ``trial`` and ``move`` (and
``sim_time``, the plant's simulated time, from the first move on):

- ``world/arm/links`` and ``world/arm/joints``: the arm (base, shoulder, elbow, wrist,
  gripper centre) after each move, ``world/arm/lights``: its lights p and q;
  ``world/target/lights``: the target's; ``world/cameras``: the cameras (mm, base frame:
  x forward, y left, z up);
- ``world/camera_0``, ``world/camera_1``: each camera as a pinhole (its pose, focal length
  and image size, from the plant's configuration), and under it ``…/lights`` and
  ``…/target``: the lights as read and the target in its image (pixels; the 3-D view shows
  them on the camera's image plane), ``…/image``: the image's frame;
- ``error/measured_px`` and ``error/true_px``: each move's error;
- ``curve/stage1_px``, ``curve/stage2_px``: the learning curve (each training trial's final
  error), ``eval/<phase>/…`` the other phases' trials;
- ``log``: the run's phases, messages and failed trials.

The recording carries its blueprint: the arm in 3-D, one view a camera framed on its image,
the errors (and a run's learning curve) as time series, the log; the time panel on ``move``.
A run's grasp trials show their cylinder (``world/cylinder``: cyan when grasped, red when
missed) and the grasp's result in the log; an environment has no grasp.

``trn train --rerun`` (and ``--rerun-save FILE``) starts ``python -m trn_softarm.live``
and sends it one JSON object a line on its standard input: ``{"event": "start" | "phase" |
"trial" | "message" | "finish", ...}`` (see :meth:`LiveView.event`). A Gymnasium
``SoftArmEnv(render_mode="human")`` logs every reset and step itself.
"""

import argparse
import json
import sys
import threading
import time

try:
    import rerun as rr
    import rerun.blueprint as rrb
except ImportError as e:  # pragma: no cover - the message is the point
    raise ImportError(
        "the live view needs the rerun SDK: pip install 'trn-softarm[live]' (rerun-sdk 0.28.2)"
    ) from e

import numpy as np

from ._native import camera_pinholes as _camera_pinholes

# colours readable on the viewer's dark background
LINK = [190, 200, 215]  # the arm's links: light blue-grey
JOINT = [240, 240, 245]  # its joints: near white
LIGHT = [255, 90, 90]  # the arm's lights, as placed and as read: red
TARGET = [90, 225, 120]  # the target: green
GRASPED = [60, 200, 255]  # a cylinder grasped: cyan
CAMERA = [90, 170, 255]  # the cameras: blue
FRAME = [120, 130, 150]  # a camera image's frame: grey
SERIES = {
    "error/measured_px": [255, 140, 90],
    "error/true_px": TARGET,
    "curve/stage1_px": [255, 190, 70],
    "curve/stage2_px": CAMERA,
}

# a batch of moves is sent once this many entity rows wait or this many seconds passed
BATCH_ROWS = 4096
BATCH_S = 0.2

# the timeline the time panel shows: one step a move, never going back (an environment's
# sim_time starts again at each reset of a plant that does not persist)
TIMELINE = "move"
CAMERAS = 2
# how far from its centre a camera's image is drawn in the 3-D view (mm)
PINHOLE_MM = 250.0


def camera_pinholes(config="realistic"):
    """The cameras of the plant ``config`` (a built-in name or a TOML file) as the plant
    builds them, ideal pinholes: each one's ``position_mm``, ``axes`` (the image's x, its y
    and the optical axis in the base frame), ``focal_px`` and ``resolution``."""
    return json.loads(_camera_pinholes(config))[:CAMERAS]


def blueprint(sizes, curves=False):
    """The view's layout for cameras of ``sizes``: the arm in 3-D beside each camera's image
    (framed on the whole image), the errors as time series (and, with ``curves``, a run's
    learning curve and evaluations), the log; the time panel on :data:`TIMELINE`."""
    cameras = [
        rrb.Spatial2DView(
            origin=f"world/camera_{k}",
            name=f"camera {k}",
            visual_bounds=rrb.VisualBounds2D(x_range=[0, w], y_range=[0, h]),
        )
        for k, (w, h) in enumerate(sizes)
    ]
    plots = [rrb.TimeSeriesView(origin="error", name="error per move (px)")]
    if curves:
        trials = rrb.TimeSeriesView(origin="/", contents=["curve/**", "eval/**"], name="final error per trial (px)")
        plots.append(trials)
    right = rrb.Vertical(rrb.Horizontal(*cameras), *plots, rrb.TextLogView(origin="log", name="log"))
    return rrb.Blueprint(
        rrb.Horizontal(rrb.Spatial3DView(origin="world", name="arm"), right, column_shares=[1, 1]),
        rrb.TimePanel(timeline=TIMELINE),
        auto_views=False,
    )


def _z_to(axis):
    """The rotation (a quaternion, xyzw) that takes the z axis, a cylinder's own axis in
    rerun, onto the unit vector ``axis``."""
    a = np.asarray(axis, dtype=float)
    a = a / np.linalg.norm(a)
    z = np.array([0.0, 0.0, 1.0])
    c = float(np.dot(z, a))
    if c < -1.0 + 1e-9:  # opposite: half a turn about x
        return rr.Quaternion(xyzw=[1.0, 0.0, 0.0, 0.0])
    v = np.cross(z, a)
    q = np.array([v[0], v[1], v[2], 1.0 + c])
    return rr.Quaternion(xyzw=(q / np.linalg.norm(q)).tolist())


def _camera_rows(v, cam):
    """Camera ``cam``'s (x, y) rows of a flat reading (row 2 i + k: light i in camera k),
    the lights not read (None) left out."""
    v = v or []
    rows = [(v[i], v[i + 1]) for i in range(0, len(v) - 1, 2)]
    return [p for j, p in enumerate(rows) if j % CAMERAS == cam and None not in p]


class _Batch:
    """Each move's entities gathered and sent to the recording as columns (``send_columns``)
    instead of one log call an entity a move: rerun's cost a call, not the data, is most of
    a live view's time. Rows are kept per entity with their ``trial``, ``move`` and
    ``sim_time`` (``None`` when a move has none) and sent by :meth:`flush`: when
    :data:`BATCH_ROWS` rows wait or :data:`BATCH_S` seconds passed since the first of them
    (a timer's thread sends them if nothing else does), and at every phase, the end and the
    close, so a viewer is never more than that behind."""

    def __init__(self, rec):
        self.rec = rec
        self.rows = {}  # entity -> (kind, [(trial, move, sim_time, value)])
        self.count = 0
        self.sent = time.monotonic()
        # rows that wait are sent by a timer too, so that the last move of an environment
        # stepped slowly reaches the viewer without waiting for the next one
        self.lock = threading.Lock()
        self.timer = None

    def add(self, entity, kind, trial, move, sim_time, value):
        with self.lock:
            self.rows.setdefault(entity, (kind, []))[1].append((trial, move, sim_time, value))
            self.count += 1
            due = self.count >= BATCH_ROWS or time.monotonic() - self.sent >= BATCH_S
            if not due and self.timer is None:
                self.timer = threading.Timer(BATCH_S, self.flush)
                self.timer.daemon = True
                self.timer.start()
        if due:
            self.flush()

    def flush(self):
        with self.lock:
            if self.timer is not None:
                self.timer.cancel()
                self.timer = None
            for entity, (kind, rows) in self.rows.items():
                # rows with and without a simulated time go apart (a column has every row's)
                for timed in (True, False):
                    part = [r for r in rows if (r[2] is not None) == timed]
                    if part:
                        self._send(entity, kind, part, timed)
            self.rows.clear()
            self.count = 0
            self.sent = time.monotonic()

    def _send(self, entity, kind, rows, timed):
        indexes = [
            rr.TimeColumn("trial", sequence=[r[0] for r in rows]),
            rr.TimeColumn("move", sequence=[r[1] for r in rows]),
        ]
        if timed:
            indexes.append(rr.TimeColumn("sim_time", duration=[r[2] for r in rows]))
        values = [r[3] for r in rows]
        if kind == "scalar":
            columns = rr.Scalars.columns(scalars=values)
        elif kind == "strip":
            columns = rr.LineStrips3D.columns(strips=values)
        else:
            archetype = rr.Points3D if kind == "points3d" else rr.Points2D
            flat = [p for v in values for p in v]
            positions = np.asarray(flat, dtype=np.float32).reshape(-1, 3 if kind == "points3d" else 2)
            columns = archetype.columns(positions=positions).partition([len(v) for v in values])
        self.rec.send_columns(entity, indexes=indexes, columns=columns)


class LiveView:
    """A rerun recording: shown in a viewer (``spawn``, or ``connect`` to one at a gRPC
    URL) and/or saved to ``save`` (an .rrd file). ``curves``: the layout has a run's
    learning curve."""

    def __init__(self, app="trn_softarm", spawn=False, save=None, connect=None, curves=False):
        self.rec = rr.RecordingStream(app)
        self._open(spawn, save, connect)
        self.curves = curves
        self.cameras = None
        self.cylinder_shown = False
        self.series = set()
        self.move = 0
        self.trial_index = 0
        self.sim_time = None
        self.batch = _Batch(self.rec)
        # what comes before the first move (the run's start, its first phase) is at 0
        self.rec.set_time("trial", sequence=0)
        self.rec.set_time("move", sequence=0)
        self._styles()

    def _open(self, spawn, save, connect):
        """The recording's sinks: the viewer and the file together (each sink call alone
        would replace the one before)."""
        sinks = []
        if spawn:
            self.rec.spawn(connect=False)
            sinks.append(rr.GrpcSink())
        elif connect is not None:
            sinks.append(rr.GrpcSink(connect))
        if save is not None:
            sinks.append(rr.FileSink(str(save)))
        if sinks:
            self.rec.set_sinks(*sinks)

    def _styles(self):
        """The static part of the scene's entities: the frame of the world, the colours and
        sizes, so that each move logs only positions."""
        log = lambda path, arch: self.rec.log(path, arch, static=True)
        log("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP)
        log("world/arm/links", rr.LineStrips3D.from_fields(colors=[LINK], radii=[8.0]))
        log("world/arm/joints", rr.Points3D.from_fields(colors=[JOINT], radii=[14.0]))
        log("world/arm/lights", rr.Points3D.from_fields(colors=[LIGHT], radii=[10.0]))
        log("world/target/lights", rr.Points3D.from_fields(colors=[TARGET], radii=[10.0]))
        for cam in range(CAMERAS):
            log(f"world/camera_{cam}/lights", rr.Points2D.from_fields(colors=[LIGHT], radii=[6.0]))
            log(f"world/camera_{cam}/target", rr.Points2D.from_fields(colors=[TARGET], radii=[9.0]))

    def _series(self, path):
        """The time series ``path``'s name (and colour, :data:`SERIES`) in the plots, once."""
        if path not in self.series:
            self.series.add(path)
            name, color = path.split("/", 1)[1], SERIES.get(path)
            style = rr.SeriesLines(colors=[color], names=name) if color else rr.SeriesLines(names=name)
            self.rec.log(path, style, static=True)

    def _scalar(self, path, value):
        """A point of the time series ``path`` at the current trial (a trial's figure)."""
        self._series(path)
        self.rec.log(path, rr.Scalars(value))

    def _move_row(self, entity, kind, value):
        """One of the current move's entities, into the batch."""
        self.batch.add(entity, kind, self.trial_index, self.move, self.sim_time, value)

    def flush(self):
        """Sends the moves gathered so far."""
        self.batch.flush()

    def layout(self, cameras):
        """Sends the blueprint and each camera as a pinhole in the world (``world/camera_k``:
        its pose, focal length and image, the frame of its image at ``world/camera_k/image``;
        its centre among ``world/cameras``) for ``cameras`` (as :func:`camera_pinholes` gives
        them), unless they were sent."""
        cameras = list(cameras)
        if cameras == self.cameras:
            return
        self.cameras = cameras
        sizes = [tuple(c["resolution"]) for c in cameras]
        self.rec.send_blueprint(blueprint(sizes, self.curves))
        centres = [c["position_mm"] for c in cameras]
        self.rec.log("world/cameras", rr.Points3D(centres, colors=[CAMERA], radii=[20.0]), static=True)
        for k, c in enumerate(cameras):
            w, h = sizes[k]
            path = f"world/camera_{k}"
            rotation = np.asarray(c["axes"], dtype=float).T  # the axes as its columns
            self.rec.log(path, rr.Transform3D(translation=c["position_mm"], mat3x3=rotation), static=True)
            pinhole = rr.Pinhole(
                focal_length=float(c["focal_px"]),
                width=w,
                height=h,
                camera_xyz=rr.ViewCoordinates.RDF,
                image_plane_distance=PINHOLE_MM,
                color=CAMERA,
            )
            self.rec.log(path, pinhole, static=True)
            self.rec.log(f"{path}/image", rr.Boxes2D(mins=[0, 0], sizes=[w, h], colors=[FRAME]), static=True)

    def _next_move(self, time_s):
        self.move += 1
        self.rec.set_time("move", sequence=self.move)
        self.sim_time = None if time_s is None else float(time_s)
        if self.sim_time is not None:
            self.rec.set_time("sim_time", duration=self.sim_time)

    def _cylinder(self, c, grasp):
        """A grasp trial's cylinder (``world/cylinder``: cyan when the grasp succeeded, red
        when not, the target's colour before it is scored), cleared at a trial without one;
        the grasp's result in the log."""
        if c is None:
            if self.cylinder_shown:
                self.cylinder_shown = False
                self.rec.log("world/cylinder", rr.Clear(recursive=False))
            return
        self.cylinder_shown = True
        color = TARGET if grasp is None else (GRASPED if grasp["success"] else LIGHT)
        self.rec.log(
            "world/cylinder",
            rr.Cylinders3D(
                lengths=[c["length"]],
                radii=[c["radius"]],
                centers=[c["centre"]],
                quaternions=[_z_to(c["axis"])],
                colors=[color],
            ),
        )
        if grasp is not None:
            verdict = "grasped" if grasp["success"] else "missed"
            text = f"grasp {verdict}: {grasp['distance_mm']:.1f} mm from the centre, {grasp['perpendicular_error_deg']:.1f} deg off perpendicular"
            self.rec.log("log", rr.TextLog(text, level="INFO" if grasp["success"] else "WARN"))

    def _arm(self, links, lights, target_lights):
        self._move_row("world/arm/links", "strip", links)
        self._move_row("world/arm/joints", "points3d", links)
        if lights:
            self._move_row("world/arm/lights", "points3d", lights)
        if target_lights:
            self._move_row("world/target/lights", "points3d", target_lights)

    def _cameras(self, seen, target):
        for cam in range(CAMERAS):
            self._move_row(f"world/camera_{cam}/lights", "points2d", _camera_rows(seen, cam))
            self._move_row(f"world/camera_{cam}/target", "points2d", _camera_rows(target, cam))

    def _errors(self, measured, true):
        for path, v in (("error/measured_px", measured), ("error/true_px", true)):
            if v is not None:
                self._series(path)
                self._move_row(path, "scalar", float(v))

    def event(self, e, config="realistic"):
        """One event of a run (see the module). The cameras come with the start; a stream
        without them is laid out for the plant ``config``'s."""
        kind = e.get("event")
        if kind != "start" and self.cameras is None:
            self.layout(camera_pinholes(config))
        if kind == "start":
            self.rec.log("log", rr.TextLog(f"run: {e.get('title', '')}, about {e.get('trials')} trials"))
            if e.get("cameras"):
                self.layout(e["cameras"][:CAMERAS])
        elif kind in ("phase", "message"):
            self.flush()
            self.rec.log("log", rr.TextLog(e.get("name") or e.get("text") or ""))
        elif kind == "trial":
            self.trial(e)
        elif kind == "finish":
            self.flush()
            self.rec.log("log", rr.TextLog("run finished"))

    def trial(self, e):
        """A trial: each move's arm, lights and error, then its point of the learning curve;
        a grasp's cylinder, coloured by how the grasp went."""
        self.trial_index += 1
        self.rec.set_time("trial", sequence=self.trial_index)
        self._cylinder(e.get("cylinder"), e.get("grasp"))
        for m in e.get("moves", []):
            self._next_move(m.get("time_s"))
            self._arm(m["links"], m.get("lights"), e.get("target_lights"))
            self._cameras(m.get("seen"), m.get("target"))
            self._errors(m.get("measured_px"), m.get("true_px"))
        prefix = "curve" if e.get("phase") == "training" else f"eval/{e.get('phase')}"
        for stage in ("stage1", "stage2"):
            v = e.get(f"{stage}_final_px")
            if v is not None:
                self._scalar(f"{prefix}/{stage}_px", v)
        if e.get("failure"):
            self.rec.log("log", rr.TextLog(f"trial {e.get('trial')}: {e['failure']}", level="WARN"))

    def env_step(self, env, obs, info, reward):
        """An environment's reset (``reward`` None) or step."""
        if self.cameras is None:
            self.layout(camera_pinholes(env.config))
        if reward is None:
            self.trial_index += 1
            self.rec.set_time("trial", sequence=self.trial_index)
        self._next_move(info["time_s"])
        g = env.geometry()
        self._arm(g["links"].tolist(), g["lights"].tolist(), g["target_lights"].tolist())
        status = np.asarray(obs["status"])
        seen = [None if s else float(c) for s, row in zip(status, obs["lights"]) for c in row]
        target = [float(c) for row in obs["target"] for c in row]
        self._cameras(seen, target)
        self._errors(info.get("error_px"), info.get("error_true_px"))

    def close(self):
        self.flush()
        self.rec.flush()
        self.rec.disconnect()


def main(argv=None):
    """``python -m trn_softarm.live [--spawn | --connect URL] [--save FILE]``: the events
    of a run, one JSON object a line on standard input, into the viewer and/or a file."""
    ap = argparse.ArgumentParser(prog="python -m trn_softarm.live", description=main.__doc__)
    ap.add_argument("--spawn", action="store_true", help="start a viewer and stream to it")
    ap.add_argument("--connect", metavar="URL", help="stream to a running viewer (rerun+http://127.0.0.1:9876/proxy)")
    ap.add_argument("--save", metavar="FILE", help="save the recording (.rrd)")
    ap.add_argument("--app", default="trn", help="the recording's application id")
    ap.add_argument(
        "--config",
        default="realistic",
        help="the plant (a built-in name or a TOML file) whose cameras lay out a stream whose start does not give them",
    )
    ap.add_argument("--ready", action="store_true", help="print a line 'ready' once the view is open")
    a = ap.parse_args(argv)
    if not (a.spawn or a.connect or a.save):
        ap.error("nothing to do: give --spawn, --connect or --save")
    view = LiveView(a.app, spawn=a.spawn, save=a.save, connect=a.connect, curves=True)
    if a.ready:
        print("ready", flush=True)
    for line in sys.stdin:
        if line.strip():
            view.event(json.loads(line), a.config)
    view.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
