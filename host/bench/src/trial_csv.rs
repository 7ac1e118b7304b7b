//! `--csv FILE`: one row per trial, as the runner saw and scored it (every phase: training,
//! snapshots, the evaluations, grasps), for a spreadsheet or pandas. [`TrialRows`] watches
//! a run beside its observer and keeps the rows; the run writes them through
//! [`crate::output`] like every other file.

use std::fmt::Write as _;

use crate::metrics::failure;
use crate::observe::Observer;
use crate::records::{Phase, TrialKind, TrialRecord};
use crate::scoring::{self, StageScore};

/// The header row.
pub const HEADER: &str = "trial,phase,snapshot_after,kind,learn,fine_moves_asked,moves,\
stage1_coarse_px,stage1_final_px,stage1_final_true_px,stage1_fine_moves,\
stage2_coarse_px,stage2_final_px,stage2_final_true_px,stage2_fine_moves,\
pose_error_mm,pose_error_deg,grasp_success,grasp_distance_mm,grasp_deg,sim_time_s,failure";

fn phase(p: Phase) -> (&'static str, Option<usize>) {
    match p {
        Phase::Training => ("training", None),
        Phase::Snapshot(n) => ("snapshot", Some(n)),
        Phase::SnapshotGrasp(n) => ("snapshot-grasp", Some(n)),
        Phase::Deployment => ("deployment", None),
        Phase::Evaluation => ("evaluation", None),
        Phase::VisitAndReturn => ("visit-and-return", None),
        Phase::Grasping => ("grasping", None),
    }
}

/// A number, empty when not a number (a failed trial's error).
fn num(x: f64) -> String {
    if x.is_finite() {
        format!("{x:.4}")
    } else {
        String::new()
    }
}

/// A CSV field: quoted when it holds a comma, a quote or a line break (RFC 4180).
pub fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

fn stage(s: Option<&StageScore>) -> [String; 4] {
    match s {
        Some(s) => [
            num(s.coarse_px() as f64),
            num(s.final_px() as f64),
            num(s.final_true_px() as f64),
            s.fine_moves().to_string(),
        ],
        None => Default::default(),
    }
}

/// One trial's row (without the line end).
pub fn row(r: &TrialRecord) -> String {
    let (phase, after) = phase(r.phase);
    let (kind, learn) = match r.kind {
        TrialKind::Stage1 { supervised, learn } => {
            (if supervised { "priming" } else { "stage1" }, learn)
        }
        TrialKind::Stage2 { learn } => ("stage2", learn),
        TrialKind::Grasp { learn } => ("grasp", learn),
    };
    let asked = match r.fine_moves {
        trn_protocol::FINE_MOVES_POLICY => "rule".to_string(),
        n => n.to_string(),
    };
    let (s1, s2) = (scoring::stage1(r), scoring::stage2(r));
    let pose = s1
        .as_ref()
        .map_or([f32::NAN; 2], |s| [s.pose_error_mm, s.pose_error_deg]);
    let grasp = r
        .grasp
        .map_or([String::new(), String::new(), String::new()], |g| {
            [
                g.success.to_string(),
                num(g.distance_mm),
                num(g.perpendicular_error_deg),
            ]
        });
    let mut out = String::new();
    let _ = write!(
        out,
        "{},{phase},{},{kind},{learn},{asked},{}",
        r.trial,
        after.map(|n| n.to_string()).unwrap_or_default(),
        r.captures.len()
    );
    for f in stage(s1.as_ref()).iter().chain(&stage(s2.as_ref())) {
        let _ = write!(out, ",{f}");
    }
    let _ = write!(
        out,
        ",{},{},{},{},{},{},{}",
        num(pose[0] as f64),
        num(pose[1] as f64),
        grasp[0],
        grasp[1],
        grasp[2],
        num(r.sim_time_s()),
        csv_field(&failure(r).map(|f| f.reason()).unwrap_or_default())
    );
    out
}

/// An observer that keeps a CSV row of every trial and passes everything on to `inner`.
pub struct TrialRows<'a> {
    inner: &'a mut dyn Observer,
    csv: Option<String>,
}

impl<'a> TrialRows<'a> {
    /// Watches beside `inner`; keeps rows only when `keep` (a run without `--csv` keeps
    /// nothing).
    pub fn new(inner: &'a mut dyn Observer, keep: bool) -> TrialRows<'a> {
        TrialRows {
            inner,
            csv: keep.then(|| format!("{HEADER}\n")),
        }
    }

    /// The CSV so far (header and rows), if kept.
    pub fn csv(&self) -> Option<&str> {
        self.csv.as_deref()
    }
}

impl Observer for TrialRows<'_> {
    fn start(&mut self, trials: u64) {
        self.inner.start(trials)
    }
    fn phase(&mut self, name: &str) {
        self.inner.phase(name)
    }
    fn trial(&mut self, record: &TrialRecord) {
        if let Some(csv) = &mut self.csv {
            csv.push_str(&row(record));
            csv.push('\n');
        }
        self.inner.trial(record)
    }
    fn message(&mut self, text: &str) {
        self.inner.message(text)
    }
    fn notice(&mut self, text: &str) {
        self.inner.notice(text)
    }
    fn finish(&mut self) {
        self.inner.finish()
    }
    fn ran(&mut self, report: &crate::report::Report) {
        self.inner.ran(report)
    }
    fn stop_requested(&self) -> bool {
        self.inner.stop_requested()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_row_has_the_headers_columns_and_quotes_its_text() {
        let columns = HEADER.split(',').count();
        let rec = TrialRecord {
            trial: 7,
            kind: TrialKind::Stage2 { learn: false },
            phase: Phase::Snapshot(25),
            fine_moves: 6,
            target: trn_plant::targets::Target::NONE,
            target_seen: false,
            captures: vec![],
            reports: vec![],
            errors: vec![],
            aborted: false,
            gave_up: false,
            grasp: None,
            started_s: 0.0,
        };
        let r = row(&rec);
        assert!(r.starts_with("7,snapshot,25,stage2,false,6,0,"), "{r}");
        assert!(r.ends_with("target not visible from the twin arm"), "{r}");
        assert_eq!(r.split(',').count(), columns, "{r}");
        assert_eq!(csv_field("a, \"b\""), "\"a, \"\"b\"\"\"");
    }

    /// Everything the runner tells the CSV's observer reaches the caller's: a notice (what
    /// `trn` says before it erases learned tables) lost here was silent in every run with
    /// the CSV observer in the chain.
    #[test]
    fn every_call_reaches_the_callers_observer() {
        #[derive(Default)]
        struct Heard(Vec<String>);
        impl Observer for Heard {
            fn start(&mut self, trials: u64) {
                self.0.push(format!("start {trials}"));
            }
            fn phase(&mut self, name: &str) {
                self.0.push(format!("phase {name}"));
            }
            fn message(&mut self, text: &str) {
                self.0.push(format!("message {text}"));
            }
            fn notice(&mut self, text: &str) {
                self.0.push(format!("notice {text}"));
            }
            fn finish(&mut self) {
                self.0.push("finish".into());
            }
            fn stop_requested(&self) -> bool {
                true
            }
        }
        let mut heard = Heard::default();
        let mut rows = TrialRows::new(&mut heard, false);
        rows.start(3);
        rows.phase("training");
        rows.message("m");
        rows.notice("erasing");
        rows.finish();
        assert!(rows.stop_requested());
        assert_eq!(
            heard.0,
            [
                "start 3",
                "phase training",
                "message m",
                "notice erasing",
                "finish"
            ]
        );
    }
}
