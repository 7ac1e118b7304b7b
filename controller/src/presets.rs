//! Named configurations, shared by every build: the host (`trn`, `controller-node`) and the
//! firmware call [`configure`], so their controllers cannot differ.

use crate::config::Config;

/// A controller preset.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum Preset {
    /// The project's defaults ([`Config::project_default`]).
    Project = 0,
    /// The chapter's printed constants, errata fixed ([`Config::paper`]).
    Paper = 1,
    /// The project's defaults with a floor on the rates ([`Config::lifelong`]).
    Lifelong = 2,
}

/// An ablation of the method.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum Ablation {
    /// The full method.
    None = 0,
    /// Only the closest neuron answers and learns: a plain VQ look-up table.
    NoNeighbourhood = 1,
    /// No supervised priming.
    NoPriming = 2,
    /// No fine moves (coarse move only).
    NoFine = 3,
    /// No secant correction of the averaged Jacobian within a trial in mature operation
    /// ([`crate::StageConfig::trial_secant`] 0, as in the paper).
    NoTrialSecant = 4,
}

impl Preset {
    /// Every preset, in wire order.
    pub const ALL: [Preset; 3] = [Preset::Project, Preset::Paper, Preset::Lifelong];

    /// The preset of a wire code.
    pub const fn from_code(code: u8) -> Option<Preset> {
        match code {
            0 => Some(Preset::Project),
            1 => Some(Preset::Paper),
            2 => Some(Preset::Lifelong),
            _ => None,
        }
    }

    /// Its name on the command line and in reports.
    pub const fn name(self) -> &'static str {
        match self {
            Preset::Project => "project",
            Preset::Paper => "paper",
            Preset::Lifelong => "lifelong",
        }
    }
}

impl Ablation {
    /// Every ablation, in wire order.
    pub const ALL: [Ablation; 5] = [
        Ablation::None,
        Ablation::NoNeighbourhood,
        Ablation::NoPriming,
        Ablation::NoFine,
        Ablation::NoTrialSecant,
    ];

    /// The ablation of a wire code.
    pub const fn from_code(code: u8) -> Option<Ablation> {
        match code {
            0 => Some(Ablation::None),
            1 => Some(Ablation::NoNeighbourhood),
            2 => Some(Ablation::NoPriming),
            3 => Some(Ablation::NoFine),
            4 => Some(Ablation::NoTrialSecant),
            _ => None,
        }
    }

    /// Its name on the command line and in reports.
    pub const fn name(self) -> &'static str {
        match self {
            Ablation::None => "none",
            Ablation::NoNeighbourhood => "no-neighbourhood",
            Ablation::NoPriming => "no-priming",
            Ablation::NoFine => "no-fine",
            Ablation::NoTrialSecant => "no-trial-secant",
        }
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
    fn codes_round_trip() {
        for p in Preset::ALL {
            assert_eq!(Preset::from_code(p as u8), Some(p));
        }
        for a in Ablation::ALL {
            assert_eq!(Ablation::from_code(a as u8), Some(a));
        }
        assert_eq!(Preset::from_code(3), None);
        assert_eq!(Ablation::from_code(5), None);
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
