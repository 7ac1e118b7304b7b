//! The simulator's configuration: every parameter with its unit, loaded from TOML
//! (`host/sim.toml` documents the defaults). The valid ranges, and
//! [`SimConfig::validate`] that every load calls, are `validate.rs`'s.

use serde::{Deserialize, Serialize};
use std::path::Path;

use crate::PlantError as SimError;

/// One pneumatic joint: servo drive, hysteresis and dynamics.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct JointConfig {
    /// Name (for messages and pictures).
    pub name: String,
    /// Joint angle at the most negative pressure difference (degrees).
    pub min_deg: f64,
    /// Joint angle at the most positive pressure difference (degrees).
    pub max_deg: f64,
    /// Random target pressures are drawn from `[-target_limit, target_limit]` (normalised).
    pub target_limit: f64,
    /// Hysteresis loop width: the gap between the ascending and descending branches over a
    /// full cycle, as a fraction of the joint's range (0 = single-valued).
    pub hysteresis_width: f64,
    /// "Asymmetry" in [0, 1): each play operator lags by `(1 + a) r` going up and `(1 - a) r`
    /// going down, which is a symmetric operator shifted by `-a r`: the loop moves by a
    /// constant, its branches stay mirror images (see `joint.rs`).
    pub hysteresis_asymmetry: f64,
    /// Natural frequency of the joint's second-order dynamics (Hz).
    pub natural_freq_hz: f64,
    /// Damping ratio (below 1: overshoot and oscillation).
    pub damping_ratio: f64,
    /// Time constant of the servo drive's first-order pressure lag (s).
    pub pressure_tau_s: f64,
    /// The servo drive saturates the command at `±servo_limit` (normalised).
    pub servo_limit: f64,
}

/// One pinhole camera.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct CameraConfig {
    /// Image width and height (pixels).
    #[serde(deserialize_with = "exactly")]
    pub resolution: [u32; 2],
    /// Focal length (pixels).
    pub focal_px: f64,
    /// Camera centre in the arm's base frame (mm; x forward, y left, z up).
    #[serde(deserialize_with = "exactly")]
    pub position_mm: [f64; 3],
    /// The point the optical axis passes through (mm).
    #[serde(deserialize_with = "exactly")]
    pub look_at_mm: [f64; 3],
    /// Radial distortion coefficients k1, k2 (normalised image coordinates).
    #[serde(deserialize_with = "exactly")]
    pub distortion: [f64; 2],
}

/// A list of exactly `N` values (a parser that reads the first `N` of a longer list would
/// take `[1024, 768, 3]` for a resolution without a word). Read as a tuple of `N`, so the
/// binary formats (a simulator checkpoint) read what they wrote.
fn exactly<'de, D, T, const N: usize>(d: D) -> Result<[T; N], D::Error>
where
    D: serde::Deserializer<'de>,
    T: Deserialize<'de>,
{
    struct Exactly<T, const N: usize>(std::marker::PhantomData<T>);
    impl<'de, T: Deserialize<'de>, const N: usize> serde::de::Visitor<'de> for Exactly<T, N> {
        type Value = [T; N];
        fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
            write!(f, "a list of {N} values")
        }
        fn visit_seq<A: serde::de::SeqAccess<'de>>(self, mut seq: A) -> Result<[T; N], A::Error> {
            let mut v = Vec::with_capacity(N);
            while v.len() < N {
                match seq.next_element()? {
                    Some(x) => v.push(x),
                    None => break,
                }
            }
            let mut n = v.len();
            while seq.next_element::<serde::de::IgnoredAny>()?.is_some() {
                n += 1;
            }
            if n != N {
                return Err(serde::de::Error::custom(format!(
                    "expected a list of {N} values, got {n}"
                )));
            }
            v.try_into()
                .map_err(|_| serde::de::Error::custom("expected a list of values"))
        }
    }
    d.deserialize_tuple(N, Exactly::<T, N>(std::marker::PhantomData))
}

/// Slow drift and wear, off by default.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct DriftConfig {
    /// Temperature drift on.
    pub temperature: bool,
    /// Amplitude of the temperature offset of every joint (degrees).
    pub temperature_amplitude_deg: f64,
    /// Period of the temperature cycle (s of simulated time).
    pub temperature_period_s: f64,
    /// Wear on.
    pub wear: bool,
    /// Loss of joint gain per radian of cumulative travel (fraction).
    pub wear_gain_per_rad: f64,
    /// Offset gained per radian of cumulative travel (degrees): the initial rate.
    pub wear_offset_deg_per_rad: f64,
    /// Wear is bounded: the gain loss approaches this fraction and the offset
    /// `wear_offset_max_deg`, each exponentially in the travel with the initial rates above
    /// (a McKibben muscle's braid and bladder settle in early use and then change slowly;
    /// see sim.toml). 0.5 and a large offset bound give the old linear wear (floored at half
    /// the gain) over any realistic travel.
    #[serde(default = "default_wear_gain_max")]
    pub wear_gain_max: f64,
    /// See `wear_gain_max` (degrees).
    #[serde(default = "default_wear_offset_max_deg")]
    pub wear_offset_max_deg: f64,
}

fn default_wear_gain_max() -> f64 {
    0.5
}

fn default_wear_offset_max_deg() -> f64 {
    1e6
}

/// What the real arm has beyond the ideal plant. Every effect is off at zero
/// ([`SimConfig::ideal`]); [`SimConfig::realistic`] (the default) turns them on with the
/// magnitudes justified in `host/sim.toml`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize, Default)]
#[serde(deny_unknown_fields, default)]
pub struct RealismConfig {
    /// Gravity sag of the shoulder with the whole arm stretched out horizontally (degrees):
    /// the links' and the hand's weight against the tubes' finite stiffness, scaled by the
    /// gravity torque of the posture, so the shoulder's angle depends on the elbow's and
    /// the wrist's.
    pub sag_shoulder_deg: f64,
    /// The same for the elbow (forearm and hand beyond it).
    pub sag_elbow_deg: f64,
    /// The loop width grows with the gravity load of shoulder and elbow:
    /// width x (1 + `load_width_gain` x load), load in [0, 1].
    pub load_width_gain: f64,
    /// Per-move random variation of each joint's equilibrium (degrees, standard deviation):
    /// drawn when a joint gets a new command.
    pub process_noise_deg: f64,
    /// Fraction of every change of a joint's equilibrium that arrives slowly (viscoelastic
    /// creep of the rubber).
    pub creep_fraction: f64,
    /// Time constant of the creep (s).
    pub creep_tau_s: f64,
    /// Branches that differ in shape (a generalised Prandtl-Ishlinskii model): the ascending
    /// branch follows the envelope x - b(x), the descending x + b(x), with
    /// b = skew (1 - x^2)(1 + x) / 2 (normalised pressure); the loop bulges on the positive
    /// side and its branches are not mirror images (`hysteresis_asymmetry` only shifts it).
    pub hysteresis_skew: f64,
    /// Probability per light and camera of an outlier: a reflection taken for the LED, a
    /// valid-looking point anywhere in the image.
    pub outlier_rate: f64,
    /// Probability per light and camera of a dropout (not detected).
    pub dropout_rate: f64,
    /// The hand and the cylinder hide lights too, not only the upper arm and the forearm.
    pub occlude_hand_and_cylinder: bool,
    /// Experiment: unidirectional approach (CNC's G60). A drive whose new command is below
    /// its last goes first to `command - approach_depth` (clamped to -1) for `approach_s`,
    /// then to the command, so every setpoint is reached from below; 0 = off. The settle
    /// that follows is lengthened by the pre-move's time.
    pub approach_depth: f64,
    /// Experiment: how long the drive holds the pre-move's pressure (s).
    pub approach_s: f64,
    /// Experiment: only a descent larger than this (normalised pressure) is approached
    /// from below; smaller ones go straight (0 = every descent).
    pub approach_min: f64,
    /// Experiment: the pre-move follows half-cosines down to its depth and up to the
    /// command over `approach_s` (instead of a step down held, then a step up), so that it
    /// excites the joint's oscillation less.
    pub approach_smooth: bool,
}

/// How the camera processor reads the lights.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "lowercase")]
pub enum Vision {
    /// Each light's projection plus Gaussian noise of `pixel_noise_px`, hidden by the
    /// geometry, outliers and dropouts drawn by rule: fast, for studies.
    #[default]
    Geometric,
    /// Every capture rendered frame by frame (`[pixels]`) and read by the camera processor
    /// on pixels (`trn_vision`): detection, identification by the capture protocol.
    Pixels,
}

/// The cameras' frames when the lights are read on pixels (`vision = "pixels"`): the LEDs,
/// the lens and the sensor. The other sensor values are `trn_vision::Sensor::machine_vision`'s
/// (8 bits, 20 e- per DN, black level 10 DN, full well 12,000 e-).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PixelsConfig {
    /// Exposure time of each frame (ms): the LEDs' and the stray light's electrons grow with
    /// it, and so does the smear of a moving light.
    pub exposure_ms: f64,
    /// Photo-electrons an LED delivers per ms of exposure at 2 m from the camera (falling
    /// with the square of the distance).
    pub led_electrons_per_ms: f64,
    /// Diameter of an LED's emitting disc (mm): its image is a disc of that size at the
    /// light's distance, blurred by the lens.
    pub led_diameter_mm: f64,
    /// The lens's blur (defocus and aberrations), a Gaussian's standard deviation (px).
    pub blur_px: f64,
    /// The sensor's read noise (electrons, standard deviation).
    pub read_noise_e: f64,
    /// Stray light and dark current per pixel (electrons per ms of exposure).
    pub stray_electrons_per_ms: f64,
    /// The identifier's gate (px): a blob within it of a track joins the track.
    pub gate_px: f64,
}

impl Default for PixelsConfig {
    /// An LED of 5 mm blurred by 1.2 px: a spot of 1.3 px at 2 m; 30,000 electrons and 50
    /// of stray light per pixel over 10 ms; 5 electrons of read noise; a 3 px gate.
    fn default() -> PixelsConfig {
        PixelsConfig {
            exposure_ms: 10.0,
            led_electrons_per_ms: 3_000.0,
            led_diameter_mm: 5.0,
            blur_px: 1.2,
            read_noise_e: 5.0,
            stray_electrons_per_ms: 5.0,
            gate_px: 3.0,
        }
    }
}

/// The whole simulator configuration.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct SimConfig {
    /// Physics step (s).
    pub dt_s: f64,
    /// Time from a command to the camera reading (s): residual oscillation is part of the error.
    pub settle_s: f64,
    /// Height of the shoulder above the base (mm).
    pub shoulder_height_mm: f64,
    /// Shoulder to elbow (mm).
    pub upper_arm_mm: f64,
    /// Elbow to wrist (mm).
    pub forearm_mm: f64,
    /// Wrist to gripper centre (mm).
    pub hand_mm: f64,
    /// Distance of each of the lights p and q from the gripper centre, along the axis the
    /// cylinder will have (mm).
    pub light_offset_mm: f64,
    /// Radius of the links for occlusion (mm).
    pub link_radius_mm: f64,
    /// Pixel noise of a light centroid, per coordinate (pixels, standard deviation), of the
    /// geometric camera model; with `vision = "pixels"` the stereo check's and the marker
    /// fit's scale of the noise.
    pub pixel_noise_px: f64,
    /// How the camera processor reads the lights (absent: geometric).
    #[serde(default)]
    pub vision: Vision,
    /// The five joints.
    pub joints: Vec<JointConfig>,
    /// The two cameras.
    pub cameras: Vec<CameraConfig>,
    /// Drift and wear.
    pub drift: DriftConfig,
    /// Effects of the real arm beyond the ideal plant (absent: all off).
    #[serde(default)]
    pub realism: RealismConfig,
    /// The frames when `vision = "pixels"` (absent: the defaults).
    #[serde(default)]
    pub pixels: PixelsConfig,
    /// The cylinder's centre lies this far ahead of the pre-grasp gripper centre (mm).
    pub approach_mm: f64,
    /// Cylinder radius (mm).
    pub cylinder_radius_mm: f64,
    /// Cylinder length (mm).
    pub cylinder_length_mm: f64,
    /// A grasp succeeds when the gripper centre is within this of the cylinder centre (mm) ...
    pub grasp_distance_mm: f64,
    /// ... and the gripper is perpendicular to the axis within this (degrees).
    pub grasp_angle_deg: f64,
}

fn joint(name: &str, min: f64, max: f64, f: f64) -> JointConfig {
    JointConfig {
        name: name.into(),
        min_deg: min,
        max_deg: max,
        // a margin below the servo limit: a target reached from one side of the hysteresis
        // loop must stay reachable from the other
        target_limit: 0.8,
        hysteresis_width: 0.10,
        hysteresis_asymmetry: 0.3,
        natural_freq_hz: f,
        damping_ratio: 0.3,
        pressure_tau_s: 0.15,
        servo_limit: 1.0,
    }
}

impl Default for SimConfig {
    fn default() -> Self {
        SimConfig {
            dt_s: 0.001,
            settle_s: 1.2,
            shoulder_height_mm: 400.0,
            upper_arm_mm: 420.0,
            forearm_mm: 400.0,
            hand_mm: 160.0,
            light_offset_mm: 50.0,
            link_radius_mm: 35.0,
            pixel_noise_px: 0.3,
            vision: Vision::Geometric,
            joints: vec![
                joint("base", -17.0, 17.0, 1.6),
                joint("shoulder", -3.0, 53.0, 1.8),
                joint("elbow", -135.0, -45.0, 2.0),
                joint("wrist A", -45.0, 45.0, 2.5),
                joint("wrist B", -45.0, 45.0, 2.5),
            ],
            cameras: vec![
                CameraConfig {
                    resolution: [1024, 768],
                    focal_px: 800.0,
                    position_mm: [2100.0, -650.0, 650.0],
                    look_at_mm: [550.0, 0.0, 450.0],
                    distortion: [0.0, 0.0],
                },
                CameraConfig {
                    resolution: [1024, 768],
                    focal_px: 800.0,
                    position_mm: [2100.0, 650.0, 650.0],
                    look_at_mm: [550.0, 0.0, 450.0],
                    distortion: [0.0, 0.0],
                },
            ],
            drift: DriftConfig {
                temperature: false,
                temperature_amplitude_deg: 1.0,
                temperature_period_s: 3600.0,
                wear: false,
                wear_gain_per_rad: 1e-4,
                wear_offset_deg_per_rad: 0.01,
                wear_gain_max: default_wear_gain_max(),
                wear_offset_max_deg: default_wear_offset_max_deg(),
            },
            realism: RealismConfig::default(),
            pixels: PixelsConfig::default(),
            approach_mm: 40.0,
            cylinder_radius_mm: 25.0,
            cylinder_length_mm: 120.0,
            grasp_distance_mm: 15.0,
            grasp_angle_deg: 10.0,
        }
    }
}

impl SimConfig {
    /// The ideal plant: independent joints, a deterministic arm, a Prandtl-Ishlinskii loop
    /// whose asymmetry is an offset, no creep, Gaussian centroid noise only, no lens
    /// distortion, no wear. The built-in default (`Default`) and the base of the plant sweep
    /// (docs/plant.md); runs default to the realistic plant.
    pub fn ideal() -> SimConfig {
        SimConfig::default()
    }

    /// The realistic plant: the ideal one with gravity coupling, process noise, a
    /// generalised (skewed) loop that widens under load, creep, camera outliers and
    /// dropouts, occlusion by the hand and the cylinder, a typical lens's barrel distortion
    /// and bounded wear (off until drift.wear is turned on). Magnitudes and their reasons:
    /// `host/sim.toml`, section `[realism]`.
    pub fn realistic() -> SimConfig {
        let mut c = SimConfig::ideal();
        c.realism = RealismConfig {
            sag_shoulder_deg: 2.0,
            sag_elbow_deg: 1.5,
            load_width_gain: 0.5,
            process_noise_deg: 0.03,
            creep_fraction: 0.03,
            creep_tau_s: 3.0,
            hysteresis_skew: 0.3,
            outlier_rate: 0.002,
            dropout_rate: 0.005,
            occlude_hand_and_cylinder: true,
            approach_depth: 0.0,
            approach_s: 0.0,
            approach_min: 0.0,
            approach_smooth: false,
        };
        for cam in &mut c.cameras {
            cam.distortion = [-0.08, 0.01];
        }
        c.drift.wear_gain_max = 0.05;
        c.drift.wear_offset_max_deg = 0.5;
        c
    }

    /// The ideal plant growing old, for life-long learning (`trn lifelong`): temperature
    /// drift and bounded wear on.
    /// - Temperature: every joint's rest angle moves by up to 3 degrees over a 1-hour cycle
    ///   (a few thousand moves). Natural rubber's modulus changes by about 1 % per kelvin, so
    ///   a 5-10 K swing of a workshop moves a tube pair's balance point by several percent of
    ///   a joint's range: 3 degrees is 5 % of the shoulder's 56 and 18 % of the base's 34.
    /// - Wear: the realistic plant's bounds (`wear_gain_max` 5 % of the gain,
    ///   `wear_offset_max_deg` 0.5 degrees; sim.toml): a McKibben muscle's braid and rubber
    ///   settle in early use, then change slowly. With the default rates the bounds are
    ///   reached after some hundred trials.
    pub fn aging() -> SimConfig {
        SimConfig::ideal().grown_old()
    }

    /// The realistic plant growing old: [`SimConfig::realistic`] with the drift and wear
    /// [`SimConfig::aging`] adds to the ideal plant (3 degrees over a 1-hour cycle, wear
    /// bounded at 5 % of the gain and 0.5 degrees). The two are not independent on the real
    /// arm: drift moves the poses the arm is asked to hold, and so where the hand, the links
    /// and a cylinder hide the gripper's lights from the cameras, which the realistic
    /// plant's occlusion models and the ideal plant's does not (only the upper arm and the
    /// forearm hide lights there). Grasps under drift depend on both, so life-long learning
    /// is measured on both together.
    pub fn realistic_aging() -> SimConfig {
        SimConfig::realistic().grown_old()
    }

    /// This plant with the temperature drift and bounded wear of [`SimConfig::aging`].
    fn grown_old(mut self) -> SimConfig {
        self.drift.temperature = true;
        self.drift.temperature_amplitude_deg = 3.0;
        self.drift.temperature_period_s = 3600.0;
        self.drift.wear = true;
        let r = SimConfig::realistic().drift;
        self.drift.wear_gain_max = r.wear_gain_max;
        self.drift.wear_offset_max_deg = r.wear_offset_max_deg;
        self
    }

    /// The names [`SimConfig::named`] knows, in the order help texts list them.
    pub const NAMES: [&'static str; 4] = ["ideal", "realistic", "aging", "realistic-aging"];

    /// A built-in configuration by name: one of [`SimConfig::NAMES`].
    pub fn named(name: &str) -> Option<SimConfig> {
        match name {
            "ideal" => Some(SimConfig::ideal()),
            "realistic" => Some(SimConfig::realistic()),
            "aging" => Some(SimConfig::aging()),
            "realistic-aging" => Some(SimConfig::realistic_aging()),
            _ => None,
        }
    }

    /// Parses and validates a TOML configuration. A parse error quotes at most a few lines
    /// of the input.
    pub fn from_toml_str(s: &str) -> Result<SimConfig, SimError> {
        let cfg: SimConfig =
            toml::from_str(s).map_err(|e| SimError::Config(clipped(&e.to_string())))?;
        cfg.validate()?;
        Ok(cfg)
    }

    /// The configuration `--config` names: a built-in one by name ([`SimConfig::NAMES`])
    /// unless a file of that name exists, else the file; the realistic plant when
    /// none is given.
    pub fn resolve(path: Option<&Path>) -> Result<SimConfig, SimError> {
        match path {
            None => Ok(SimConfig::realistic()),
            Some(p) => match p.to_str().and_then(SimConfig::named) {
                Some(c) if !p.exists() => Ok(c),
                _ if matches!(p.symlink_metadata(), Err(e) if e.kind() == std::io::ErrorKind::NotFound) => {
                    Err(SimError::Config(format!(
                        "{}: neither a built-in configuration ({}) nor a file",
                        p.display(),
                        SimConfig::NAMES.join(", ")
                    )))
                }
                _ => SimConfig::load(p),
            },
        }
    }

    /// Reads, parses and validates a TOML file (at most [`MAX_FILE_BYTES`]).
    pub fn load(path: &Path) -> Result<SimConfig, SimError> {
        let named = |e: String| SimError::Config(format!("{}: {e}", path.display()));
        let file = crate::input::open(path).map_err(|e| named(e.to_string()))?;
        let mut bytes = Vec::new();
        std::io::Read::read_to_end(
            &mut std::io::Read::take(file, MAX_FILE_BYTES + 1),
            &mut bytes,
        )
        .map_err(|e| named(e.to_string()))?;
        if bytes.len() as u64 > MAX_FILE_BYTES {
            return Err(named(format!(
                "larger than {MAX_FILE_BYTES} bytes: not a simulator configuration"
            )));
        }
        let s = String::from_utf8(bytes).map_err(|_| named("not UTF-8 text".into()))?;
        Self::from_toml_str(&s).map_err(|e| match e {
            SimError::Config(m) => SimError::Config(format!("{}: {m}", path.display())),
            other => other,
        })
    }

    /// The first camera's image size (the controller's initial weights span it).
    pub fn image_size(&self) -> (u32, u32) {
        self.cameras
            .first()
            .map(|c| (c.resolution[0], c.resolution[1]))
            .unwrap_or((1024, 768))
    }
}

/// The largest configuration file read (1 MiB: `sim.toml` is about 10 KiB).
pub const MAX_FILE_BYTES: u64 = 1 << 20;

/// An error message cut to a readable length (a garbage file of one long line would be
/// quoted whole by the TOML parser).
fn clipped(msg: &str) -> String {
    const MAX: usize = 600;
    let mut out: String = msg
        .lines()
        .map(|l| {
            if l.chars().count() > 120 {
                l.chars().take(117).chain("...".chars()).collect()
            } else {
                l.to_string()
            }
        })
        .collect::<Vec<_>>()
        .join("\n");
    if out.len() > MAX {
        let cut = (0..=MAX)
            .rev()
            .find(|&i| out.is_char_boundary(i))
            .unwrap_or(0);
        out.truncate(cut);
        out.push_str("...");
    }
    out
}
