//! The SoftArm plant: five hysteretic pneumatic joints behind servo drive units, the arm's
//! kinematics, two cameras watching its lights, and cylinders to grasp.
//!
//! Time advances in fixed physics steps ([`Plant::step`]); a camera reading is taken after
//! [`Plant::settle`], so residual oscillation is part of the error. Every random draw comes
//! from a seeded `Xoshiro256PlusPlus`: the same seed gives the same trajectory bit for bit.

pub mod camera;
pub mod config;
pub mod joint;
pub mod kinematics;
#[cfg(feature = "plot")]
pub mod picture;

use rand_core::{RngCore, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;

use camera::{add, cross, dot, norm, scale, sub, unit, Camera, V3};
pub use config::{CameraConfig, DriftConfig, JointConfig, SimConfig};
use joint::Joint;
pub use kinematics::{Chain, Pose};

/// Errors of the simulator.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum SimError {
    /// A configuration value is wrong; the message names the key.
    #[error("{0}")]
    Config(String),
    /// A joint index outside 0..5.
    #[error("joint {0} does not exist (0..5)")]
    NoSuchJoint(usize),
}

/// Why a light has no reading.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PointStatus {
    /// A valid centroid.
    Valid,
    /// Outside the image or behind the camera.
    OutOfView,
    /// Hidden behind the arm.
    Occluded,
    /// Not detected (unused).
    NotDetected,
}

/// One light in one camera (pixels); `x`, `y` are NaN unless valid.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PixelReading {
    /// Column.
    pub x: f64,
    /// Row.
    pub y: f64,
    /// Validity.
    pub status: PointStatus,
}

/// `K` readings: each light in camera 0, then camera 1.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Observation<const K: usize> {
    /// The readings.
    pub points: [PixelReading; K],
}

impl<const K: usize> Observation<K> {
    /// The readings as the controller's input vector, or `None` if any is invalid.
    pub fn to_vector<const D: usize>(&self) -> Option<[f32; D]> {
        if D != 2 * K || self.points.iter().any(|p| p.status != PointStatus::Valid) {
            return None;
        }
        let mut v = [0.0; D];
        for (i, p) in self.points.iter().enumerate() {
            v[2 * i] = p.x as f32;
            v[2 * i + 1] = p.y as f32;
        }
        Some(v)
    }
}

/// Servo drive feedback.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ServoFeedback {
    /// Pressure in the tubes, 12-bit.
    pub raw_pressure: u16,
    /// The command was clipped to the drive's limit.
    pub saturated: bool,
}

/// A cylinder to grasp.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cylinder {
    /// Centre of mass (mm).
    pub centre: V3,
    /// Unit axis (ZZ').
    pub axis: V3,
    /// Radius (mm).
    pub radius: f64,
    /// Length (mm).
    pub length: f64,
}

/// How well a grasp went.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GraspScore {
    /// Gripper centre to cylinder centre (mm).
    pub distance_mm: f64,
    /// Deviation of the gripper from perpendicular to the cylinder axis (degrees).
    pub perpendicular_error_deg: f64,
    /// Both within the configured limits.
    pub success: bool,
}

/// The plant.
#[derive(Debug, Clone)]
pub struct Plant {
    cfg: SimConfig,
    joints: Vec<Joint>,
    cameras: [Camera; 2],
    noise: Xoshiro256PlusPlus,
    time_s: f64,
    cylinder: Option<Cylinder>,
}

fn gaussian(rng: &mut Xoshiro256PlusPlus) -> f64 {
    // Box-Muller from two uniforms in (0, 1]
    let u1 = ((rng.next_u64() >> 11) as f64 + 1.0) / (1u64 << 53) as f64;
    let u2 = (rng.next_u64() >> 11) as f64 / (1u64 << 53) as f64;
    (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
}

/// Uniform in `[lo, hi)`.
pub fn uniform(rng: &mut impl RngCore, lo: f64, hi: f64) -> f64 {
    lo + (hi - lo) * ((rng.next_u64() >> 11) as f64 / (1u64 << 53) as f64)
}

fn angle_between(a: &V3, b: &V3) -> f64 {
    (dot(a, b) / (norm(a) * norm(b)))
        .clamp(-1.0, 1.0)
        .acos()
        .to_degrees()
}

/// Distance from point `p` to the segment `a`-`b`.
fn segment_distance(p: &V3, a: &V3, b: &V3) -> f64 {
    let ab = sub(b, a);
    let t = (dot(&sub(p, a), &ab) / dot(&ab, &ab)).clamp(0.0, 1.0);
    norm(&sub(p, &add(a, &scale(&ab, t))))
}

/// Closest distance between segments `p0`-`p1` and `q0`-`q1` (sampled; links are short).
fn segments_distance(p0: &V3, p1: &V3, q0: &V3, q1: &V3) -> f64 {
    let mut best = f64::INFINITY;
    for i in 0..=40 {
        let t = i as f64 / 40.0;
        let p = add(p0, &scale(&sub(p1, p0), t));
        best = best.min(segment_distance(&p, q0, q1));
    }
    best
}

impl Plant {
    /// A plant at rest at zero pressure; `seed` drives the camera noise.
    pub fn new(cfg: &SimConfig, seed: u64) -> Result<Plant, SimError> {
        cfg.validate()?;
        Ok(Plant {
            joints: cfg.joints.iter().map(Joint::new).collect(),
            cameras: [Camera::new(&cfg.cameras[0]), Camera::new(&cfg.cameras[1])],
            noise: Xoshiro256PlusPlus::seed_from_u64(seed ^ 0x0CA3_E4A5_0153),
            time_s: 0.0,
            cylinder: None,
            cfg: cfg.clone(),
        })
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
    pub fn servo_command_raw(&mut self, joint: usize, raw: u16) -> Result<ServoFeedback, SimError> {
        let j = self
            .joints
            .get_mut(joint)
            .ok_or(SimError::NoSuchJoint(joint))?;
        let (raw_pressure, saturated) = j.command_raw(raw);
        Ok(ServoFeedback {
            raw_pressure,
            saturated,
        })
    }

    /// Commands all five joints (normalised pressures), through the servo drives.
    pub fn command(&mut self, p: &[f32; 5]) {
        for (j, &x) in self.joints.iter_mut().zip(p) {
            j.command_raw(joint::raw_of(x as f64));
        }
    }

    /// Commands some joints.
    pub fn command_joints(&mut self, p: &[(usize, f32)]) {
        for &(i, x) in p {
            if let Some(j) = self.joints.get_mut(i) {
                j.command_raw(joint::raw_of(x as f64));
            }
        }
    }

    /// One physics step.
    pub fn step(&mut self) {
        let dt = self.cfg.dt_s;
        let d = &self.cfg.drift;
        let temp = if d.temperature {
            d.temperature_amplitude_deg.to_radians()
                * (2.0 * std::f64::consts::PI * self.time_s / d.temperature_period_s).sin()
        } else {
            0.0
        };
        for j in &mut self.joints {
            let (gain, wear_off) = if d.wear {
                (
                    (1.0 - d.wear_gain_per_rad * j.travel).max(0.5),
                    (d.wear_offset_deg_per_rad * j.travel).to_radians(),
                )
            } else {
                (1.0, 0.0)
            };
            j.gain = gain;
            j.offset = temp + wear_off;
            j.step(dt);
        }
        self.time_s += dt;
    }

    /// Advances time by `seconds`.
    pub fn advance(&mut self, seconds: f64) {
        let n = (seconds / self.cfg.dt_s).round() as usize;
        for _ in 0..n {
            self.step();
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

    fn read(&mut self, cam: usize, p: &V3, noisy: bool, chain: &Chain) -> PixelReading {
        let invalid = |status| PixelReading {
            x: f64::NAN,
            y: f64::NAN,
            status,
        };
        let camera = &self.cameras[cam];
        let Some((u, v)) = camera.project(p) else {
            return invalid(PointStatus::OutOfView);
        };
        // hidden behind the upper arm or the forearm (capsules)
        let eye = camera.position();
        let r = self.cfg.link_radius_mm;
        let along = unit(&sub(p, &eye));
        let near = sub(p, &scale(&along, 2.0 * r)); // stop short of the light itself
        for (a, b) in [
            (&chain.shoulder, &chain.elbow),
            (&chain.elbow, &chain.wrist),
        ] {
            if segments_distance(&eye, &near, a, b) < r {
                return invalid(PointStatus::Occluded);
            }
        }
        let s = self.cfg.pixel_noise_px;
        let (du, dv) = if noisy {
            (s * gaussian(&mut self.noise), s * gaussian(&mut self.noise))
        } else {
            (0.0, 0.0)
        };
        PixelReading {
            x: u + du,
            y: v + dv,
            status: PointStatus::Valid,
        }
    }

    fn observe_points<const K: usize>(&mut self, lights: &[V3], noisy: bool) -> Observation<K> {
        let chain = self.chain();
        let mut points = [PixelReading {
            x: f64::NAN,
            y: f64::NAN,
            status: PointStatus::NotDetected,
        }; K];
        for (i, light) in lights.iter().enumerate() {
            for cam in 0..2 {
                if let Some(slot) = points.get_mut(2 * i + cam) {
                    *slot = self.read(cam, light, noisy, &chain);
                }
            }
        }
        Observation { points }
    }

    /// The gripper lights p and q in both cameras (stage 1's 8-D input), with pixel noise.
    pub fn observe_gripper_lights(&mut self) -> Observation<4> {
        let l = kinematics::lights(&self.cfg, &self.gripper_pose());
        self.observe_points(&l, true)
    }

    /// The same without noise (ground truth).
    pub fn observe_gripper_lights_true(&mut self) -> Observation<4> {
        let l = kinematics::lights(&self.cfg, &self.gripper_pose());
        self.observe_points(&l, false)
    }

    /// The gripper-centre light in both cameras (stage 2's 4-D input), with pixel noise.
    pub fn observe_gripper_centre(&mut self) -> Observation<2> {
        let c = self.gripper_pose().centre_mm;
        self.observe_points(&[c], true)
    }

    /// The same without noise.
    pub fn observe_gripper_centre_true(&mut self) -> Observation<2> {
        let c = self.gripper_pose().centre_mm;
        self.observe_points(&[c], false)
    }

    /// Places a cylinder for the current pose as the pre-grasp pose (Fig. 8.3): its axis
    /// along the gripper's normal (parallel to the line of the lights p and q, which are the
    /// gripper's lights now), its centre `approach_mm` ahead of the gripper centre.
    pub fn place_cylinder(&mut self) -> Cylinder {
        let pose = self.gripper_pose();
        let c = Cylinder {
            centre: add(
                &pose.centre_mm,
                &scale(&pose.approach, self.cfg.approach_mm),
            ),
            axis: pose.normal,
            radius: self.cfg.cylinder_radius_mm,
            length: self.cfg.cylinder_length_mm,
        };
        self.cylinder = Some(c);
        c
    }

    /// The cylinder placed last.
    pub fn cylinder(&self) -> Option<&Cylinder> {
        self.cylinder.as_ref()
    }

    /// The centre of the cylinder (the middle of its axis ab) in both cameras, with noise.
    pub fn observe_cylinder_centre(&mut self) -> Observation<2> {
        self.observe_cylinder(true)
    }

    /// The same without noise.
    pub fn observe_cylinder_centre_true(&mut self) -> Observation<2> {
        self.observe_cylinder(false)
    }

    fn observe_cylinder(&mut self, noisy: bool) -> Observation<2> {
        match self.cylinder {
            Some(c) => self.observe_points(&[c.centre], noisy),
            None => {
                let none = PixelReading {
                    x: f64::NAN,
                    y: f64::NAN,
                    status: PointStatus::NotDetected,
                };
                Observation { points: [none; 2] }
            }
        }
    }

    /// Position (mm) and orientation (degrees) error of the gripper now against `target`.
    pub fn pose_error(&self, target: &Pose) -> (f32, f32) {
        let now = self.gripper_pose();
        let mm = norm(&sub(&now.centre_mm, &target.centre_mm));
        let deg = angle_between(&now.approach, &target.approach)
            .max(angle_between(&now.normal, &target.normal));
        (mm as f32, deg as f32)
    }

    /// Scores a grasp of `cyl` with the gripper where it is now.
    pub fn grasp_score(&self, cyl: &Cylinder) -> GraspScore {
        let pose = self.gripper_pose();
        let distance_mm = norm(&sub(&pose.centre_mm, &cyl.centre));
        // perpendicular: the cylinder axis along the gripper normal, i.e. perpendicular to
        // both the approach direction and the finger axis
        let tilt = angle_between(&pose.normal, &cyl.axis);
        let perpendicular_error_deg = tilt.min(180.0 - tilt);
        let success = distance_mm <= self.cfg.grasp_distance_mm
            && perpendicular_error_deg <= self.cfg.grasp_angle_deg;
        GraspScore {
            distance_mm,
            perpendicular_error_deg,
            success,
        }
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

    /// Perpendicular unit vector helper for pictures.
    pub fn cross(a: &V3, b: &V3) -> V3 {
        cross(a, b)
    }
}
