//! `trn lifelong`: life-long learning under temperature drift and wear (issue 17). Each
//! controller runs the same thousands of trials on the same aging plant (the `aging`
//! configuration by default: [`crate::plant::SimConfig::aging`]), with a frozen snapshot
//! evaluation every few hundred trials: the held-out deployment targets with the fixed move
//! budget and the held-out grasps with the stop rule, on a copy of the plant in its present
//! state of drift and wear. The controllers:
//! - `frozen`: the project preset, learning only for its first `--initial` trials; the
//!   remaining trials still move the arm (so it wears as the others do) without learning;
//! - `project`: the project preset learning throughout (its rates decay with time);
//! - `lifelong`: the lifelong preset (the project's with a floor on the rates);
//! - `broyden`: the Broyden servo, which never trains.

use serde::Serialize;

use super::cli::{Ablation, Common, Controller, LifelongArgs, Preset};
use super::report::SnapshotPoint;
use super::run::{load_sim_config, run_plan};
use super::schedule::Plan;
use super::summary::px;
use crate::error::{io, Error, Result};

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
    pub controller: Controller,
    /// Learning stops after the initial training.
    pub frozen: bool,
}

/// The scenario's controllers.
pub const ARMS: [Arm; 4] = [
    Arm {
        key: "frozen",
        name: "project, frozen after the initial training",
        preset: Preset::Project,
        controller: Controller::Trn,
        frozen: true,
    },
    Arm {
        key: "project",
        name: "project preset (decaying rates)",
        preset: Preset::Project,
        controller: Controller::Trn,
        frozen: false,
    },
    Arm {
        key: "lifelong",
        name: "lifelong preset (rate floor)",
        preset: Preset::Lifelong,
        controller: Controller::Trn,
        frozen: false,
    },
    Arm {
        key: "broyden",
        name: "Broyden servo (no training)",
        preset: Preset::Project,
        controller: Controller::Broyden,
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
        return Err(Error::Config(format!(
            "--only: unknown controller {bad:?} (frozen, project, lifelong, broyden)"
        )));
    }
    Ok(ARMS
        .into_iter()
        .filter(|a| only.iter().any(|k| k == a.key))
        .collect())
}

/// The run of one arm: its options and plan.
pub fn arm_run(a: &LifelongArgs, arm: &Arm) -> (Common, Plan) {
    let common = Common {
        config: Some(a.config.clone()),
        controller: arm.controller,
        eval_targets: a.snapshot_targets,
        grasps: a.snapshot_grasps,
        ..Common::inproc(a.seed, arm.preset, Ablation::None)
    };
    let plan = Plan {
        snapshot_every: a.snapshot_every as usize,
        snapshot_targets: a.snapshot_targets,
        snapshot_grasps: a.snapshot_grasps,
        learn_trials: arm.frozen.then_some(a.initial),
        ..Plan::new(a.trials as usize, a.snapshot_targets, a.snapshot_grasps)
    };
    (common, plan)
}

/// Runs the scenario, prints the table and writes lifelong.json (and the plot).
pub fn run(a: &LifelongArgs) -> Result<()> {
    load_sim_config(Some(&a.config))?;
    if a.initial as u64 > a.trials {
        return Err(Error::Config(format!(
            "--initial {} is more than --trials {}",
            a.initial, a.trials
        )));
    }
    let arms = select(&a.only)?;
    std::fs::create_dir_all(&a.out).map_err(io(&a.out))?;
    let mut curves = vec![];
    for arm in &arms {
        let (common, plan) = arm_run(a, arm);
        let r = run_plan(&common, plan, None, None, "lifelong")?;
        let curve = Curve {
            key: arm.key.into(),
            name: arm.name.into(),
            snapshots: r.learning_curve,
            failed_trials: r.failed_trials,
            wall_s: r.wall_s,
        };
        let (ratio, grasp) = curve.worst_after(a.initial);
        eprintln!(
            "{}: worst after {} trials: {} x the floor, grasps {:.1} %, wall {:.0} s",
            arm.key,
            a.initial,
            px(ratio),
            100.0 * grasp,
            r.wall_s
        );
        curves.push(curve);
    }
    print_table(&curves, a);
    let out = a.out.join("lifelong.json");
    let json = serde_json::to_string_pretty(&curves).map_err(|e| Error::Io {
        path: out.clone(),
        source: e.into(),
    })?;
    std::fs::write(&out, json).map_err(io(&out))?;
    #[cfg(feature = "plot")]
    plot(&curves, &a.out.join("lifelong.png"))?;
    Ok(())
}

/// The markdown tables: per snapshot and controller the measured combined error after the
/// budget over the noise floor and the grasp success; then each controller's worst after
/// the initial training.
pub fn print_table(curves: &[Curve], a: &LifelongArgs) {
    println!(
        "Seed {}, configuration `{}`, {} trials per network, a snapshot every {} trials ({} held-out targets per network, coarse + 6 fine moves; {} held-out grasps, stop rule). Each cell: measured combined error after the budget / camera-noise floor, grasp success.",
        a.seed,
        a.config.display(),
        a.trials,
        a.snapshot_every,
        a.snapshot_targets,
        a.snapshot_grasps
    );
    println!();
    let head: Vec<&str> = curves.iter().map(|c| c.name.as_str()).collect();
    println!("| trials | {} |", head.join(" | "));
    println!("|---|{}", "---|".repeat(curves.len()));
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
                    format!("{}x, {:.0} %{unreachable}", px(*r), 100.0 * p.grasp_success)
                }
                _ => "-".into(),
            })
            .collect();
        println!("| {trial} | {} |", cells.join(" | "));
    }
    println!();
    println!(
        "| controller | worst error / floor after {} trials | lowest grasp success after {} trials | failed trials |",
        a.initial, a.initial
    );
    println!("|---|---|---|---|");
    for c in curves {
        let (ratio, grasp) = c.worst_after(a.initial);
        println!(
            "| {} | {}x | {:.1} % | {} |",
            c.name,
            px(ratio),
            100.0 * grasp,
            c.failed_trials
        );
    }
}

/// Error over the floor and grasp success against trials, one line per controller.
#[cfg(feature = "plot")]
fn plot(curves: &[Curve], path: &std::path::Path) -> Result<()> {
    use plotters::prelude::*;
    let err =
        |e: &dyn std::fmt::Display| Error::Plot(format!("cannot draw {}: {e}", path.display()));
    let draw = || -> std::result::Result<(), Box<dyn std::error::Error>> {
        let root = BitMapBackend::new(path, (1200, 500)).into_drawing_area();
        root.fill(&WHITE)?;
        let (left, right) = root.split_horizontally(600);
        let xmax = curves
            .iter()
            .flat_map(|c| c.snapshots.last().map(|p| p.trial))
            .max()
            .unwrap_or(1) as f32;
        let colours = [RED, BLUE, GREEN, MAGENTA];
        let ymax = curves
            .iter()
            .flat_map(|c| c.ratios())
            .map(|(_, r)| r)
            .filter(|r| r.is_finite())
            .fold(2.0f32, f32::max)
            .min(20.0);
        let mut chart = ChartBuilder::on(&left)
            .caption("error after the budget / noise floor", ("sans-serif", 18))
            .margin(10)
            .x_label_area_size(35)
            .y_label_area_size(45)
            .build_cartesian_2d(0f32..xmax * 1.02, 0.8f32..ymax * 1.1)?;
        chart.configure_mesh().x_desc("trials per network").draw()?;
        for (c, colour) in curves.iter().zip(colours) {
            let pts: Vec<(f32, f32)> = c
                .ratios()
                .into_iter()
                .filter(|(_, r)| r.is_finite())
                .map(|(t, r)| (t as f32, r))
                .collect();
            chart
                .draw_series(LineSeries::new(pts, colour.stroke_width(2)))?
                .label(c.name.clone())
                .legend(move |(x, y)| PathElement::new(vec![(x, y), (x + 20, y)], colour));
        }
        chart
            .configure_series_labels()
            .border_style(BLACK)
            .background_style(WHITE.mix(0.8))
            .draw()?;
        let mut chart = ChartBuilder::on(&right)
            .caption("grasp success (%)", ("sans-serif", 18))
            .margin(10)
            .x_label_area_size(35)
            .y_label_area_size(45)
            .build_cartesian_2d(0f32..xmax * 1.02, 0f32..102f32)?;
        chart.configure_mesh().x_desc("trials per network").draw()?;
        for (c, colour) in curves.iter().zip(colours) {
            let pts: Vec<(f32, f32)> = c
                .snapshots
                .iter()
                .filter(|p| p.grasp_success.is_finite())
                .map(|p| (p.trial as f32, 100.0 * p.grasp_success))
                .collect();
            chart.draw_series(LineSeries::new(pts, colour.stroke_width(2)))?;
        }
        root.present()?;
        Ok(())
    };
    draw().map_err(|e| err(&e))
}
