//! `trn compare`: the presets, ablations and baselines over seeds from 100 up (tuning never
//! used them), on the honest protocol: deployment-style held-out targets, a fixed move
//! budget, failures counted. The configurations are a study file, `studies/compare.toml`
//! (built in; `--study FILE` another); the table is docs/results.md's (recorded in
//! docs/results/compare.md), each cell the mean ± the standard deviation over the seeds with
//! the worst seed beside it, and the per-target measured errors after the budget of every
//! seed pooled into percentiles.

mod tables;

use std::path::PathBuf;

use serde::{Deserialize, Serialize};

use crate::study::file::{Overrides, StudyFile};
use crate::study::runfile::by_row;
use crate::study::stats::{Spread, Tail, Worse};
use crate::study::{Finished, RunFile, Study};
pub use tables::{ratio_table, table};
use trn_bench::format::px;
use trn_bench::fsio::parent;
use trn_bench::report::Report;
use trn_bench::Result;

/// The built-in comparison: `studies/compare.toml`.
pub const STUDY: &str = include_str!("../../../../studies/compare.toml");

/// What `trn compare` runs.
#[derive(Debug, Clone, PartialEq)]
pub struct CompareSpec {
    /// The study file (`None`: the built-in `studies/compare.toml`).
    pub study: Option<PathBuf>,
    /// What the command line changes in it (rows, seeds, trials, the plant, the
    /// evaluation's size).
    pub over: Overrides,
    /// Where plants made of keys go (`KEY.toml`).
    pub out: PathBuf,
}

impl CompareSpec {
    /// The study: its configurations over its seeds.
    pub fn study(&self) -> Result<Study> {
        self.study_unless(&|| false)
    }

    /// [`CompareSpec::study`], ended early when `stop` says so ([`StudyFile::study_unless`]).
    pub fn study_unless(&self, stop: &dyn Fn() -> bool) -> Result<Study> {
        let (file, dir) = match &self.study {
            Some(p) => (StudyFile::read(p)?, parent(p)),
            None => (
                StudyFile::parse(STUDY, "studies/compare.toml")?,
                PathBuf::from("."),
            ),
        };
        file.study_unless(&dir, &self.over, Some(&self.out), stop)
    }
}

/// The first seed of every reported table: tuning uses seeds 1-99 only.
pub const FIRST_REPORTED_SEED: u64 = 100;

/// One seed's figures of one configuration.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SeedFigures {
    /// The seed.
    pub seed: u64,
    /// Combined noise-free error after each move (0 = coarse), fixed budget.
    pub combined_true_px: Vec<f32>,
    /// Combined measured error after each move.
    pub combined_measured_px: Vec<f32>,
    /// The floor of the measured error.
    pub noise_floor_px: f32,
    /// Mean fine moves to 2 px (noise-free).
    pub moves_to_2px: f32,
    /// Fine moves per network trial with the controller's stop rule.
    pub fine_moves_stop_rule: f32,
    /// Combined final error with the stop rule, noise-free.
    pub final_true_px_stop_rule: f32,
    /// Simulated time per target with the stop rule, both networks (s).
    pub sim_s_per_target_stop_rule: f32,
    /// Grasp success rate.
    pub grasp_success: f32,
    /// Failed trials (whole run).
    pub failed_trials: usize,
    /// Coarse-move error at the first and the last snapshot (combined, noise-free).
    pub snapshot_coarse_px: (f32, f32),
    /// Training trials per network before the evaluation.
    pub training_trials: usize,
    /// The measured combined error after the budget over this seed's held-out targets.
    pub measured_after_budget_by_target_px: Tail,
    /// The 95th percentile of the measured combined error after the budget over this
    /// seed's held-out targets, over the noise floor (the tail the seed's mean hides).
    #[serde(default)]
    pub measured_p95_over_floor: f32,
    /// Wall time (s).
    pub wall_s: f64,
}

impl SeedFigures {
    /// The figures of one run's report.
    pub fn of(seed: u64, r: &Report) -> SeedFigures {
        let d = &r.deployment;
        let coarse = |p: Option<&trn_bench::report::SnapshotPoint>| {
            p.and_then(|p| p.combined_true_px.first().copied())
                .unwrap_or(f32::NAN)
        };
        SeedFigures {
            seed,
            combined_true_px: d.combined_true_px.clone(),
            combined_measured_px: d.combined_measured_px.clone(),
            noise_floor_px: d.noise_floor_px,
            moves_to_2px: d.moves_to_2px_mean,
            fine_moves_stop_rule: r.fine_moves_mean,
            final_true_px_stop_rule: r.final_error_true_px,
            sim_s_per_target_stop_rule: r.sim_time_per_target_s,
            grasp_success: r.grasp_success_rate,
            failed_trials: r.failed_trials,
            snapshot_coarse_px: (
                coarse(r.learning_curve.first()),
                coarse(r.learning_curve.last()),
            ),
            training_trials: r.trials,
            measured_after_budget_by_target_px: Tail::of(&d.combined_measured_by_target_px),
            measured_p95_over_floor: d
                .combined_measured_p95_px
                .last()
                .map_or(f32::NAN, |p| p / d.noise_floor_px),
            wall_s: r.wall_s,
        }
    }
}

/// A configuration's figures over its seeds: each column's mean, spread and worst seed.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Summary {
    /// Combined noise-free error after each move of the budget (0 = coarse).
    pub combined_true_px: Vec<Spread>,
    /// Combined measured error after the budget.
    pub measured_after_budget_px: Spread,
    /// The camera-noise floor of it.
    pub noise_floor_px: Spread,
    /// Fine moves to 2 px.
    pub moves_to_2px: Spread,
    /// Fine moves per network trial with the stop rule.
    pub fine_moves_stop_rule: Spread,
    /// Simulated seconds per target with the stop rule.
    pub sim_s_per_target_stop_rule: Spread,
    /// Combined noise-free error where the stop rule ended the trials: what the fine moves
    /// with the stop rule bought (a stop rule that stops earlier and farther off shows here).
    #[serde(default = "Spread::none")]
    pub final_true_px_stop_rule: Spread,
    /// Grasp success (fraction; the worst seed is the lowest).
    pub grasp_success: Spread,
    /// The measured combined error after the budget over every held-out target of every
    /// seed (the tail of the distribution, not the seeds' means).
    pub measured_after_budget_by_target_px: Tail,
    /// Each seed's 95th percentile of the measured error after the budget over its noise
    /// floor (the worst is the highest).
    pub measured_p95_over_floor: Spread,
    /// Failed trials over every seed.
    pub failed_trials: usize,
}

/// One row of the comparison: a configuration over the seeds.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Row {
    /// The configuration's name.
    pub name: String,
    /// Its control law (`trn`, `broyden`, `model`, `oracle`).
    pub law: String,
    /// Every seed's figures.
    pub seeds: Vec<SeedFigures>,
    /// Over the seeds.
    pub summary: Summary,
}

/// Mean and sample standard deviation of the finite values.
pub fn spread(x: &[f32]) -> (f32, f32) {
    let s = Spread::of(x, Worse::Higher);
    (s.mean, s.sd)
}

impl Row {
    /// The row of the runs `files` (one configuration's seeds).
    fn of(files: &[&RunFile]) -> Row {
        let seeds: Vec<SeedFigures> = files
            .iter()
            .map(|f| SeedFigures::of(f.report.seed, &f.report))
            .collect();
        let col = |f: &dyn Fn(&SeedFigures) -> f32| -> Vec<f32> { seeds.iter().map(f).collect() };
        let higher = |f: &dyn Fn(&SeedFigures) -> f32| Spread::of(&col(f), Worse::Higher);
        let moves = seeds
            .iter()
            .map(|s| s.combined_true_px.len())
            .max()
            .unwrap_or(0);
        let pooled: Vec<f32> = files
            .iter()
            .flat_map(|f| {
                f.report
                    .deployment
                    .combined_measured_by_target_px
                    .iter()
                    .copied()
            })
            .collect();
        let summary = Summary {
            combined_true_px: (0..moves)
                .map(|m| higher(&|s| s.combined_true_px.get(m).copied().unwrap_or(f32::NAN)))
                .collect(),
            measured_after_budget_px: higher(&|s| {
                s.combined_measured_px.last().copied().unwrap_or(f32::NAN)
            }),
            noise_floor_px: higher(&|s| s.noise_floor_px),
            moves_to_2px: higher(&|s| s.moves_to_2px),
            fine_moves_stop_rule: higher(&|s| s.fine_moves_stop_rule),
            sim_s_per_target_stop_rule: higher(&|s| s.sim_s_per_target_stop_rule),
            final_true_px_stop_rule: higher(&|s| s.final_true_px_stop_rule),
            grasp_success: Spread::of(&col(&|s| s.grasp_success), Worse::Lower),
            measured_after_budget_by_target_px: Tail::of(&pooled),
            measured_p95_over_floor: higher(&|s| s.measured_p95_over_floor),
            failed_trials: seeds.iter().map(|s| s.failed_trials).sum(),
        };
        Row {
            name: files
                .first()
                .map(|f| f.row.name.clone())
                .unwrap_or_default(),
            law: files
                .first()
                .map(|f| f.report.law.clone())
                .unwrap_or_default(),
            seeds,
            summary,
        }
    }
}

/// The comparison's rows, table and JSON from every run of the study.
pub fn finish(files: &[RunFile]) -> Result<Finished> {
    let rows: Vec<Row> = by_row(files).iter().map(|r| Row::of(r)).collect();
    Ok(Finished {
        table: table(&rows),
        json: serde_json::to_value(&rows).map_err(|e| trn_bench::LabError::Usage(e.to_string()))?,
        files: files.to_vec(),
    })
}

/// The line of one finished run (progress off a terminal).
pub fn line(f: &RunFile) -> String {
    let d = &f.report.deployment;
    let at = |m: usize| d.combined_true_px.get(m).copied().unwrap_or(f32::NAN);
    format!(
        "{} seed {}: combined true after coarse + 2 fine {} px, after {} {} px, measured / floor {} / {} px",
        f.row.name,
        f.report.seed,
        px(at(2)),
        d.fine_moves,
        px(d.combined_true_px.last().copied().unwrap_or(f32::NAN)),
        px(d.combined_measured_px.last().copied().unwrap_or(f32::NAN)),
        px(d.noise_floor_px),
    )
}

#[cfg(test)]
mod tests;
