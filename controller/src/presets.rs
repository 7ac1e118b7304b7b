//! Named configurations, shared by every build: the host (`trn`, `controller-node`) and the
//! firmware call [`configure`], so their controllers cannot differ.

use crate::config::{Config, Law};

crate::wire_enum! {
    /// A controller preset.
    #[derive(Default)]
    pub enum Preset {
        /// The project's defaults ([`Config::project_default`]).
        #[default]
        Project = 0 => "project",
        /// The chapter's printed constants, errata fixed ([`Config::paper`]).
        Paper = 1 => "paper",
        /// The project's defaults with a floor on the rates ([`Config::lifelong`]).
        Lifelong = 2 => "lifelong",
    }
}

crate::wire_enum! {
    /// An ablation of the method.
    #[derive(Default)]
    pub enum Ablation {
        /// The full method.
        #[default]
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

/// What a session configures of a controller (SPEC.md 3.2, besides the seed and the bus):
/// a preset, an ablation and a law. [`Profile::config`] is the one place a controller's
/// configuration is built from them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct Profile {
    /// The named configuration.
    pub preset: Preset,
    /// What is left out of the method.
    pub ablation: Ablation,
    /// The control law.
    pub law: Law,
}

/// A session's profile as the wire gives it (SPEC.md 3.2): a preset, an ablation, the raw
/// law byte (a host-side law's code included) and the cameras' image size; what
/// [`crate::Control::session_config`] answers.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SessionProfile {
    /// The named configuration.
    pub preset: Preset,
    /// What is left out of the method.
    pub ablation: Ablation,
    /// The session's law byte.
    pub law: u8,
    /// The cameras' image size.
    pub image: ImageSize,
}

impl Profile {
    /// The controller configuration of this profile for cameras of `image` size.
    pub fn config(self, image: ImageSize) -> Config {
        Config {
            law: self.law,
            ..configure(self.preset, self.ablation, image)
        }
    }

    /// The profile of a session's three codes (SPEC.md 3.2):
    /// [`crate::Error::UnsupportedLaw`] for a host-side law's code ([`Law::decode`]),
    /// [`crate::Error::UnknownCode`] for a code the wire does not define.
    pub const fn from_codes(preset: u8, ablation: u8, law: u8) -> crate::Result<Profile> {
        let (Some(preset), Some(ablation)) =
            (Preset::from_code(preset), Ablation::from_code(ablation))
        else {
            return Err(crate::Error::UnknownCode);
        };
        match Law::decode(law) {
            Ok(law) => Ok(Profile {
                preset,
                ablation,
                law,
            }),
            Err(e) => Err(e),
        }
    }
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
            (Preset::COUNT, Ablation::COUNT, Law::COUNT, Law::WIRE_CODES),
            (3, 5, 2, 4)
        );
    }

    /// The host-side laws' codes are valid on the wire and answered as unsupported, not as
    /// unknown; codes past them are unknown; the core's laws decode.
    #[test]
    fn host_law_codes_are_unsupported_and_later_codes_unknown() {
        use crate::Error;
        assert_eq!(Law::decode(0), Ok(Law::Trn));
        assert_eq!(Law::decode(1), Ok(Law::Broyden));
        for (code, name) in Law::HOST_CODES {
            assert_eq!(Law::decode(code), Err(Error::UnsupportedLaw), "{name}");
            assert_eq!(Law::host_code(name), Some(code));
            assert_eq!(Law::from_name(name), None);
            assert_eq!(Profile::from_codes(0, 0, code), Err(Error::UnsupportedLaw));
        }
        assert_eq!(Law::host_code("trn"), None);
        assert_eq!(Law::decode(Law::WIRE_CODES), Err(Error::UnknownCode));
        assert_eq!(Profile::from_codes(0, 0, 4), Err(Error::UnknownCode));
        assert_eq!(Profile::from_codes(3, 0, 0), Err(Error::UnknownCode));
        assert_eq!(Profile::from_codes(0, 5, 0), Err(Error::UnknownCode));
        let p = Profile::from_codes(1, 3, 1).unwrap();
        assert_eq!(
            (p.preset, p.ablation, p.law),
            (Preset::Paper, Ablation::NoFine, Law::Broyden)
        );
        assert_eq!(p.config(ImageSize::DEFAULT).law, Law::Broyden);
        assert_eq!(
            p.config(ImageSize::DEFAULT).stage1.max_fine_moves,
            configure(Preset::Paper, Ablation::NoFine, ImageSize::DEFAULT)
                .stage1
                .max_fine_moves
        );
    }

    /// The fingerprint with a law byte is the configuration's own encoding with that byte:
    /// for the core's laws it is [`Config::fingerprint`] of the postcard encoding, and a
    /// host-side law's code gives a fingerprint of its own.
    #[test]
    fn a_fingerprint_with_a_law_code_is_the_encoding_with_that_byte() {
        let cfg = Profile::default().config(ImageSize::DEFAULT);
        for &law in Law::ALL {
            let c = Config { law, ..cfg };
            let mut buf = [0u8; 512];
            let bytes = postcard::to_slice(&c, &mut buf).unwrap();
            assert_eq!(c.fingerprint(), crate::crc::crc32(bytes));
            assert_eq!(cfg.fingerprint_as(law.code()), c.fingerprint());
        }
        let host: [u32; 2] = Law::HOST_CODES.map(|(code, _)| cfg.fingerprint_as(code));
        assert!(host[0] != host[1] && !host.contains(&cfg.fingerprint()));
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
