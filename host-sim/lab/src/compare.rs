//! `trn compare`: the presets and ablations over seeds from 100 up (tuning never used them),
//! on the honest protocol: deployment-style held-out targets, a fixed move budget, failures
//! counted. Prints the README's table; `--report` writes every seed's figures as JSON.

use serde::Serialize;

use std::path::PathBuf;

use trn_controller::presets::{Ablation, Preset};
use trn_controller::Law;

use super::report::{mean, Report};
use super::schedule::Plan;
use super::summary::px;
use crate::error::Result;
use crate::spec::{Command, Profile, RunSpec};

/// What `trn compare` runs.
#[derive(Debug, Clone, PartialEq)]
pub struct CompareSpec {
    /// Seeds 100 .. 100 + N.
    pub seeds: u64,
    /// Training trials per network.
    pub trials: usize,
    /// Only the project preset.
    pub project_only: bool,
    /// The plant (`--config`: a built-in name or a file).
    pub config: Option<String>,
    /// Where every seed's figures go as JSON.
    pub report: Option<PathBuf>,
}

/// The first seed of every reported table: tuning uses seeds 1-99 only.
pub const FIRST_REPORTED_SEED: u64 = 100;

/// One seed's figures of one configuration.
#[derive(Debug, Clone, Serialize)]
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
    /// Wall time (s).
    pub wall_s: f64,
}

impl SeedFigures {
    fn of(seed: u64, r: &Report) -> SeedFigures {
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
            wall_s: r.wall_s,
        }
    }
}

/// One row of the comparison: a configuration over the seeds.
#[derive(Debug, Clone, Serialize)]
pub struct Row {
    /// Preset and ablation.
    pub name: String,
    /// Every seed's figures.
    pub seeds: Vec<SeedFigures>,
}

/// Mean and sample standard deviation of the finite values.
pub fn spread(x: &[f32]) -> (f32, f32) {
    let v: Vec<f32> = x.iter().copied().filter(|v| v.is_finite()).collect();
    let m = mean(&v);
    let var = if v.len() > 1 {
        v.iter().map(|x| (x - m) * (x - m)).sum::<f32>() / (v.len() - 1) as f32
    } else {
        f32::NAN
    };
    (m, var.sqrt())
}

fn ms(x: &[f32]) -> String {
    let (m, s) = spread(x);
    format!("{} ± {}", px(m), px(s))
}

/// One configuration of the table.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Entry {
    /// Controller preset.
    pub preset: Preset,
    /// Ablation.
    pub ablation: Ablation,
    /// Control law.
    pub law: Law,
}

impl Entry {
    const fn trn(preset: Preset, ablation: Ablation) -> Entry {
        Entry {
            preset,
            ablation,
            law: Law::Trn,
        }
    }

    /// Its name in the table.
    pub fn name(&self) -> String {
        match (self.law, self.ablation) {
            (Law::Broyden, _) => "Broyden servo (no training)".to_string(),
            (Law::Model, _) => {
                "nominal inverse kinematics (calibrated model, no learning)".to_string()
            }
            (_, Ablation::None) => self.preset.name().to_string(),
            (_, Ablation::NoNeighbourhood) => {
                format!("{}, no-neighbourhood (plain VQ table)", self.preset.name())
            }
            (_, a) => format!("{}, {}", self.preset.name(), a.name()),
        }
    }

    /// Training trials per network: none for a method that does not train.
    pub fn trials(&self, trials: usize) -> usize {
        match self.law {
            Law::Broyden | Law::Model => 0,
            Law::Trn => trials,
        }
    }
}

/// The configurations of the table.
pub const CONFIGS: [Entry; 8] = [
    Entry::trn(Preset::Project, Ablation::None),
    Entry::trn(Preset::Paper, Ablation::None),
    Entry::trn(Preset::Project, Ablation::NoNeighbourhood),
    Entry::trn(Preset::Project, Ablation::NoPriming),
    Entry::trn(Preset::Project, Ablation::NoFine),
    Entry::trn(Preset::Project, Ablation::NoTrialSecant),
    Entry {
        preset: Preset::Project,
        ablation: Ablation::None,
        law: Law::Broyden,
    },
    Entry {
        preset: Preset::Project,
        ablation: Ablation::None,
        law: Law::Model,
    },
];

/// Runs every configuration over seeds 100.. and prints a markdown table.
pub fn run(a: &CompareSpec) -> Result<()> {
    let configs: Vec<Entry> = if a.project_only {
        vec![CONFIGS[0]]
    } else {
        CONFIGS.to_vec()
    };
    let mut rows = vec![];
    for entry in configs {
        let mut row = Row {
            name: entry.name(),
            seeds: vec![],
        };
        for seed in FIRST_REPORTED_SEED..FIRST_REPORTED_SEED + a.seeds {
            let mut spec = RunSpec::new(Command::Train, seed).with_plant(a.config.as_deref())?;
            spec.profile = Profile {
                preset: entry.preset,
                ablation: entry.ablation,
                law: entry.law,
            };
            spec.plan = Plan::new(entry.trials(a.trials), 100, 50);
            let r = crate::run::run_quietly(&spec)?;
            let f = SeedFigures::of(seed, &r);
            eprintln!(
                "{} seed {seed}: combined true after coarse + 2 fine {} px, after 6 {} px, wall {:.1} s",
                row.name,
                px(f.combined_true_px.get(2).copied().unwrap_or(f32::NAN)),
                px(f.combined_true_px.last().copied().unwrap_or(f32::NAN)),
                r.wall_s
            );
            row.seeds.push(f);
        }
        rows.push(row);
    }
    print_table(&rows);
    if let Some(p) = &a.report {
        crate::output::write_json(p, &crate::provenance::Stamped::new(&rows))?;
    }
    Ok(())
}

/// The markdown table of `rows` (mean ± standard deviation over the seeds).
pub fn print_table(rows: &[Row]) {
    println!("| configuration | training trials | combined true px: coarse | after 1 fine | after 2 fine | after 6 fine | measured after 6 / noise floor px | fine moves to 2 px | fine moves, stop rule | simulated s per target, stop rule | grasp success % | failed trials |");
    println!("|---|---|---|---|---|---|---|---|---|---|---|---|");
    for r in rows {
        let col = |f: &dyn Fn(&SeedFigures) -> f32| -> Vec<f32> { r.seeds.iter().map(f).collect() };
        let at = |m: usize| col(&|s| s.combined_true_px.get(m).copied().unwrap_or(f32::NAN));
        let last = col(&|s| s.combined_measured_px.last().copied().unwrap_or(f32::NAN));
        let floor = col(&|s| s.noise_floor_px);
        println!(
            "| {} | {} | {} | {} | {} | {} | {} / {} | {} | {} | {} | {} | {} |",
            r.name,
            r.seeds.first().map_or(0, |s| s.training_trials),
            ms(&at(0)),
            ms(&at(1)),
            ms(&at(2)),
            ms(&col(&|s| s
                .combined_true_px
                .last()
                .copied()
                .unwrap_or(f32::NAN))),
            ms(&last),
            px(spread(&floor).0),
            ms(&col(&|s| s.moves_to_2px)),
            ms(&col(&|s| s.fine_moves_stop_rule)),
            ms(&col(&|s| s.sim_s_per_target_stop_rule)),
            ms(&col(&|s| 100.0 * s.grasp_success)),
            r.seeds.iter().map(|s| s.failed_trials).sum::<usize>(),
        );
    }
}
