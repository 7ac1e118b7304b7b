//! `--rerun` and `--rerun-save FILE`: the run in the rerun viewer while it goes on, or saved
//! as a recording. [`LiveStream`] is an observer of the run (it gets every trial's record)
//! that sends each event, one JSON object a line, to `python -m trn_softarm.live` (the
//! Python package's live view, on the rerun Python SDK: `pip install './python[live]'`;
//! the interpreter is `$TRN_PYTHON`, else `python3`). The recording is written as every
//! output is (`trn_bench::output`): checked before the run, into a temporary file that
//! becomes FILE when the viewer's process ended well.

use std::io::{BufRead, BufReader, BufWriter, Read, Write};
use std::path::Path;
use std::process::{Child, ChildStdin, Command, Stdio};

use serde_json::{json, Value};
use trn_bench::output::{check_path, Kind, PendingFile};
use trn_bench::records::{Phase, TrialRecord};
use trn_bench::{metrics, scoring, LabError, Observer};
use trn_plant::camera::Camera;
use trn_plant::kinematics::{forward, lights};
use trn_plant::nodes::Sight;
use trn_plant::{Readings, SimConfig};

use crate::{CliError, Result};

/// The interpreter that runs the live view.
fn python() -> String {
    std::env::var("TRN_PYTHON").unwrap_or_else(|_| "python3".into())
}

fn usage(m: String) -> CliError {
    CliError::Lab(LabError::Usage(m))
}

/// Copies `from` to `to` on a thread of its own until `from` ends (a child's output pipe,
/// which must never fill while the run goes on).
fn copy_in_background(mut from: impl Read + Send + 'static, mut to: impl Write + Send + 'static) {
    std::thread::spawn(move || std::io::copy(&mut from, &mut to));
}

/// The run's events on their way to the live view's process.
pub struct LiveStream {
    child: Child,
    stdin: Option<BufWriter<ChildStdin>>,
    cfg: SimConfig,
    recording: Option<PendingFile>,
    /// The first write that failed (the process is gone): reported at the end.
    broken: Option<std::io::Error>,
}

/// A reading as pixels, `null` for a light not read.
fn pixels<const K: usize>(r: &Readings<K>) -> Vec<Value> {
    r.points
        .iter()
        .flat_map(|p| {
            let ok = p.x.is_finite() && p.y.is_finite();
            [ok.then_some(p.x), ok.then_some(p.y)]
        })
        .map(|x| json!(x))
        .collect()
}

fn finite(x: f32) -> Value {
    if x.is_finite() {
        json!(x)
    } else {
        Value::Null
    }
}

fn phase_name(p: Phase) -> &'static str {
    match p {
        Phase::Training => "training",
        Phase::Snapshot(_) => "snapshot",
        Phase::SnapshotGrasp(_) => "snapshot-grasp",
        Phase::Deployment => "deployment",
        Phase::Evaluation => "evaluation",
        Phase::VisitAndReturn => "visit-and-return",
        Phase::Grasping => "grasping",
    }
}

impl LiveStream {
    /// Starts the live view's process: a viewer when `spawn`, the recording `save`. Refuses
    /// (a usage error, before anything runs) a recording path that breaks the output rule,
    /// or a Python without the live view.
    pub fn start(cfg: &SimConfig, spawn: bool, save: Option<&Path>) -> Result<LiveStream> {
        if let Some(p) = save {
            check_path(p, Kind::Recording)?;
        }
        let py = python();
        let recording = save.map(PendingFile::create).transpose()?;
        let mut cmd = Command::new(&py);
        cmd.args(["-m", "trn_softarm.live", "--app", "trn", "--ready"]);
        if spawn {
            cmd.arg("--spawn");
        }
        if let Some(r) = &recording {
            cmd.arg("--save").arg(r.temporary_path());
        }
        // its own process group: an interrupt at the terminal stops the run at a trial
        // boundary (`progress`), and the live view then ends with what the run did
        #[cfg(unix)]
        std::os::unix::process::CommandExt::process_group(&mut cmd, 0);
        let mut child = cmd
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .map_err(|e| usage(format!("--rerun/--rerun-save: cannot run {py}: {e}")))?;
        // the run starts once the live view said it is ready (its imports done, its sinks
        // open), so that a Python without it is refused before anything runs; one import,
        // not a probe and then the view's own
        let (Some(out), Some(mut err)) = (child.stdout.take(), child.stderr.take()) else {
            let _ = child.kill();
            return Err(usage(format!(
                "--rerun/--rerun-save: {py} has no output pipes"
            )));
        };
        let mut out = BufReader::new(out);
        let mut line = String::new();
        let ready = out.read_line(&mut line).is_ok() && line.trim_end() == "ready";
        if !ready {
            let mut text = String::new();
            let _ = err.read_to_string(&mut text);
            let _ = child.wait();
            return Err(usage(format!(
                "--rerun/--rerun-save need the live view in {py}: pip install './python[live]' ({})",
                text.lines().last().unwrap_or("it did not start")
            )));
        }
        // what the live view prints later goes where this process's output goes
        copy_in_background(out, std::io::stdout());
        copy_in_background(err, std::io::stderr());
        let stdin = child.stdin.take().map(BufWriter::new);
        Ok(LiveStream {
            child,
            stdin,
            cfg: cfg.clone(),
            recording,
            broken: None,
        })
    }

    fn send(&mut self, event: Value) {
        if let (Some(w), None) = (&mut self.stdin, &self.broken) {
            if let Err(e) = writeln!(w, "{event}") {
                self.broken = Some(e);
            }
        }
    }

    /// Ends the stream: the process gets the end of its input and is waited for; the
    /// recording becomes its file when the process ended well.
    pub fn close(mut self) -> Result<()> {
        let flushed = self.stdin.take().map_or(Ok(()), |mut w| w.flush());
        let status = self.child.wait();
        let fail = |m: String| Err(CliError::Plot(format!("live view: {m}")));
        match status {
            Ok(s) if s.success() => {}
            Ok(s) => return fail(format!("python -m trn_softarm.live ended with {s}")),
            Err(e) => return fail(e.to_string()),
        }
        if let Some(e) = self.broken.take().or(flushed.err()) {
            return fail(e.to_string());
        }
        match self.recording.take() {
            Some(r) => Ok(r.commit()?),
            None => Ok(()),
        }
    }

    /// A trial's event: each move's arm, lights, reading and error, its final errors.
    fn trial_event(&self, r: &TrialRecord) -> Value {
        let t = &r.target;
        let moves: Vec<Value> = r
            .captures
            .iter()
            .map(|c| {
                let q = c.pose.joint_angles_deg.map(f64::to_radians);
                let chain = forward(&self.cfg, &q);
                let links = chain.links();
                let (seen, target, errs) = match &c.sight {
                    Sight::Lights { noisy, truth } => (
                        pixels(noisy),
                        t.v.to_vec(),
                        (
                            noisy
                                .to_vector()
                                .map(|v| trn_bench::targets::dist(&v, &t.v)),
                            truth
                                .to_vector()
                                .map(|v| trn_bench::targets::dist(&v, &t.v_true)),
                        ),
                    ),
                    Sight::Centre { noisy, truth } => (
                        pixels(noisy),
                        t.c.to_vec(),
                        (
                            noisy
                                .to_vector()
                                .map(|v| trn_bench::targets::dist(&v, &t.c)),
                            truth
                                .to_vector()
                                .map(|v| trn_bench::targets::dist(&v, &t.c_true)),
                        ),
                    ),
                };
                json!({
                    "time_s": c.time_s,
                    "links": links,
                    "lights": lights(&self.cfg, &chain.pose),
                    "seen": seen,
                    "target": target.iter().map(|&x| finite(x)).collect::<Vec<_>>(),
                    "measured_px": errs.0.map(finite),
                    "true_px": errs.1.map(finite),
                })
            })
            .collect();
        let target_lights = t
            .pose
            .centre_mm
            .iter()
            .all(|x| x.is_finite())
            .then(|| lights(&self.cfg, &t.pose));
        let last = |s: Option<scoring::StageScore>| s.map(|s| finite(s.final_px()));
        // a grasp's cylinder (mm, base frame) and how the grasp went
        let cylinder = t.cylinder.map(|c| {
            json!({
                "centre": [c.centre.x, c.centre.y, c.centre.z],
                "axis": [c.axis.x, c.axis.y, c.axis.z],
                "radius": c.radius,
                "length": c.length,
            })
        });
        let grasp = r.grasp.map(|g| {
            json!({
                "distance_mm": g.distance_mm,
                "perpendicular_error_deg": g.perpendicular_error_deg,
                "success": g.success,
            })
        });
        json!({
            "event": "trial",
            "trial": r.trial,
            "phase": phase_name(r.phase),
            "moves": moves,
            "target_lights": target_lights,
            "stage1_final_px": last(scoring::stage1(r)),
            "stage2_final_px": last(scoring::stage2(r)),
            "failure": metrics::failure(r).map(|f| f.reason()),
            "cylinder": cylinder,
            "grasp": grasp,
        })
    }
}

impl Observer for LiveStream {
    fn start(&mut self, trials: u64) {
        let pinholes: Vec<_> = self
            .cfg
            .cameras
            .iter()
            .map(|c| Camera::new(c).pinhole())
            .collect();
        let title = std::env::args().collect::<Vec<_>>().join(" ");
        self.send(json!({
            "event": "start",
            "trials": trials,
            "cameras": pinholes,
            "title": title,
        }));
    }
    fn phase(&mut self, name: &str) {
        self.send(json!({"event": "phase", "name": name}));
    }
    fn trial(&mut self, record: &TrialRecord) {
        let e = self.trial_event(record);
        self.send(e);
    }
    fn message(&mut self, text: &str) {
        self.send(json!({"event": "message", "text": text}));
    }
    fn finish(&mut self) {
        self.send(json!({"event": "finish"}));
    }
}

/// Two observers watching one run (the progress bar and the live view); the first decides
/// when to stop.
pub struct Both<'a>(pub &'a mut dyn Observer, pub &'a mut dyn Observer);

impl Observer for Both<'_> {
    fn start(&mut self, trials: u64) {
        self.0.start(trials);
        self.1.start(trials);
    }
    fn phase(&mut self, name: &str) {
        self.0.phase(name);
        self.1.phase(name);
    }
    fn trial(&mut self, record: &TrialRecord) {
        self.0.trial(record);
        self.1.trial(record);
    }
    fn message(&mut self, text: &str) {
        self.0.message(text);
        self.1.message(text);
    }
    fn notice(&mut self, text: &str) {
        self.0.notice(text);
        self.1.notice(text);
    }
    fn finish(&mut self) {
        self.0.finish();
        self.1.finish();
    }
    fn ran(&mut self, report: &trn_bench::Report) {
        self.0.ran(report);
        self.1.ran(report);
    }
    fn stop_requested(&self) -> bool {
        self.0.stop_requested() || self.1.stop_requested()
    }
}
