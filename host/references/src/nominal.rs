//! The learning-free reference: a perfectly calibrated model-based controller without
//! hysteresis compensation (`--controller model`). It knows the simulated arm exactly
//! (links, cameras, each joint's pressure-to-angle curve) except for what a calibration at
//! rest cannot capture: the hysteresis (its model is the joints' curve of zero loop width),
//! drift, wear and the arm's dynamics. Its coarse move is the nominal inverse kinematics
//! from zero pressure; each fine move is a Gauss-Newton step with the model's Jacobian at
//! the pressure it commanded last, from the observed error ([`ModelBased`]). Its limits,
//! which are those of any such controller: the wrist's pressures in a stage-2 trial are what
//! it commanded last (it has no joint sensors; the runner moves the arm between trials).

use nalgebra::SVector;
use trn_controller::Config;
use trn_plant::{Plant, SimConfig};

use crate::model_based::{ArmModel, ModelBased};

/// The nominal model: the arm at rest at the commanded pressures, loops of zero width.
pub struct NominalModel {
    plant: Plant,
}

impl ArmModel for NominalModel {
    fn image<const D: usize>(&mut self, p: &[f64; 5]) -> Option<SVector<f64, D>> {
        self.plant.settle_joints_at(p);
        let v: Option<[f32; D]> = if D == 8 {
            self.plant.observe_gripper_lights_true().to_vector()
        } else {
            self.plant.observe_gripper_centre_true().to_vector()
        };
        v.map(|v| SVector::from_fn(|i, _| v[i] as f64))
    }

    fn start(&self, held: [f64; 5], joints: usize) -> [f64; 5] {
        let mut start = held;
        start[..joints].fill(0.0);
        start
    }

    fn resolves(&self) -> bool {
        false
    }

    fn law_code(&self) -> u8 {
        crate::law_code::MODEL
    }

    /// The static map has no command steps: a small difference.
    fn step_size(&self) -> f64 {
        1e-4
    }
}

/// The model-based reference controller.
pub type NominalIk = ModelBased<NominalModel>;

impl NominalIk {
    /// The reference for the simulated arm `sim`: its model is the same arm with loops of
    /// zero width, no drift and no wear.
    pub fn new(sim: &SimConfig, cfg: Config) -> Result<NominalIk, trn_plant::PlantError> {
        let mut nominal = sim.clone();
        for j in &mut nominal.joints {
            j.hysteresis_width = 0.0;
            j.hysteresis_asymmetry = 0.0;
        }
        nominal.drift.temperature = false;
        nominal.drift.wear = false;
        nominal.pixel_noise_px = 0.0;
        let model = NominalModel {
            plant: Plant::new(&nominal, 0)?,
        };
        Ok(ModelBased::on(model, cfg))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::law_code;
    use trn_controller::presets::ImageSize;
    use trn_controller::{Command, Control, Error, FineMoves, Observation, Task};

    fn reference(sim: &SimConfig) -> NominalIk {
        NominalIk::new(
            sim,
            trn_controller::presets::Profile::default().config(ImageSize::DEFAULT),
        )
        .unwrap()
    }

    /// On an arm without hysteresis (the model is then exact up to the settling left after
    /// 1.2 s) the coarse move lands within a pixel or two; with hysteresis it lands several
    /// times farther, and the fine moves close the gap.
    #[test]
    fn exact_without_hysteresis_and_not_with_it() {
        let mut ideal = SimConfig::default();
        for j in &mut ideal.joints {
            j.hysteresis_width = 0.0;
            j.hysteresis_asymmetry = 0.0;
        }
        ideal.pixel_noise_px = 0.0;
        let p = [0.3, -0.2, 0.4, 0.1, -0.3];
        let mut coarse = vec![];
        for sim in [ideal, SimConfig::default()] {
            let mut plant = Plant::new(&sim, 1).unwrap();
            plant.command(&p);
            plant.settle();
            let v = plant.observe_gripper_lights_true().to_vector().unwrap();
            plant.command(&[0.0; 5]);
            plant.settle();
            let mut r = reference(&sim);
            let mut cmd = r
                .begin_with(
                    Task::Stage1 {
                        v,
                        supervised: None,
                        learn: false,
                    },
                    FineMoves::Exactly(3),
                )
                .unwrap();
            let o = loop {
                match cmd {
                    Command::Move { pressures, .. } => {
                        plant.command(&pressures);
                        plant.settle();
                        let seen = plant.observe_gripper_lights_true().to_vector().unwrap();
                        cmd = r.observe(Observation::Lights(seen)).unwrap();
                    }
                    Command::Done(o) => break o.stage1.unwrap(),
                }
            };
            assert!(o.final_error < 0.5, "{o:?}");
            coarse.push(o.coarse_error);
        }
        assert!(coarse[0] < 2.0, "{coarse:?}");
        assert!(coarse[1] > 3.0 * coarse[0], "{coarse:?}");
    }

    /// A session of its own law code is served (the profile's configuration, fingerprinted
    /// with that code); the core's laws and the oracle's code are not.
    #[test]
    fn it_runs_only_its_own_law() {
        use trn_controller::presets::{Ablation, Preset, SessionProfile};
        use trn_controller::Law;
        let mut r = reference(&SimConfig::default());
        let image = ImageSize::DEFAULT;
        let asked = |law| SessionProfile {
            preset: Preset::Project,
            ablation: Ablation::None,
            law,
            image,
        };
        for code in [Law::Trn.code(), Law::Broyden.code(), law_code::ORACLE] {
            assert_eq!(
                r.session_config(asked(code)),
                Err(Error::UnsupportedLaw),
                "law code {code}"
            );
        }
        let (cfg, fp) = r.session_config(asked(law_code::MODEL)).unwrap();
        assert_eq!(
            cfg,
            trn_controller::presets::Profile::default().config(image)
        );
        assert_eq!(fp, cfg.fingerprint_as(2));
        assert_ne!(fp, cfg.fingerprint());
        assert_eq!(r.fingerprint(), fp);
        let broyden = Config {
            law: Law::Broyden,
            ..Config::project_default()
        };
        assert_eq!(r.set_config(broyden), Err(Error::UnsupportedLaw));
        assert_eq!(
            r.observe(Observation::Lights([0.0; 8])),
            Err(Error::UnexpectedObservation)
        );
    }
}
