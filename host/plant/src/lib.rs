//! `trn-plant`: the simulated SoftArm, usable alone (a runner, a Python binding, another
//! controller's test bench need nothing else): five hysteretic pneumatic joints behind servo
//! drive units, the arm's kinematics, two cameras watching its lights, cylinders to grasp,
//! the named configurations, and the plant's CAN nodes as sans-IO state machines
//! ([`nodes`]).
//!
//! Time advances in fixed physics steps ([`Plant::step`]); a camera reading is taken after
//! [`Plant::settle`], so residual oscillation is part of the error. Every random draw comes
//! from a seeded `Xoshiro256PlusPlus`: the same seed gives the same trajectory bit for bit.
//! `sim.toml` beside this crate documents every configuration value.

pub mod camera;
pub mod config;
mod error;
pub mod geometry;
mod grasp;
pub mod input;
pub mod joint;
pub mod kinematics;
pub mod markers;
pub mod model;
pub mod nodes;
pub mod pixels;
pub mod random;
mod readings;
pub mod stereo;
pub mod targets;
mod validate;

use rand_core::{RngCore, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;

use crate::PlantError as Error;
use camera::Camera;
pub use config::{
    CameraConfig, DriftConfig, JointConfig, PixelsConfig, RealismConfig, SimConfig, Vision,
};
pub use error::PlantError;
pub use grasp::{Cylinder, GraspScore};
use joint::Joint;
pub use kinematics::{Chain, Pose};
pub use nalgebra::Vector3;
pub use random::uniform;
pub use readings::{Occluder, PixelReading, Readings};
/// A reading's status is the protocol's ([`stereo`] and [`markers`] say when the plant reports
/// a light not detected or estimated).
pub use trn_protocol::PointStatus;

/// Servo drive feedback.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ServoFeedback {
    /// Pressure in the tubes, 12-bit.
    pub raw_pressure: u16,
    /// The command was clipped to the drive's limit.
    pub saturated: bool,
}

/// The plant.
/// Serializable: its whole state goes into a run's simulator checkpoint
/// (the lab's simulator checkpoint).
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct Plant {
    cfg: SimConfig,
    joints: Vec<Joint>,
    cameras: [Camera; 2],
    noise: Xoshiro256PlusPlus,
    /// Each joint's generator of its process noise (one per joint: a joint's draws do not
    /// depend on the order in which the drives' commands arrive, which a lost or late
    /// frame changes).
    move_noise: Vec<Xoshiro256PlusPlus>,
    time_s: f64,
    cylinder: Option<Cylinder>,
    /// The step of [`Plant::set_exact_step`], when set (not part of the plant's saved
    /// state: whoever set it sets it again on a restored plant).
    #[serde(skip)]
    exact_step_s: Option<f64>,
    /// The camera processor's fit of [`Plant::set_fit`] (not part of the plant's saved
    /// state either).
    #[serde(skip)]
    fit: markers::Fit,
}

/// The coarsest step [`Plant::set_exact_step`] takes (s).
pub const EXACT_STEP_MAX_S: f64 = 0.05;

/// One process-noise generator per joint, from the plant's seed.
fn move_noise(seed: u64, joints: usize) -> Vec<Xoshiro256PlusPlus> {
    (0..joints as u64)
        .map(|j| {
            Xoshiro256PlusPlus::seed_from_u64(seed ^ 0x9E37_79B9_7F4A_7C15u64.wrapping_mul(j + 1))
        })
        .collect()
}

impl Plant {
    /// A plant at rest at zero pressure; `seed` drives the camera noise.
    pub fn new(cfg: &SimConfig, seed: u64) -> Result<Plant, Error> {
        cfg.validate()?;
        Ok(Plant {
            joints: joints_of(cfg),
            cameras: [Camera::new(&cfg.cameras[0]), Camera::new(&cfg.cameras[1])],
            noise: Xoshiro256PlusPlus::seed_from_u64(seed ^ 0x0CA3_E4A5_0153),
            move_noise: move_noise(seed ^ 0x0CA3_E4A5_0153, cfg.joints.len()),
            time_s: 0.0,
            cylinder: None,
            cfg: cfg.clone(),
            exact_step_s: None,
            fit: markers::Fit::Differences,
        })
    }

    /// A second arm of the same make, in the same state of drift and wear (the same time,
    /// the same cumulative travel per joint), but at rest at zero pressure with a fresh
    /// hysteresis history, no cylinder, and its own camera noise from `seed`. Deployment-style
    /// targets come from a twin: a pose reached along a history independent of the arm's.
    pub fn twin(&self, seed: u64) -> Plant {
        let mut joints = joints_of(&self.cfg);
        for (t, j) in joints.iter_mut().zip(&self.joints) {
            t.travel = j.travel;
        }
        let mut twin = Plant {
            joints,
            cameras: self.cameras.clone(),
            noise: Xoshiro256PlusPlus::seed_from_u64(seed ^ 0x071A_5EED),
            move_noise: move_noise(seed ^ 0x071A_5EED, self.joints.len()),
            time_s: self.time_s,
            cylinder: None,
            cfg: self.cfg.clone(),
            exact_step_s: self.exact_step_s,
            fit: self.fit,
        };
        // the drift and wear of this moment, applied at rest
        twin.step();
        twin.time_s = self.time_s;
        twin
    }

    /// The configuration.
    pub fn config(&self) -> &SimConfig {
        &self.cfg
    }

    /// Simulated time (s).
    pub fn time_s(&self) -> f64 {
        self.time_s
    }

    /// The joints.
    pub fn joints(&self) -> &[Joint] {
        &self.joints
    }

    /// Servo drive unit of `joint`: a 12-bit pressure command.
    pub fn servo_command_raw(&mut self, joint: usize, raw: u16) -> Result<ServoFeedback, Error> {
        let (raw_pressure, saturated) = self
            .command_one(joint, raw)
            .ok_or(Error::NoSuchJoint(joint))?;
        Ok(ServoFeedback {
            raw_pressure,
            saturated,
        })
    }

    /// Commands all five joints (normalised pressures), through the servo drives.
    pub fn command(&mut self, p: &[f32; 5]) {
        for (i, &x) in p.iter().enumerate() {
            self.command_one(i, joint::raw_of(x as f64));
        }
    }

    /// One joint's command; a new one (another pressure) draws the move's process noise
    /// (none without process noise: a copy of the plant with it switched off, [`Plant::expected`],
    /// moves as the plant does on average).
    fn command_one(&mut self, i: usize, raw: u16) -> Option<(u16, bool)> {
        let sigma = self.cfg.realism.process_noise_deg.to_radians();
        let j = self.joints.get_mut(i)?;
        let new = joint::raw_of(j.commanded()) != raw;
        let out = j.command_raw(raw);
        if new {
            j.effects.process_offset = if sigma > 0.0 {
                let rng = self.move_noise.get_mut(i)?;
                sigma * random::gaussian(rng)
            } else {
                0.0
            };
        }
        Some(out)
    }

    /// An exact copy of the plant now (every joint's hysteresis history, creep, drift, wear,
    /// the cylinder) whose future moves carry no process noise: what it does next is what
    /// this plant does on average. The oracle solves on it.
    pub fn expected(&self) -> Plant {
        let mut copy = self.clone();
        copy.cfg.realism.process_noise_deg = 0.0;
        copy
    }

    /// Puts every joint at rest at its equilibrium for pressures `p` at once (no dynamics,
    /// no time passes): the static map of a model (the model-based reference), tests.
    pub fn settle_joints_at(&mut self, p: &[f64; 5]) {
        for (j, &x) in self.joints.iter_mut().zip(p) {
            j.settle_at(x);
        }
    }

    /// Commands some joints.
    pub fn command_joints(&mut self, p: &[(usize, f32)]) {
        for &(i, x) in p {
            self.command_one(i, joint::raw_of(x as f64));
        }
    }

    /// Gravity's share of each joint's equilibrium (radians: the sag, negative = down) and
    /// the load of shoulder and elbow in [0, 1] (the gravity torque of the posture over the
    /// torque with the arm stretched out horizontally). Relative masses: upper arm 1,
    /// forearm 0.8, hand with a grasped load 0.7, each at the middle of its link.
    fn gravity(&self) -> ([f64; 5], [f64; 5]) {
        let r = &self.cfg.realism;
        let (mut sag, mut load) = ([0.0; 5], [0.0; 5]);
        if r.sag_shoulder_deg == 0.0 && r.sag_elbow_deg == 0.0 && r.load_width_gain == 0.0 {
            return (sag, load);
        }
        let q = self.joint_angles();
        let (lu, lf, lh) = (self.cfg.upper_arm_mm, self.cfg.forearm_mm, self.cfg.hand_mm);
        let (mu, mf, mh) = (1.0, 0.8, 0.7);
        let (a1, a2) = (q[1], q[1] + q[2]);
        let a3 = a2 + 0.5 * (q[3] + q[4]);
        let (c1, c2, c3) = (a1.cos(), a2.cos(), a3.cos());
        let elbow = mf * 0.5 * lf * c2 + mh * (lf * c2 + 0.5 * lh * c3);
        let elbow_max = mf * 0.5 * lf + mh * (lf + 0.5 * lh);
        let shoulder = mu * 0.5 * lu * c1 + (mf + mh) * lu * c1 + elbow;
        let shoulder_max = mu * 0.5 * lu + (mf + mh) * lu + elbow_max;
        load[1] = (shoulder / shoulder_max).abs();
        load[2] = (elbow / elbow_max).abs();
        sag[1] = -r.sag_shoulder_deg.to_radians() * shoulder / shoulder_max;
        sag[2] = -r.sag_elbow_deg.to_radians() * elbow / elbow_max;
        (sag, load)
    }

    /// One physics step of the configuration's `dt_s` by Euler's rule (the lab's step),
    /// whatever [`Plant::set_exact_step`] set: [`Plant::advance`] and [`Plant::settle`] are
    /// what take the exact steps.
    pub fn step(&mut self) {
        let c = self.step_constants();
        self.step_with(&c);
    }

    /// Each joint's constants of a physics step ([`Joint::step_constants`]), the same for
    /// every step of an [`Plant::advance`].
    fn step_constants(&self) -> Vec<joint::StepConstants> {
        let dt = self.cfg.dt_s;
        self.joints.iter().map(|j| j.step_constants(dt)).collect()
    }

    /// One physics step with each joint's constants from [`Plant::step_constants`].
    fn step_with(&mut self, constants: &[joint::StepConstants]) {
        self.set_effects();
        for (j, c) in self.joints.iter_mut().zip(constants) {
            j.step_with(c);
        }
        self.time_s += self.cfg.dt_s;
    }

    /// One exact step ([`Plant::set_exact_step`]) of `step_s`.
    fn step_exact(&mut self, step_s: f64, constants: &[joint::ExactConstants]) {
        self.set_effects();
        for (j, c) in self.joints.iter_mut().zip(constants) {
            j.step_exact(c);
        }
        self.time_s += step_s;
    }

    /// Settles by steps of `step_s` (at most [`EXACT_STEP_MAX_S`]) with each joint's
    /// dynamics solved exactly over a step ([`Joint::step_exact`]) instead of the
    /// configuration's `dt_s` steps of Euler's rule: fewer steps for the same settle, close
    /// to the lab's 1 ms steps (a coarser physics for the Python environment). `None` goes
    /// back to the configuration's steps. A plant restored from its saved state has none.
    pub fn set_exact_step(&mut self, step_s: Option<f64>) -> Result<(), Error> {
        if let Some(s) = step_s {
            if !(1e-4..=EXACT_STEP_MAX_S).contains(&s) {
                return Err(Error::Config(format!(
                    "the exact physics step is between 0.0001 and {EXACT_STEP_MAX_S} s, got {s}"
                )));
            }
        }
        self.exact_step_s = step_s;
        Ok(())
    }

    /// How the camera processor fits the marker body to fill in a hidden light
    /// ([`markers::Fit`]; the lab's forward differences unless set). A plant restored from
    /// its saved state has the lab's.
    pub fn set_fit(&mut self, fit: markers::Fit) {
        self.fit = fit;
    }

    /// The step of [`Plant::set_exact_step`], if set.
    pub fn exact_step(&self) -> Option<f64> {
        self.exact_step_s
    }

    /// Drift, wear and gravity of this moment set on every joint, for the step that follows.
    #[inline(always)]
    fn set_effects(&mut self) {
        let d = &self.cfg.drift;
        let temp = if d.temperature {
            d.temperature_amplitude_deg.to_radians()
                * (2.0 * std::f64::consts::PI * self.time_s / d.temperature_period_s).sin()
        } else {
            0.0
        };
        let (sag, load) = self.gravity();
        let load_width_gain = self.cfg.realism.load_width_gain;
        for (i, j) in self.joints.iter_mut().enumerate() {
            let (gain, wear_off) = if d.wear {
                // linear in the travel at first, bounded (drift.wear_gain_max,
                // drift.wear_offset_max_deg)
                let off_max = d.wear_offset_max_deg;
                (
                    1.0 - (d.wear_gain_per_rad * j.travel).min(d.wear_gain_max),
                    (d.wear_offset_deg_per_rad * j.travel)
                        .clamp(-off_max, off_max)
                        .to_radians(),
                )
            } else {
                (1.0, 0.0)
            };
            j.gain = gain;
            j.offset = temp + wear_off + sag[i];
            if load_width_gain > 0.0 {
                j.effects.width_scale = 1.0 + load_width_gain * load[i];
            }
        }
    }

    /// Advances time by `seconds`: by the configuration's `dt_s` steps of Euler's rule (the
    /// lab's), or by the exact steps of [`Plant::set_exact_step`] when set.
    pub fn advance(&mut self, seconds: f64) {
        if let Some(step) = self.exact_step_s {
            let n = (seconds / step).round() as usize;
            let constants: Vec<_> = self
                .joints
                .iter()
                .map(|j| j.exact_constants(step))
                .collect();
            for _ in 0..n {
                self.step_exact(step, &constants);
            }
            return;
        }
        let n = (seconds / self.cfg.dt_s).round() as usize;
        let constants = self.step_constants();
        for _ in 0..n {
            self.step_with(&constants);
        }
    }

    /// Advances by the configured settle time (a camera reading follows).
    pub fn settle(&mut self) {
        self.advance(self.cfg.settle_s);
    }

    /// Joint angles now (radians).
    pub fn joint_angles(&self) -> [f64; 5] {
        let mut q = [0.0; 5];
        for (a, j) in q.iter_mut().zip(&self.joints) {
            *a = j.angle();
        }
        q
    }

    /// The arm's chain now.
    pub fn chain(&self) -> Chain {
        kinematics::forward(&self.cfg, &self.joint_angles())
    }

    /// The gripper's pose now (ground truth).
    pub fn gripper_pose(&self) -> Pose {
        self.chain().pose
    }

    /// Random pressures within each joint's target limits ("split brain" targets).
    pub fn random_pressures(&self, rng: &mut impl RngCore) -> [f32; 5] {
        let mut p = [0.0f32; 5];
        for (x, j) in p.iter_mut().zip(&self.cfg.joints) {
            *x = uniform(rng, -j.target_limit, j.target_limit) as f32;
        }
        p
    }

    /// Commands random pressures to the first `n` joints and settles: "the robot arm went to
    /// a particular arbitrarily chosen position" before each trial.
    pub fn move_to_random_joints(&mut self, rng: &mut impl RngCore, n: usize) {
        let p = self.random_pressures(rng);
        let cmds: Vec<(usize, f32)> = (0..n.min(5)).map(|i| (i, p[i])).collect();
        self.command_joints(&cmds);
        self.settle();
    }

    /// Position (mm) and orientation (degrees) error of the gripper now against `target`.
    pub fn pose_error(&self, target: &Pose) -> (f32, f32) {
        self.gripper_pose().error_to(target)
    }

    /// Extent (mm) of the gripper centre over `n` random pressure vectors: the 1st to 99th
    /// percentile along x, y and z, at equilibrium (no dynamics).
    pub fn workspace_extent(&self, rng: &mut impl RngCore, n: usize) -> [f64; 3] {
        let mut j: Vec<Joint> = self.cfg.joints.iter().map(Joint::new).collect();
        let mut xs = [
            Vec::with_capacity(n),
            Vec::with_capacity(n),
            Vec::with_capacity(n),
        ];
        for _ in 0..n {
            let p = self.random_pressures(rng);
            let mut q = [0.0; 5];
            for k in 0..5 {
                j[k].settle_at(p[k] as f64);
                q[k] = j[k].angle();
            }
            let c = kinematics::forward(&self.cfg, &q).pose.centre_mm;
            for k in 0..3 {
                xs[k].push(c[k]);
            }
        }
        let mut out = [0.0; 3];
        for k in 0..3 {
            xs[k].sort_by(f64::total_cmp);
            let lo = xs[k][n / 100];
            let hi = xs[k][n - 1 - n / 100];
            out[k] = hi - lo;
        }
        out
    }
}

/// The joints of a configuration, with their share of the real arm's effects.
fn joints_of(cfg: &SimConfig) -> Vec<Joint> {
    let r = &cfg.realism;
    cfg.joints
        .iter()
        .map(|c| {
            let mut j = Joint::new(c);
            j.effects = joint::JointEffects {
                skew: r.hysteresis_skew,
                creep_fraction: r.creep_fraction,
                creep_tau_s: r.creep_tau_s,
                ..joint::JointEffects::NONE
            };
            j
        })
        .collect()
}
