//! `trn lifelong`: life-long learning under temperature drift and wear (issue 17). Each
//! controller runs the same thousands of trials on the same aging plant (the `aging`
//! configuration by default: [`trn_plant::SimConfig::aging`]), with a frozen snapshot
//! evaluation every few hundred trials: the held-out deployment targets with the fixed move
//! budget and the held-out grasps with the stop rule, on a copy of the plant in its present
//! state of drift and wear. The controllers:
//! - `frozen`: the project preset, learning only for its first `--initial` trials; the
//!   remaining trials still move the arm (so it wears as the others do) without learning;
//! - `project`: the project preset learning throughout (its rates decay with time);
//! - `lifelong`: the lifelong preset (the project's with a floor on the rates);
//! - `broyden`: the Broyden servo, which never trains.

use serde::Serialize;

use std::path::PathBuf;

use trn_bench::spec::ControllerChoice;
use trn_controller::presets::{Ablation, Preset};

use crate::study::{Finished, LifelongTable, Row, RunFile, Study, StudyHeader, Table};
use trn_bench::format::px;
use trn_bench::report::SnapshotPoint;
use trn_bench::schedule::Plan;
use trn_bench::spec::{Command, Profile, RunSpec};
use trn_bench::{LabError as Error, Result};

/// What `trn lifelong` runs.
#[derive(Debug, Clone, PartialEq)]
pub struct LifelongSpec {
    /// Seed of the runs.
    pub seed: u64,
    /// Trials per network, in all.
    pub trials: usize,
    /// Training trials before the frozen network stops learning.
    pub initial: usize,
    /// A snapshot evaluation every this many trials.
    pub snapshot_every: usize,
    /// Held-out targets per network in each snapshot.
    pub snapshot_targets: usize,
    /// Held-out grasps in each snapshot.
    pub snapshot_grasps: usize,
    /// The plant (a built-in name or a file).
    pub config: String,
    /// Only these controllers (keys of [`ARMS`]).
    pub only: Vec<String>,
    /// Where lifelong.json goes.
    pub out: PathBuf,
}

/// One controller of the scenario.
#[derive(Debug, Clone, Copy)]
pub struct Arm {
    /// Its key for `--only`.
    pub key: &'static str,
    /// Its name in the table.
    pub name: &'static str,
    /// Controller preset.
    pub preset: Preset,
    /// Control law.
    pub law: ControllerChoice,
    /// Learning stops after the initial training.
    pub frozen: bool,
}

/// The scenario's controllers.
pub const ARMS: [Arm; 4] = [
    Arm {
        key: "frozen",
        name: "project, frozen after the initial training",
        preset: Preset::Project,
        law: ControllerChoice::Trn,
        frozen: true,
    },
    Arm {
        key: "project",
        name: "project preset (decaying rates)",
        preset: Preset::Project,
        law: ControllerChoice::Trn,
        frozen: false,
    },
    Arm {
        key: "lifelong",
        name: "lifelong preset (rate floor)",
        preset: Preset::Lifelong,
        law: ControllerChoice::Trn,
        frozen: false,
    },
    Arm {
        key: "broyden",
        name: "Broyden servo (no training)",
        preset: Preset::Project,
        law: ControllerChoice::Broyden,
        frozen: false,
    },
];

/// One controller's snapshots.
#[derive(Debug, Clone, Serialize)]
pub struct Curve {
    /// The controller's key.
    pub key: String,
    /// Its name.
    pub name: String,
    /// The snapshots, in order.
    pub snapshots: Vec<SnapshotPoint>,
    /// Trials of the run that failed (training, snapshots and the final evaluation).
    pub failed_trials: usize,
    /// Wall time of the run (s).
    pub wall_s: f64,
}

impl Curve {
    /// Measured combined error after the fixed budget over its noise floor, per snapshot.
    pub fn ratios(&self) -> Vec<(usize, f32)> {
        self.snapshots
            .iter()
            .map(|p| {
                let last = p.combined_measured_px.last().copied().unwrap_or(f32::NAN);
                (p.trial, last / p.noise_floor_px)
            })
            .collect()
    }

    /// The worst ratio and the lowest grasp success over the snapshots after `after` trials
    /// (NaN when there is none).
    pub fn worst_after(&self, after: usize) -> (f32, f32) {
        let late = |t: usize| t > after;
        let ratio = self
            .ratios()
            .into_iter()
            .filter(|(t, _)| late(*t))
            .map(|(_, r)| r)
            .fold(f32::NAN, |a, r| if a.is_nan() || r > a { r } else { a });
        let grasp = self
            .snapshots
            .iter()
            .filter(|p| late(p.trial))
            .map(|p| p.grasp_success)
            .fold(f32::NAN, |a, g| if a.is_nan() || g < a { g } else { a });
        (ratio, grasp)
    }
}

/// The arms `only` names, in the scenario's order; an unknown name is an error.
pub fn select(only: &[String]) -> Result<Vec<Arm>> {
    if let Some(bad) = only
        .iter()
        .find(|k| !ARMS.iter().any(|a| a.key == k.as_str()))
    {
        return Err(Error::Usage(format!(
            "--only: unknown controller {bad:?} (frozen, project, lifelong, broyden)"
        )));
    }
    Ok(ARMS
        .into_iter()
        .filter(|a| only.iter().any(|k| k == a.key))
        .collect())
}

/// The run of one arm.
pub fn arm_run(a: &LifelongSpec, arm: &Arm) -> Result<RunSpec> {
    let mut spec = RunSpec::new(Command::Train, a.seed).with_plant(Some(&a.config))?;
    spec.profile = Profile {
        preset: arm.preset,
        ablation: Ablation::None,
        law: arm.law,
    };
    spec.plan = Plan {
        snapshot_every: a.snapshot_every,
        snapshot_targets: a.snapshot_targets,
        snapshot_grasps: a.snapshot_grasps,
        learn_trials: arm.frozen.then_some(a.initial),
        ..Plan::new(a.trials, a.snapshot_targets, a.snapshot_grasps)
    };
    Ok(spec)
}

impl LifelongSpec {
    /// The scenario as a study: one run per controller of `only`, in the scenario's order.
    /// Refuses a plant that cannot be loaded, more initial trials than trials and an
    /// unknown controller before anything runs or is written.
    pub fn study(&self) -> Result<Study> {
        trn_plant::SimConfig::resolve(Some(std::path::Path::new(&self.config)))?;
        if self.initial > self.trials {
            return Err(Error::Usage(format!(
                "--initial {} is more than --trials {}",
                self.initial, self.trials
            )));
        }
        let runs = select(&self.only)?
            .iter()
            .map(|arm| {
                let row = Row {
                    name: arm.name.into(),
                    key: arm.key.into(),
                };
                arm_run(self, arm).map(|spec| (row, spec))
            })
            .collect::<Result<Vec<_>>>()?;
        let table = LifelongTable {
            seed: self.seed,
            config: self.config.clone(),
            trials: self.trials,
            initial: self.initial,
            snapshot_every: self.snapshot_every,
            snapshot_targets: self.snapshot_targets,
            snapshot_grasps: self.snapshot_grasps,
        };
        Ok(Study::new("lifelong", Table::Lifelong, Some(table), runs))
    }
}

/// The curves of the scenario's runs, in the study's order.
pub fn curves(files: &[RunFile]) -> Vec<Curve> {
    files
        .iter()
        .map(|f| Curve {
            key: f.row.key.clone(),
            name: f.row.name.clone(),
            snapshots: f.report.learning_curve.clone(),
            failed_trials: f.report.failed_trials,
            wall_s: f.report.wall_s,
        })
        .collect()
}

/// The scenario's tables and JSON (its curves) from every run of the study.
pub fn finish(header: &StudyHeader, files: &[RunFile]) -> Result<Finished> {
    let t = header.lifelong.as_ref().ok_or_else(|| {
        Error::Usage(format!(
            "study {}: a life-long study without its parameters",
            header.name
        ))
    })?;
    let curves = curves(files);
    Ok(Finished {
        table: table(&curves, t),
        json: serde_json::to_value(&curves).map_err(|e| Error::Usage(e.to_string()))?,
        files: files.to_vec(),
    })
}

/// The line of one finished run (progress off a terminal).
pub fn line(f: &RunFile) -> String {
    let initial = f.study.lifelong.as_ref().map_or(0, |t| t.initial);
    let c = &curves(std::slice::from_ref(f))[0];
    let (ratio, grasp) = c.worst_after(initial);
    format!(
        "{}: worst after {initial} trials: {} x the floor, grasps {}",
        c.key,
        px(ratio),
        percent(grasp)
    )
}

/// The markdown tables: per snapshot and controller the measured combined error after the
/// budget over the noise floor and the grasp success; then each controller's worst after
/// the initial training.
pub fn table(curves: &[Curve], a: &LifelongTable) -> String {
    use std::fmt::Write;
    let mut out = String::new();
    let _ = writeln!(
        out,
        "Seed {}, configuration `{}`, {} trials per network, a snapshot every {} trials ({} held-out targets per network, coarse + 6 fine moves; {} held-out grasps, stop rule). Each cell: measured combined error after the budget / camera-noise floor, grasp success.",
        a.seed,
        a.config,
        a.trials,
        a.snapshot_every,
        a.snapshot_targets,
        a.snapshot_grasps
    );
    out.push('\n');
    let head: Vec<&str> = curves.iter().map(|c| c.name.as_str()).collect();
    let _ = writeln!(out, "| trials | {} |", head.join(" | "));
    let _ = writeln!(out, "|---|{}", "---|".repeat(curves.len()));
    let n = curves.iter().map(|c| c.snapshots.len()).max().unwrap_or(0);
    for i in 0..n {
        let trial = curves
            .iter()
            .find_map(|c| c.snapshots.get(i).map(|p| p.trial))
            .unwrap_or(0);
        let cells: Vec<String> = curves
            .iter()
            .map(|c| match (c.snapshots.get(i), c.ratios().get(i)) {
                (Some(p), Some((_, r))) => {
                    let unreachable = if p.grasps_unreachable > 0 {
                        format!(" ({} unreachable)", p.grasps_unreachable)
                    } else {
                        String::new()
                    };
                    format!("{}x, {}{unreachable}", px(*r), percent(p.grasp_success))
                }
                _ => "-".into(),
            })
            .collect();
        let _ = writeln!(out, "| {trial} | {} |", cells.join(" | "));
    }
    out.push('\n');
    let _ = writeln!(
        out,
        "| controller | worst error / floor after {} trials | lowest grasp success after {} trials | failed trials |",
        a.initial, a.initial
    );
    out.push_str("|---|---|---|---|\n");
    for c in curves {
        let (ratio, grasp) = c.worst_after(a.initial);
        let _ = writeln!(
            out,
            "| {} | {}x | {} | {} |",
            c.name,
            px(ratio),
            percent(grasp),
            c.failed_trials
        );
    }
    out
}

/// A fraction as a percentage with one decimal, `n/a` when there is none (no snapshot after
/// the initial training).
fn percent(x: f32) -> String {
    if x.is_finite() {
        format!("{:.1} %", 100.0 * x)
    } else {
        "n/a".into()
    }
}
