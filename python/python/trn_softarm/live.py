"""The live view: a run or an environment shown in the rerun viewer while it goes on, or
saved as a recording (.rrd) to open later (``rerun run.rrd``).

What it shows, on the timelines ``trial`` and ``move`` (and ``sim_time``, the plant's time):

- ``arm/links`` and ``arm/joints``: the arm (base, shoulder, elbow, wrist, gripper centre)
  after each move, ``arm/lights``: its lights p and q; ``target/lights``: the target's
  (mm, base frame: x forward, y left, z up);
- ``camera_0/…``, ``camera_1/…``: the lights as read and the target in each image (pixels);
- ``error/measured_px`` and ``error/true_px``: each move's error;
- ``curve/stage1_px``, ``curve/stage2_px``: the learning curve (each training trial's final
  error), ``eval/…`` the evaluations' trials;
- ``log``: the run's phases and messages.

``trn train --rerun`` (and ``--rerun-save FILE``) starts ``python -m trn_softarm.live``
and sends it one JSON object a line on its standard input: ``{"event": "start" | "phase" |
"trial" | "message" | "finish", ...}`` (see :meth:`LiveView.event`). A Gymnasium
``SoftArmEnv(render_mode="human")`` logs every reset and step itself.
"""

import argparse
import json
import sys

import numpy as np

try:
    import rerun as rr
except ImportError as e:  # pragma: no cover - the message is the point
    raise ImportError(
        "the live view needs the rerun SDK: pip install 'trn-softarm[live]' (rerun-sdk 0.28.2)"
    ) from e

RED, GREEN, GREY, BLUE = [214, 39, 40], [44, 160, 44], [60, 60, 70], [31, 119, 180]


def _camera_rows(v, cam):
    """Camera ``cam``'s (x, y) rows of a flat reading (row 2 i + k: light i in camera k),
    the lights not read (None) left out."""
    v = v or []
    rows = [(v[i], v[i + 1]) for i in range(0, len(v) - 1, 2)]
    return [p for j, p in enumerate(rows) if j % 2 == cam and None not in p]


class LiveView:
    """A rerun recording: shown in a viewer (``spawn``, or ``connect`` to one at a gRPC
    URL) and/or saved to ``save`` (an .rrd file)."""

    def __init__(self, app="trn_softarm", spawn=False, save=None, connect=None):
        self.rec = rr.RecordingStream(app)
        if save is not None:
            self.rec.save(str(save))
        if spawn:
            self.rec.spawn()
        elif connect is not None:
            self.rec.connect_grpc(connect)
        self.move = 0
        self.trial_index = 0
        self.rec.log("world", rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)
        for name, color in [("curve/stage1_px", RED), ("curve/stage2_px", BLUE), ("error/measured_px", RED), ("error/true_px", GREEN)]:
            self.rec.log(name, rr.SeriesLines(colors=[color], names=name.split("/")[1]), static=True)

    def _arm(self, links, lights, target_lights, cameras=None):
        self.rec.log("world/arm/links", rr.LineStrips3D([links], colors=[GREY], radii=[8.0]))
        self.rec.log("world/arm/joints", rr.Points3D(links, colors=[GREY], radii=[14.0]))
        if lights:
            self.rec.log("world/arm/lights", rr.Points3D(lights, colors=[RED], radii=[10.0]))
        if target_lights:
            self.rec.log("world/target/lights", rr.Points3D(target_lights, colors=[GREEN], radii=[10.0]))
        if cameras is not None:
            self.rec.log("world/cameras", rr.Points3D(cameras, colors=[BLUE], radii=[20.0]), static=True)

    def _cameras(self, seen, target):
        for cam in range(2):
            self.rec.log(f"camera_{cam}/lights", rr.Points2D(_camera_rows(seen, cam), colors=[RED], radii=[6.0]))
            self.rec.log(f"camera_{cam}/target", rr.Points2D(_camera_rows(target, cam), colors=[GREEN], radii=[9.0]))

    def event(self, e):
        """One event of a run (see the module)."""
        kind = e.get("event")
        if kind == "start":
            self.rec.log("log", rr.TextLog(f"run: {e.get('title', '')}, about {e.get('trials')} trials"))
            if e.get("cameras"):
                self.rec.log("world/cameras", rr.Points3D(e["cameras"], colors=[BLUE], radii=[20.0]), static=True)
        elif kind in ("phase", "message"):
            self.rec.log("log", rr.TextLog(e.get("name") or e.get("text") or ""))
        elif kind == "trial":
            self.trial(e)
        elif kind == "finish":
            self.rec.log("log", rr.TextLog("run finished"))

    def trial(self, e):
        """A trial: each move's arm, lights and error, then its point of the learning curve."""
        self.trial_index += 1
        self.rec.set_time("trial", sequence=self.trial_index)
        for m in e.get("moves", []):
            self.move += 1
            self.rec.set_time("move", sequence=self.move)
            if m.get("time_s") is not None:
                self.rec.set_time("sim_time", duration=m["time_s"])
            self._arm(m["links"], m.get("lights"), e.get("target_lights"))
            self._cameras(m.get("seen"), m.get("target"))
            for k in ("measured_px", "true_px"):
                if m.get(k) is not None:
                    self.rec.log(f"error/{k}", rr.Scalars(m[k]))
        prefix = "curve" if e.get("phase") == "training" else f"eval/{e.get('phase')}"
        for stage in ("stage1", "stage2"):
            v = e.get(f"{stage}_final_px")
            if v is not None:
                self.rec.log(f"{prefix}/{stage}_px", rr.Scalars(v))
        if e.get("failure"):
            self.rec.log("log", rr.TextLog(f"trial {e.get('trial')}: {e['failure']}", level="WARN"))

    def env_step(self, env, obs, info, reward):
        """An environment's reset (``reward`` None) or step."""
        if reward is None:
            self.trial_index += 1
            self.rec.set_time("trial", sequence=self.trial_index)
        self.move += 1
        self.rec.set_time("move", sequence=self.move)
        self.rec.set_time("sim_time", duration=float(info["time_s"]))
        g = env.geometry()
        self._arm(g["links"].tolist(), g["lights"].tolist(), g["target_lights"].tolist(), g["cameras"].tolist())
        status = np.asarray(obs["status"])
        seen = [None if s else float(c) for s, row in zip(status, obs["lights"]) for c in row]
        target = [float(c) for row in obs["target"] for c in row]
        self._cameras(seen, target)
        if info.get("error_px") is not None:
            self.rec.log("error/measured_px", rr.Scalars(info["error_px"]))
        if info.get("error_true_px") is not None:
            self.rec.log("error/true_px", rr.Scalars(info["error_true_px"]))

    def close(self):
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
    a = ap.parse_args(argv)
    if not (a.spawn or a.connect or a.save):
        ap.error("nothing to do: give --spawn, --connect or --save")
    view = LiveView(a.app, spawn=a.spawn, save=a.save, connect=a.connect)
    for line in sys.stdin:
        if line.strip():
            view.event(json.loads(line))
    view.close()
    return 0


if __name__ == "__main__":
    sys.exit(main())
