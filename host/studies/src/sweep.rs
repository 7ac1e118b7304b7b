//! `trn sweep`: the project preset on plant variants (hysteresis width, camera noise,
//! coupling, creep, camera outliers, damping; each changed alone from the base
//! configuration, the ideal plant unless `--config` names another; then the realistic plant
//! with all of them, and with 25 % hysteresis), on the honest protocol (deployment targets,
//! fixed move budget), over seeds from 100: how the result degrades with each effect. The
//! variants are a study file, `studies/sweep.toml` (built in; `--study FILE` another). Each
//! variant's configuration is written as a TOML file beside the results, so every row can
//! be rerun with `--config`.

use std::path::PathBuf;

use serde::{Deserialize, Serialize};

use crate::study::file::{Overrides, StudyFile};
use crate::study::runfile::by_row;
use crate::study::stats::{Spread, Worse};
use crate::study::{Finished, RunFile, Study};
use trn_bench::format::px;
use trn_bench::fsio::parent;
use trn_bench::{LabError, Result};

/// The built-in sweep: `studies/sweep.toml`.
pub const STUDY: &str = include_str!("../../../studies/sweep.toml");

/// What `trn sweep` runs.
#[derive(Debug, Clone, PartialEq)]
pub struct SweepSpec {
    /// The study file (`None`: the built-in `studies/sweep.toml`).
    pub study: Option<PathBuf>,
    /// What the command line changes in it (`plant`: the base the variants change).
    pub over: Overrides,
    /// Where the variants' configurations (and sweep.json) go.
    pub out: PathBuf,
}

impl SweepSpec {
    /// The study: its variants over its seeds, each variant's plant written to `out`.
    pub fn study(&self) -> Result<Study> {
        self.study_unless(&|| false)
    }

    /// [`SweepSpec::study`], ended early when `stop` says so ([`StudyFile::study_unless`]).
    pub fn study_unless(&self, stop: &dyn Fn() -> bool) -> Result<Study> {
        let (file, dir) = match &self.study {
            Some(p) => (StudyFile::read(p)?, parent(p)),
            None => (
                StudyFile::parse(STUDY, "studies/sweep.toml")?,
                PathBuf::from("."),
            ),
        };
        file.study_unless(&dir, &self.over, Some(&self.out), stop)
    }
}

/// One variant's figures over the seeds.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
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

impl Row {
    fn of(files: &[&RunFile]) -> Row {
        let col = |f: &dyn Fn(&trn_bench::Report) -> f32| -> Vec<f32> {
            files.iter().map(|r| f(&r.report)).collect()
        };
        let measured = |r: &trn_bench::Report, m: Option<usize>| {
            let v = &r.deployment.combined_measured_px;
            m.map_or(v.last(), |m| v.get(m))
                .copied()
                .unwrap_or(f32::NAN)
        };
        let config = files
            .first()
            .and_then(|f| f.report.spec.as_ref())
            .and_then(|s| s.plant_name.clone())
            .unwrap_or_default();
        Row {
            name: files
                .first()
                .map(|f| f.row.name.clone())
                .unwrap_or_default(),
            config: config.into(),
            measured_2_px: col(&|r| measured(r, Some(2))),
            measured_last_px: col(&|r| measured(r, None)),
            floor_px: col(&|r| r.deployment.noise_floor_px),
            fine_moves_stop_rule: col(&|r| r.fine_moves_mean),
            grasp_success: col(&|r| r.grasp_success_rate),
            failed_trials: files.iter().map(|r| r.report.failed_trials).collect(),
        }
    }
}

/// The sweep's rows, table and JSON from every run of the study.
pub fn finish(files: &[RunFile]) -> Result<Finished> {
    let rows: Vec<Row> = by_row(files).iter().map(|r| Row::of(r)).collect();
    Ok(Finished {
        table: table(&rows),
        json: serde_json::to_value(&rows).map_err(|e| LabError::Usage(e.to_string()))?,
        files: files.to_vec(),
    })
}

/// The line of one finished run (progress off a terminal).
pub fn line(f: &RunFile) -> String {
    let d = &f.report.deployment;
    format!(
        "{} seed {}: measured after 2 fine {} px, after the budget {} px (floor {})",
        f.row.name,
        f.report.seed,
        px(d.combined_measured_px.get(2).copied().unwrap_or(f32::NAN)),
        px(d.combined_measured_px.last().copied().unwrap_or(f32::NAN)),
        px(d.noise_floor_px),
    )
}

/// The markdown table: each cell the mean ± the standard deviation over the seeds and, in
/// brackets, the worst seed.
pub fn table(rows: &[Row]) -> String {
    let cell = |x: &[f32], w: Worse| Spread::of(x, w).cell();
    let mut out = String::new();
    out.push_str("| plant variant | measured px after coarse + 2 fine | after the budget | noise floor | ratio to the floor | fine moves, stop rule | grasp success % | failed trials |\n");
    out.push_str("|---|---|---|---|---|---|---|---|\n");
    for r in rows {
        let ratio: Vec<f32> = r
            .measured_last_px
            .iter()
            .zip(&r.floor_px)
            .map(|(m, f)| m / f)
            .collect();
        let grasp: Vec<f32> = r.grasp_success.iter().map(|g| 100.0 * g).collect();
        out.push_str(&format!(
            "| {} | {} | {} | {} | {} | {} | {} | {} |\n",
            r.name,
            cell(&r.measured_2_px, Worse::Higher),
            cell(&r.measured_last_px, Worse::Higher),
            px(Spread::of(&r.floor_px, Worse::Higher).mean),
            cell(&ratio, Worse::Higher),
            cell(&r.fine_moves_stop_rule, Worse::Higher),
            cell(&grasp, Worse::Lower),
            r.failed_trials.iter().sum::<usize>()
        ));
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use trn_plant::SimConfig;

    fn width(c: &mut SimConfig, w: f64) {
        c.joints.iter_mut().for_each(|j| j.hysteresis_width = w);
    }

    /// The variants as they were compiled in before the sweep became a study file:
    /// `studies/sweep.toml` must make exactly these plants, so the recorded figures
    /// (docs/plant.md) stand.
    #[allow(clippy::type_complexity)]
    fn before() -> Vec<(&'static str, Box<dyn Fn(&mut SimConfig)>)> {
        let real = SimConfig::realistic;
        vec![
            ("base", Box::new(|_| {})),
            ("hysteresis width 5 %", Box::new(|c| width(c, 0.05))),
            ("hysteresis width 15 %", Box::new(|c| width(c, 0.15))),
            ("hysteresis width 25 %", Box::new(|c| width(c, 0.25))),
            ("camera noise 0.1 px", Box::new(|c| c.pixel_noise_px = 0.1)),
            ("camera noise 0.5 px", Box::new(|c| c.pixel_noise_px = 0.5)),
            ("camera noise 1 px", Box::new(|c| c.pixel_noise_px = 1.0)),
            ("coupling (gravity sag, load-dependent width)", Box::new(move |c| {
                let r = real().realism;
                c.realism.sag_shoulder_deg = r.sag_shoulder_deg;
                c.realism.sag_elbow_deg = r.sag_elbow_deg;
                c.realism.load_width_gain = r.load_width_gain;
            })),
            ("creep", Box::new(move |c| {
                let r = real().realism;
                c.realism.creep_fraction = r.creep_fraction;
                c.realism.creep_tau_s = r.creep_tau_s;
            })),
            ("process noise", Box::new(move |c| c.realism.process_noise_deg = real().realism.process_noise_deg)),
            ("skewed loop", Box::new(move |c| c.realism.hysteresis_skew = real().realism.hysteresis_skew)),
            ("camera outliers and dropouts", Box::new(move |c| {
                let r = real().realism;
                c.realism.outlier_rate = r.outlier_rate;
                c.realism.dropout_rate = r.dropout_rate;
            })),
            ("damping 0.15", Box::new(|c| c.joints.iter_mut().for_each(|j| j.damping_ratio = 0.15))),
            ("realistic (coupling, creep, process noise, skewed loop, outliers, occlusion, distortion: the runs' default)", Box::new(move |c| *c = real())),
            ("realistic, hysteresis width 25 %", Box::new(move |c| {
                *c = real();
                width(c, 0.25);
            })),
            ("realistic, hysteresis width 25 %, loop width independent of the load", Box::new(move |c| {
                *c = real();
                width(c, 0.25);
                c.realism.load_width_gain = 0.0;
            })),
        ]
    }

    #[test]
    fn the_study_file_makes_the_variants_it_replaced() {
        let out = std::env::temp_dir().join(format!("trn-sweep-variants-{}", std::process::id()));
        let spec = SweepSpec {
            study: None,
            over: Overrides::default(),
            out: out.clone(),
        };
        let s = spec.study().unwrap();
        assert!(s.write_plants(&|| false).unwrap());
        let before = before();
        assert_eq!(s.jobs.len(), before.len() * 3);
        for (i, (name, apply)) in before.iter().enumerate() {
            let mut plant = SimConfig::ideal();
            apply(&mut plant);
            for (k, seed) in (100..103).enumerate() {
                let j = &s.jobs[i * 3 + k];
                assert_eq!(j.row.name, *name);
                let mut old = trn_bench::RunSpec::new(trn_bench::Command::Train, seed);
                old.plant = plant.clone();
                let file = out.join(format!("{}.toml", crate::study::slug(name)));
                old.plant_name = Some(file.display().to_string());
                assert_eq!(j.spec, old, "{name}");
                // the file written is the variant's plant
                assert_eq!(SimConfig::load(&file).unwrap(), plant, "{name}");
            }
        }
        let _ = std::fs::remove_dir_all(&out);
    }

    #[test]
    fn the_pixel_sweep_changes_one_thing_of_the_frames_per_row() {
        let out = std::env::temp_dir().join(format!("trn-sweep-pixels-{}", std::process::id()));
        let file = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../../studies/sweep-pixels.toml");
        let spec = SweepSpec {
            study: Some(file),
            over: Overrides {
                seeds: Some(1),
                ..Overrides::default()
            },
            out: out.clone(),
        };
        let s = spec.study().unwrap();
        let plants: Vec<SimConfig> = s.jobs.iter().map(|j| j.spec.plant.clone()).collect();
        let real = SimConfig::realistic();
        let mut pixels = real.clone();
        pixels.vision = trn_plant::Vision::Pixels;
        let p = real.pixels.clone();
        let with = |f: &dyn Fn(&mut trn_plant::PixelsConfig)| {
            let mut c = pixels.clone();
            f(&mut c.pixels);
            c
        };
        let want = vec![
            real.clone(),
            pixels.clone(),
            with(&|x| x.exposure_ms = 2.0),
            with(&|x| x.exposure_ms = 40.0),
            with(&|x| x.blur_px = 0.5),
            with(&|x| x.blur_px = 2.5),
            with(&|x| {
                x.read_noise_e = 30.0;
                x.stray_electrons_per_ms = 50.0;
            }),
            with(&|x| x.led_diameter_mm = 2.0),
            with(&|x| x.led_diameter_mm = 15.0),
        ];
        assert_eq!(plants, want);
        assert_eq!(p, trn_plant::PixelsConfig::default());
        // `--vision` sets the base: every row of the built-in sweep, which sets none
        let all = SweepSpec {
            study: None,
            over: Overrides {
                seeds: Some(1),
                vision: Some(trn_plant::Vision::Pixels),
                ..Overrides::default()
            },
            out: out.clone(),
        }
        .study()
        .unwrap();
        assert!(all
            .jobs
            .iter()
            .all(|j| j.spec.plant.vision == trn_plant::Vision::Pixels));
        let _ = std::fs::remove_dir_all(&out);
    }
}
