//! `trn sweep`: the project preset on a built-in list of plant variants (hysteresis width,
//! camera noise, coupling, creep, camera outliers, damping; each changed alone from the base
//! configuration, the ideal plant unless `--config` names another; then the realistic plant
//! with all of them, and with 25 % hysteresis), on the honest protocol (deployment targets,
//! fixed move budget), over seeds from 100: how the result degrades with each effect. Each variant's configuration is
//! written as a TOML file beside the report, so every row can be rerun with `--config`.

use std::path::{Path, PathBuf};

use serde::Serialize;

use super::compare::{spread, FIRST_REPORTED_SEED};
use super::schedule::Plan;
use super::summary::px;
use crate::error::{io, LabError as Error, Result};
use crate::spec::{Command, RunSpec};
use trn_plant::SimConfig;

/// What `trn sweep` runs.
#[derive(Debug, Clone, PartialEq)]
pub struct SweepSpec {
    /// Seeds 100 .. 100 + N.
    pub seeds: u64,
    /// Training trials per network.
    pub trials: usize,
    /// The base plant the variants change (`None`: the ideal plant).
    pub config: Option<String>,
    /// Where the variants' configurations and sweep.json go.
    pub out: PathBuf,
}

/// One plant variant: a name and what it changes.
pub struct Variant {
    /// Its name in the table.
    pub name: &'static str,
    /// The change, applied to the base configuration.
    pub apply: fn(&mut SimConfig),
}

fn width(c: &mut SimConfig, w: f64) {
    c.joints.iter_mut().for_each(|j| j.hysteresis_width = w);
}

fn damping(c: &mut SimConfig, z: f64) {
    c.joints.iter_mut().for_each(|j| j.damping_ratio = z);
}

/// The built-in variants (the list).
pub const VARIANTS: &[Variant] = &[
    Variant {
        name: "base",
        apply: |_| {},
    },
    Variant {
        name: "hysteresis width 5 %",
        apply: |c| width(c, 0.05),
    },
    Variant {
        name: "hysteresis width 15 %",
        apply: |c| width(c, 0.15),
    },
    Variant {
        name: "hysteresis width 25 %",
        apply: |c| width(c, 0.25),
    },
    Variant {
        name: "camera noise 0.1 px",
        apply: |c| c.pixel_noise_px = 0.1,
    },
    Variant {
        name: "camera noise 0.5 px",
        apply: |c| c.pixel_noise_px = 0.5,
    },
    Variant {
        name: "camera noise 1 px",
        apply: |c| c.pixel_noise_px = 1.0,
    },
    Variant {
        name: "coupling (gravity sag, load-dependent width)",
        apply: |c| {
            let r = SimConfig::realistic().realism;
            c.realism.sag_shoulder_deg = r.sag_shoulder_deg;
            c.realism.sag_elbow_deg = r.sag_elbow_deg;
            c.realism.load_width_gain = r.load_width_gain;
        },
    },
    Variant {
        name: "creep",
        apply: |c| {
            let r = SimConfig::realistic().realism;
            c.realism.creep_fraction = r.creep_fraction;
            c.realism.creep_tau_s = r.creep_tau_s;
        },
    },
    Variant {
        name: "process noise",
        apply: |c| c.realism.process_noise_deg = SimConfig::realistic().realism.process_noise_deg,
    },
    Variant {
        name: "skewed loop",
        apply: |c| c.realism.hysteresis_skew = SimConfig::realistic().realism.hysteresis_skew,
    },
    Variant {
        name: "camera outliers and dropouts",
        apply: |c| {
            let r = SimConfig::realistic().realism;
            c.realism.outlier_rate = r.outlier_rate;
            c.realism.dropout_rate = r.dropout_rate;
        },
    },
    Variant {
        name: "damping 0.15",
        apply: |c| damping(c, 0.15),
    },
    Variant {
        name: "realistic (coupling, creep, process noise, skewed loop, outliers, occlusion, distortion: the runs' default)",
        apply: |c| *c = SimConfig::realistic(),
    },
    Variant {
        name: "realistic, hysteresis width 25 %",
        apply: |c| {
            *c = SimConfig::realistic();
            width(c, 0.25);
        },
    },
    Variant {
        name: "realistic, hysteresis width 25 %, loop width independent of the load",
        apply: |c| {
            *c = SimConfig::realistic();
            width(c, 0.25);
            c.realism.load_width_gain = 0.0;
        },
    },
];

/// One variant's figures over the seeds.
#[derive(Debug, Clone, Serialize)]
pub struct Row {
    /// The variant.
    pub name: String,
    /// Its configuration file.
    pub config: PathBuf,
    /// Per seed: measured combined error after the coarse move and 2 fine moves.
    pub measured_2_px: Vec<f32>,
    /// Per seed: measured combined error after the last fine move of the budget.
    pub measured_last_px: Vec<f32>,
    /// Per seed: the camera-noise floor of the measured error.
    pub floor_px: Vec<f32>,
    /// Per seed: fine moves per network trial with the stop rule.
    pub fine_moves_stop_rule: Vec<f32>,
    /// Per seed: grasp success.
    pub grasp_success: Vec<f32>,
    /// Per seed: failed trials.
    pub failed_trials: Vec<usize>,
}

/// Runs every variant and prints the table.
pub fn run(a: &SweepSpec) -> Result<()> {
    let base = match &a.config {
        Some(p) => SimConfig::resolve(Some(Path::new(p)))?,
        None => SimConfig::ideal(),
    };
    let dir = a.out.clone();
    std::fs::create_dir_all(&dir).map_err(io(&dir))?;
    let mut rows = vec![];
    for v in VARIANTS {
        let mut cfg = base.clone();
        (v.apply)(&mut cfg);
        cfg.validate()?;
        let path = dir.join(format!("{}.toml", file_name(v.name)));
        write_config(&cfg, &path)?;
        let mut row = Row {
            name: v.name.to_string(),
            config: path.clone(),
            measured_2_px: vec![],
            measured_last_px: vec![],
            floor_px: vec![],
            fine_moves_stop_rule: vec![],
            grasp_success: vec![],
            failed_trials: vec![],
        };
        for seed in FIRST_REPORTED_SEED..FIRST_REPORTED_SEED + a.seeds {
            let mut spec = RunSpec::new(Command::Train, seed);
            spec.plant = cfg.clone();
            spec.plant_name = Some(path.display().to_string());
            spec.plan = Plan::new(a.trials, 100, 50);
            let r = crate::run::run_quietly(&spec)?;
            let d = &r.deployment;
            let at = |m: usize| d.combined_measured_px.get(m).copied().unwrap_or(f32::NAN);
            row.measured_2_px.push(at(2));
            row.measured_last_px
                .push(d.combined_measured_px.last().copied().unwrap_or(f32::NAN));
            row.floor_px.push(d.noise_floor_px);
            row.fine_moves_stop_rule.push(r.fine_moves_mean);
            row.grasp_success.push(r.grasp_success_rate);
            row.failed_trials.push(r.failed_trials);
            eprintln!(
                "{} seed {seed}: measured after 2 fine {} px, after the budget {} px (floor {}), wall {:.1} s",
                v.name,
                px(at(2)),
                px(*row.measured_last_px.last().unwrap_or(&f32::NAN)),
                px(d.noise_floor_px),
                r.wall_s
            );
        }
        rows.push(row);
    }
    print_table(&rows);
    crate::output::write_json(
        &dir.join("sweep.json"),
        &crate::provenance::Stamped::new(&rows),
    )
}

fn file_name(name: &str) -> String {
    name.chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '-' })
        .collect::<String>()
        .split('-')
        .filter(|s| !s.is_empty())
        .collect::<Vec<_>>()
        .join("-")
}

fn write_config(cfg: &SimConfig, path: &Path) -> Result<()> {
    let text = toml::to_string(cfg).map_err(|e| Error::Usage(e.to_string()))?;
    std::fs::write(path, text).map_err(io(path))
}

/// The markdown table (mean ± standard deviation over the seeds).
pub fn print_table(rows: &[Row]) {
    let ms = |x: &[f32]| {
        let (m, s) = spread(x);
        format!("{} ± {}", px(m), px(s))
    };
    println!("| plant variant | measured px after coarse + 2 fine | after the budget | noise floor | ratio to the floor | fine moves, stop rule | grasp success % | failed trials |");
    println!("|---|---|---|---|---|---|---|---|");
    for r in rows {
        let ratio: Vec<f32> = r
            .measured_last_px
            .iter()
            .zip(&r.floor_px)
            .map(|(m, f)| m / f)
            .collect();
        let grasp: Vec<f32> = r.grasp_success.iter().map(|g| 100.0 * g).collect();
        println!(
            "| {} | {} | {} | {} | {} | {} | {} | {} |",
            r.name,
            ms(&r.measured_2_px),
            ms(&r.measured_last_px),
            px(spread(&r.floor_px).0),
            ms(&ratio),
            ms(&r.fine_moves_stop_rule),
            ms(&grasp),
            r.failed_trials.iter().sum::<usize>()
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every variant is a valid configuration that changes the base (but `base`), and each
    /// has its own file name.
    #[test]
    fn every_variant_is_valid_distinct_and_named_uniquely() {
        let base = SimConfig::ideal();
        let mut names = std::collections::BTreeSet::new();
        for v in VARIANTS {
            let mut c = base.clone();
            (v.apply)(&mut c);
            assert!(c.validate().is_ok(), "{}", v.name);
            assert_eq!(c == base, v.name == "base", "{}", v.name);
            assert!(names.insert(file_name(v.name)), "{}", v.name);
            // the file round-trips
            let text = toml::to_string(&c).unwrap();
            assert_eq!(SimConfig::from_toml_str(&text).unwrap(), c, "{}", v.name);
        }
    }
}
