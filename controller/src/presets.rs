//! Named configurations, shared by every build: the host (`trn`, `controller-node`) and the
//! firmware call [`configure`], so their controllers cannot differ.

use crate::config::Config;

crate::wire_enum! {
    /// A controller preset.
    pub enum Preset {
        /// The project's defaults ([`Config::project_default`]).
        Project = 0 => "project",
        /// The chapter's printed constants, errata fixed ([`Config::paper`]).
        Paper = 1 => "paper",
        /// The project's defaults with a floor on the rates ([`Config::lifelong`]).
        Lifelong = 2 => "lifelong",
    }
}

crate::wire_enum! {
    /// An ablation of the method.
    pub enum Ablation {
        /// The full method.
        None = 0 => "none",
        /// Only the closest neuron answers and learns: a plain VQ look-up table.
        NoNeighbourhood = 1 => "no-neighbourhood",
        /// No supervised priming.
        NoPriming = 2 => "no-priming",
        /// No fine moves (coarse move only).
        NoFine = 3 => "no-fine",
        /// No secant correction of the averaged Jacobian within a trial in mature operation
        /// ([`crate::StageConfig::trial_secant`] 0, as in the paper).
        NoTrialSecant = 4 => "no-trial-secant",
    }
}

/// The camera images the controller works in: the initial weights span them and inputs
/// outside a margin around them are rejected.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct ImageSize {
    /// Width (pixels).
    pub width: u16,
    /// Height (pixels).
    pub height: u16,
}

impl ImageSize {
    /// The simulator's default cameras.
    pub const DEFAULT: ImageSize = ImageSize {
        width: 1024,
        height: 768,
    };
}

/// The controller configuration of a preset and an ablation for cameras of `image` size:
/// the initial weights spread over the images, inputs accepted within one image size
/// around them.
pub fn configure(preset: Preset, ablation: Ablation, image: ImageSize) -> Config {
    let mut cfg = match preset {
        Preset::Project => Config::project_default(),
        Preset::Paper => Config::paper(),
        Preset::Lifelong => Config::lifelong(),
    };
    let (w, h) = (image.width as f32, image.height as f32);
    let side = if w > h { w } else { h };
    for s in [&mut cfg.stage1, &mut cfg.stage2] {
        s.init.x = (0.0, w);
        s.init.y = (0.0, h);
        s.input_min = -side;
        s.input_max = 2.0 * side;
    }
    match ablation {
        Ablation::None => {}
        Ablation::NoNeighbourhood => {
            for s in [&mut cfg.stage1, &mut cfg.stage2] {
                s.alpha_range = 1e-3;
                s.sigma = 1e-3;
                s.sigma_start = 1e-3;
            }
        }
        Ablation::NoPriming => cfg.supervised_steps = 0,
        Ablation::NoFine => {
            cfg.stage1.max_fine_moves = 0;
            cfg.stage2.max_fine_moves = 0;
        }
        Ablation::NoTrialSecant => {
            cfg.stage1.trial_secant = 0.0;
            cfg.stage2.trial_secant = 0.0;
        }
    }
    cfg
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn codes_and_names_round_trip() {
        for &p in Preset::ALL {
            assert_eq!(Preset::from_code(p.code()), Some(p));
            assert_eq!(Preset::from_name(p.name()), Some(p));
        }
        for &a in Ablation::ALL {
            assert_eq!(Ablation::from_code(a.code()), Some(a));
            assert_eq!(Ablation::from_name(a.name()), Some(a));
        }
        for &l in crate::Law::ALL {
            assert_eq!(crate::Law::from_code(l.code()), Some(l));
            assert_eq!(crate::Law::from_name(l.name()), Some(l));
        }
        assert_eq!(Preset::from_code(Preset::COUNT), None);
        assert_eq!(Ablation::from_code(Ablation::COUNT), None);
        assert_eq!(crate::Law::from_code(crate::Law::COUNT), None);
        assert_eq!(
            (Preset::COUNT, Ablation::COUNT, crate::Law::COUNT),
            (3, 5, 4)
        );
    }

    #[test]
    fn the_images_set_the_initial_weights_and_the_input_range() {
        let c = configure(
            Preset::Project,
            Ablation::None,
            ImageSize {
                width: 640,
                height: 480,
            },
        );
        assert_eq!(c.stage1.init.x, (0.0, 640.0));
        assert_eq!(c.stage2.init.y, (0.0, 480.0));
        assert_eq!((c.stage1.input_min, c.stage1.input_max), (-640.0, 1280.0));
        let n = configure(Preset::Paper, Ablation::NoFine, ImageSize::DEFAULT);
        assert_eq!(n.stage1.max_fine_moves, 0);
        assert_eq!(n.stage1.j.eps, Config::paper().stage1.j.eps);
        let s = configure(Preset::Project, Ablation::NoTrialSecant, ImageSize::DEFAULT);
        assert_eq!((s.stage1.trial_secant, s.stage2.trial_secant), (0.0, 0.0));
        assert!(Config::project_default().stage1.trial_secant > 0.0);
        assert_eq!(Config::paper().stage2.trial_secant, 0.0);
    }
}
