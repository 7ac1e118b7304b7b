//! `trn compare`: both presets and the ablations over several seeds, as the README table.

use super::cli::{Ablation, Common, CompareArgs, Preset};
use super::report::mean;
use super::run::run_plan;
use super::schedule::Plan;
use super::summary::trials_to_reach;
use crate::error::{Error, Result};
use serde::Serialize;

/// One row of the comparison: a configuration over the seeds.
#[derive(Debug, Clone, Serialize)]
pub struct Row {
    /// Preset and ablation.
    pub name: String,
    /// Seeds run.
    pub seeds: Vec<u64>,
    /// Combined final error per seed (noisy, px).
    pub final_error_px: Vec<f32>,
    /// Combined final error per seed (noise-free, px).
    pub final_error_true_px: Vec<f32>,
    /// Noise floor per seed (px).
    pub noise_floor_px: Vec<f32>,
    /// Mean fine moves per seed (mature).
    pub fine_moves: Vec<f32>,
    /// Trials until stage 1 stays below 3 px (None: never).
    pub stage1_below_3px: Vec<Option<usize>>,
    /// Trials until stage 2 stays below 3 px.
    pub stage2_below_3px: Vec<Option<usize>>,
    /// Grasp success rate per seed.
    pub grasp_success: Vec<f32>,
    /// Wall time per seed (s).
    pub wall_s: Vec<f64>,
}

fn spread(x: &[f32]) -> (f32, f32) {
    let m = mean(x);
    let var = if x.len() > 1 {
        x.iter().map(|v| (v - m) * (v - m)).sum::<f32>() / (x.len() - 1) as f32
    } else {
        0.0
    };
    (m, var.sqrt())
}

/// Runs every configuration over seeds 1..=N and prints a markdown table.
pub fn run(a: &CompareArgs) -> Result<()> {
    let configs = [
        (Preset::Project, Ablation::None),
        (Preset::Paper, Ablation::None),
        (Preset::Project, Ablation::NoNeighbourhood),
        (Preset::Project, Ablation::NoPriming),
        (Preset::Project, Ablation::NoFine),
    ];
    let mut rows = vec![];
    for (preset, ablation) in configs {
        let name = match ablation {
            Ablation::None => preset.name().to_string(),
            a => format!("{} {}", preset.name(), a.name().replace('-', "")),
        };
        let mut row = Row {
            name,
            seeds: vec![],
            final_error_px: vec![],
            final_error_true_px: vec![],
            noise_floor_px: vec![],
            fine_moves: vec![],
            stage1_below_3px: vec![],
            stage2_below_3px: vec![],
            grasp_success: vec![],
            wall_s: vec![],
        };
        for seed in 1..=a.seeds {
            let common = Common::inproc(seed, preset, ablation);
            let plan = Plan {
                trials: a.trials,
                eval_targets: 100,
                grasps: 50,
            };
            let r = run_plan(&common, plan, None, None, "compare")?;
            eprintln!(
                "{} seed {seed}: final {:.2} px, wall {:.1} s",
                row.name, r.final_error_px, r.wall_s
            );
            row.seeds.push(seed);
            row.final_error_px.push(r.final_error_px);
            row.final_error_true_px.push(r.final_error_true_px);
            row.noise_floor_px.push(r.noise_floor_px);
            row.fine_moves.push(r.fine_moves_mean);
            row.stage1_below_3px
                .push(trials_to_reach(&r.stage1_error_px, 3.0));
            row.stage2_below_3px
                .push(trials_to_reach(&r.stage2_error_px, 3.0));
            row.grasp_success.push(r.grasp_success_rate);
            row.wall_s.push(r.wall_s);
        }
        rows.push(row);
    }
    println!("| configuration | final error px (noisy) | final error px (true) | noise floor px | fine moves | stage 1 < 3 px by trial | stage 2 < 3 px by trial | grasp success |");
    println!("|---|---|---|---|---|---|---|---|");
    for r in &rows {
        let ms = |x: &[f32]| {
            let (m, s) = spread(x);
            format!("{m:.2} ± {s:.2}")
        };
        let reach = |x: &[Option<usize>]| {
            x.iter()
                .map(|v| v.map(|n| n.to_string()).unwrap_or_else(|| "-".into()))
                .collect::<Vec<_>>()
                .join(", ")
        };
        let success: Vec<f32> = r.grasp_success.iter().map(|x| 100.0 * x).collect();
        println!(
            "| {} | {} | {} | {} | {} | {} | {} | {} % |",
            r.name,
            ms(&r.final_error_px),
            ms(&r.final_error_true_px),
            ms(&r.noise_floor_px),
            ms(&r.fine_moves),
            reach(&r.stage1_below_3px),
            reach(&r.stage2_below_3px),
            ms(&success)
        );
    }
    if let Some(p) = &a.report {
        let json = serde_json::to_string_pretty(&rows).map_err(|e| Error::Io {
            path: p.clone(),
            source: e.into(),
        })?;
        std::fs::write(p, json).map_err(|source| Error::Io {
            path: p.clone(),
            source,
        })?;
    }
    Ok(())
}
