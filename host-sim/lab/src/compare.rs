//! `trn compare`: the presets, ablations and baselines over seeds from 100 up (tuning never
//! used them), on the honest protocol: deployment-style held-out targets, a fixed move
//! budget, failures counted. The configurations are a study file, `studies/compare.toml`
//! (built in; `--study FILE` another); the table is docs/results.md's (recorded in
//! docs/results/compare.md), each cell the mean ± the standard deviation over the seeds with
//! the worst seed beside it, and the per-target measured errors after the budget of every
//! seed pooled into percentiles.

use std::path::PathBuf;

use serde::{Deserialize, Serialize};

use super::report::Report;
use super::summary::px;
use crate::error::Result;
use crate::study::file::{Overrides, StudyFile};
use crate::study::stats::{Spread, Tail, Worse};
use crate::study::{Finished, RunFile, Study};

/// The built-in comparison: `studies/compare.toml`.
pub const STUDY: &str = include_str!("../../../studies/compare.toml");

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
        let (file, dir) = match &self.study {
            Some(p) => (StudyFile::read(p)?, parent(p)),
            None => (
                StudyFile::parse(STUDY, "studies/compare.toml")?,
                PathBuf::from("."),
            ),
        };
        file.study(&dir, &self.over, Some(&self.out))
    }
}

/// The directory of a file (`.` for a bare name).
pub(crate) fn parent(p: &std::path::Path) -> PathBuf {
    match p.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
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
    /// Wall time (s).
    pub wall_s: f64,
}

impl SeedFigures {
    /// The figures of one run's report.
    pub fn of(seed: u64, r: &Report) -> SeedFigures {
        let d = &r.deployment;
        let coarse = |p: Option<&super::report::SnapshotPoint>| {
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
    /// Grasp success (fraction; the worst seed is the lowest).
    pub grasp_success: Spread,
    /// The measured combined error after the budget over every held-out target of every
    /// seed (the tail of the distribution, not the seeds' means).
    pub measured_after_budget_by_target_px: Tail,
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
            grasp_success: Spread::of(&col(&|s| s.grasp_success), Worse::Lower),
            measured_after_budget_by_target_px: Tail::of(&pooled),
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

/// The runs of a study grouped by row, in the study's order.
pub(crate) fn by_row(files: &[RunFile]) -> Vec<Vec<&RunFile>> {
    let mut rows: Vec<Vec<&RunFile>> = vec![];
    for f in files {
        match rows.iter_mut().find(|r| r[0].row == f.row) {
            Some(r) => r.push(f),
            None => rows.push(vec![f]),
        }
    }
    rows
}

/// The comparison's rows, table and JSON from every run of the study.
pub fn finish(files: &[RunFile]) -> Result<Finished> {
    let rows: Vec<Row> = by_row(files).iter().map(|r| Row::of(r)).collect();
    Ok(Finished {
        table: table(&rows),
        json: serde_json::to_value(&rows).map_err(|e| crate::LabError::Usage(e.to_string()))?,
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

/// The markdown table of `rows`: each cell the mean ± the standard deviation over the seeds
/// and, in brackets, the worst seed; the last column the per-target tail.
pub fn table(rows: &[Row]) -> String {
    let mut out = String::new();
    out.push_str("| configuration | training trials | combined true px: coarse | after 1 fine | after 2 fine | after 6 fine | measured after 6 / noise floor px | fine moves to 2 px | fine moves, stop rule | simulated s per target, stop rule | grasp success % | failed trials | measured after 6 per target: p50 / p90 / max px |\n");
    out.push_str("|---|---|---|---|---|---|---|---|---|---|---|---|---|\n");
    for r in rows {
        let s = &r.summary;
        let at = |m: usize| s.combined_true_px.get(m).map_or("n/a".into(), Spread::cell);
        let last = s.combined_true_px.last().map_or("n/a".into(), Spread::cell);
        let mut grasp = s.grasp_success;
        for v in [&mut grasp.mean, &mut grasp.sd, &mut grasp.worst] {
            *v *= 100.0;
        }
        out.push_str(&format!(
            "| {} | {} | {} | {} | {} | {} | {} / {} | {} | {} | {} | {} | {} | {} |\n",
            r.name,
            r.seeds.first().map_or(0, |s| s.training_trials),
            at(0),
            at(1),
            at(2),
            last,
            s.measured_after_budget_px.cell(),
            px(s.noise_floor_px.mean),
            s.moves_to_2px.cell(),
            s.fine_moves_stop_rule.cell(),
            s.sim_s_per_target_stop_rule.cell(),
            grasp.cell(),
            s.failed_trials,
            s.measured_after_budget_by_target_px.cell(),
        ));
    }
    if let Some(oracle) = rows.iter().find(|r| r.law == "oracle") {
        out.push('\n');
        out.push_str(&ratio_table(rows, oracle));
    }
    out
}

/// Every row's means as a ratio to the oracle's (the physical limit): 1.00 is as good as
/// possible on this plant; errors and moves above 1 are worse, grasp success below 1.
pub fn ratio_table(rows: &[Row], oracle: &Row) -> String {
    let o = &oracle.summary;
    let ratio = |a: f32, b: f32| {
        if a.is_finite() && b.is_finite() && b > 0.0 {
            format!("{:.2}", a / b)
        } else {
            "n/a".into()
        }
    };
    let at = |s: &Summary, m: usize| s.combined_true_px.get(m).map_or(f32::NAN, |v| v.mean);
    let last = |s: &Summary| s.combined_true_px.last().map_or(f32::NAN, |v| v.mean);
    let mut out = String::from("As a ratio to the oracle's mean (the physical limit on this plant; worst seed's value over the oracle's worst in brackets for the measured error):\n\n");
    out.push_str("| configuration | combined true: coarse | after 2 fine | after 6 fine | measured after 6 | measured after 6 per target p90 | fine moves, stop rule | simulated s per target | grasp success |\n");
    out.push_str("|---|---|---|---|---|---|---|---|---|\n");
    for r in rows {
        let s = &r.summary;
        out.push_str(&format!(
            "| {} | {} | {} | {} | {} ({}) | {} | {} | {} | {} |\n",
            r.name,
            ratio(at(s, 0), at(o, 0)),
            ratio(at(s, 2), at(o, 2)),
            ratio(last(s), last(o)),
            ratio(
                s.measured_after_budget_px.mean,
                o.measured_after_budget_px.mean
            ),
            ratio(
                s.measured_after_budget_px.worst,
                o.measured_after_budget_px.worst
            ),
            ratio(
                s.measured_after_budget_by_target_px.p90,
                o.measured_after_budget_by_target_px.p90
            ),
            ratio(s.fine_moves_stop_rule.mean, o.fine_moves_stop_rule.mean),
            ratio(
                s.sim_s_per_target_stop_rule.mean,
                o.sim_s_per_target_stop_rule.mean
            ),
            ratio(s.grasp_success.mean, o.grasp_success.mean),
        ));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::study::file::Overrides;
    use trn_controller::presets::{Ablation, Preset};
    use trn_controller::Law;

    /// The table of the comparison before it became a study file (name, preset, ablation,
    /// law, training trials at 300) and the oracle's row added since: `studies/compare.toml`
    /// must describe exactly these runs, so the published figures stand.
    const BEFORE: [(&str, Preset, Ablation, Law, usize); 9] = [
        ("project", Preset::Project, Ablation::None, Law::Trn, 300),
        ("paper", Preset::Paper, Ablation::None, Law::Trn, 300),
        (
            "project, no-neighbourhood (plain VQ table)",
            Preset::Project,
            Ablation::NoNeighbourhood,
            Law::Trn,
            300,
        ),
        (
            "project, no-priming",
            Preset::Project,
            Ablation::NoPriming,
            Law::Trn,
            300,
        ),
        (
            "project, no-fine",
            Preset::Project,
            Ablation::NoFine,
            Law::Trn,
            300,
        ),
        (
            "project, no-trial-secant",
            Preset::Project,
            Ablation::NoTrialSecant,
            Law::Trn,
            300,
        ),
        (
            "Broyden servo (no training)",
            Preset::Project,
            Ablation::None,
            Law::Broyden,
            0,
        ),
        (
            "nominal inverse kinematics (calibrated model, no learning)",
            Preset::Project,
            Ablation::None,
            Law::Model,
            0,
        ),
        (
            "oracle (exact copy of the plant: the physical limit)",
            Preset::Project,
            Ablation::None,
            Law::Oracle,
            0,
        ),
    ];

    #[test]
    fn the_study_file_is_the_table_it_replaced() {
        let spec = CompareSpec {
            study: None,
            over: Overrides::default(),
            out: std::env::temp_dir(),
        };
        let s = spec.study().unwrap();
        assert_eq!(s.jobs.len(), BEFORE.len() * 10);
        for (i, (name, preset, ablation, law, trials)) in BEFORE.into_iter().enumerate() {
            for (k, seed) in (100..110).enumerate() {
                let j = &s.jobs[i * 10 + k];
                assert_eq!(j.row.name, name);
                let mut old = crate::RunSpec::new(crate::Command::Train, seed);
                old.profile = crate::Profile {
                    preset,
                    ablation,
                    law,
                };
                old.plan = crate::schedule::Plan::new(trials, 100, 50);
                let mut new = j.spec.clone();
                assert_eq!(new.plant_name.take().as_deref(), Some("realistic"));
                assert_eq!(new, old, "{name} seed {seed}");
            }
        }
        // --project-only is --configs project; --eval-targets and --grasps size the base
        let over = Overrides {
            configs: vec!["project".into(), "broyden".into()],
            seeds: Some(2),
            eval_targets: Some(7),
            grasps: Some(3),
            trials: Some(40),
            ..Overrides::default()
        };
        let s = CompareSpec { over, ..spec }.study().unwrap();
        let rows: Vec<(&str, u64, usize, usize, usize)> = s
            .jobs
            .iter()
            .map(|j| {
                (
                    j.row.key.as_str(),
                    j.spec.seed,
                    j.spec.plan.trials,
                    j.spec.plan.eval_targets,
                    j.spec.plan.grasps,
                )
            })
            .collect();
        assert_eq!(
            rows,
            [
                ("project", 100, 40, 7, 3),
                ("project", 101, 40, 7, 3),
                ("broyden", 100, 0, 7, 3),
                ("broyden", 101, 0, 7, 3)
            ]
        );
    }

    fn row(name: &str, law: &str, px_: f32, moves: f32, grasps: f32) -> Row {
        let hi = |v: f32| Spread::of(&[v], Worse::Higher);
        Row {
            name: name.into(),
            law: law.into(),
            seeds: vec![],
            summary: Summary {
                combined_true_px: vec![hi(10.0 * px_), hi(2.0 * px_), hi(px_)],
                measured_after_budget_px: hi(px_),
                noise_floor_px: hi(1.0),
                moves_to_2px: hi(moves),
                fine_moves_stop_rule: hi(moves),
                sim_s_per_target_stop_rule: hi(moves),
                grasp_success: Spread::of(&[grasps], Worse::Lower),
                measured_after_budget_by_target_px: Tail::of(&[px_]),
                failed_trials: 0,
            },
        }
    }

    #[test]
    fn the_table_has_a_ratio_to_the_oracle_when_it_has_its_row() {
        let rows = [
            row("net", "trn", 3.0, 4.0, 0.8),
            row("limit", "oracle", 1.5, 0.5, 1.0),
        ];
        let t = table(&rows);
        let ratios = t
            .split("As a ratio to the oracle")
            .nth(1)
            .expect("ratio table");
        let net = ratios.lines().find(|l| l.starts_with("| net |")).unwrap();
        assert_eq!(
            net,
            "| net | 2.00 | 2.00 | 2.00 | 2.00 (2.00) | 2.00 | 8.00 | 8.00 | 0.80 |"
        );
        assert!(ratios
            .contains("| limit | 1.00 | 1.00 | 1.00 | 1.00 (1.00) | 1.00 | 1.00 | 1.00 | 1.00 |"));
        assert!(!table(&rows[..1]).contains("As a ratio"));
    }
}
