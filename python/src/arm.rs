//! [`Arm`]: the simulated SoftArm as the core of a reaching environment, as the lab's
//! held-out evaluation sets a trial up (many of them stepped in one call: `crate::arm_vec`).
//!
//! `reset(seed)` builds the plant from `seed`, draws a deployment-style target (a twin arm
//! in the same state goes from rest along its own random path to random pressures; its
//! lights, read by the camera processor, are the target: `trn_plant::targets::HeldOut`) and
//! moves the arm to a start pose of its own (stage 2: with the target's wrist pressures,
//! since stage 2 drives joints 0..=2 only). `step(action)` commands the pressures through
//! the servo drives' 12-bit commands and reads the cameras as the camera processor does
//! (settle, stereo check, new frames, hidden lights filled from the marker fit): one move.
//!
//! The options ([`Options`]) change the plant the lab runs only when asked: `dt_s` (a
//! coarser physics step, each joint's dynamics solved exactly over it: faster, and close to
//! the lab's 1 ms steps), `persistent` (the arm carries over from one episode to the
//! next: drift and wear build up), `randomise` (each plant built draws its joints'
//! dynamics and loop width around the configured values, from the episode's seed).
//!
//! An arm's whole state (the plant's hysteresis, creep, drift, wear, noise generators, the
//! target, the camera processor's memory) is saved by `state()` and restored bit for bit by
//! `from_state` (pickling in Python).

use pyo3::exceptions::{PyRuntimeError, PyValueError};

use crate::ahead::Ahead;
use pyo3::prelude::*;
use pyo3::types::{PyByteArray, PyBytes, PyDict};
use pyo3::IntoPyObjectExt;
use rand_core::SeedableRng;
use rand_xoshiro::Xoshiro256PlusPlus;
use serde::{Deserialize, Serialize};
use trn_plant::camera::Camera;
use trn_plant::kinematics::{forward, lights};
use trn_plant::markers::{Fit, Tracker};
use trn_plant::pixels::PixelVision;
use trn_plant::targets::{HeldOut, Target};
use trn_plant::{uniform, Plant, PointStatus, Readings, SimConfig, Vector3};
use trn_vision::CaptureProtocol;

use crate::render;

/// A light's reading for Python: pixels (0, 0 when invalid) and the protocol's status code
/// (0 valid, 1 out of view, 2 occluded, 3 not detected, 4 estimated: a hidden light the
/// camera processor placed from what it saw and where the markers were, not a reading).
fn reading<const K: usize>(r: &Readings<K>) -> (Vec<f64>, Vec<u8>) {
    let mut xy = Vec::with_capacity(2 * K);
    let mut status = Vec::with_capacity(K);
    for p in &r.points {
        let code = match p.status {
            PointStatus::Valid if p.x.is_finite() && p.y.is_finite() => 0,
            PointStatus::Valid | PointStatus::NotDetected => 3,
            PointStatus::OutOfView => 1,
            PointStatus::Occluded => 2,
            PointStatus::Estimated => 4,
        };
        let (x, y) = if matches!(code, 0 | 4) {
            (p.x, p.y)
        } else {
            (0.0, 0.0)
        };
        xy.extend([x, y]);
        status.push(code);
    }
    (xy, status)
}

/// How an arm departs from the lab's plant (see the module); the default departs in nothing.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Options {
    /// The physics step (s) of a settle, each joint's dynamics solved exactly over a step
    /// (`Plant::set_exact_step`, at most `trn_plant::EXACT_STEP_MAX_S`), instead of the
    /// configuration's 1 ms steps of Euler's rule.
    pub dt_s: Option<f64>,
    /// The plant carries over from one episode to the next.
    pub persistent: bool,
    /// Each joint's natural frequency, damping ratio, pressure lag and loop width are the
    /// configured ones times a factor drawn from [1 - randomise, 1 + randomise].
    pub randomise: f64,
}

/// Largest `randomise`.
const RANDOMISE_MAX: f64 = 0.5;

/// What the agent is not shown, computed once a reading is taken.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
struct Truth {
    lights_true: Vec<f64>,
    in_view: Vec<bool>,
    joint_angles_deg: [f64; 5],
    gripper_mm: Vector3<f64>,
    pose_error_mm: f32,
    pose_error_deg: f32,
}

/// One simulated arm, its target and its last reading: the state an [`Arm`] wraps and an
/// [`ArmVec`] holds many of.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct Sim {
    /// The configuration as named (before the options' changes).
    cfg: SimConfig,
    options: Options,
    stage: u8,
    plant: Plant,
    /// Whether `plant` has been through a reset (a persistent arm keeps it from then on).
    started: bool,
    /// The seed the plant was built from.
    plant_seed: u64,
    target: Target,
    /// The camera processor's memory of where the markers were.
    track: Tracker,
    commanded: [f32; 5],
    lights: Vec<f64>,
    status: Vec<u8>,
    truth: Truth,
    moves: u32,
    /// The seed of the episode (its frames' noise is drawn from it and the move).
    episode_seed: u64,
}

/// Appends the `scale` x `scale` block means (rounded) of the `width`-wide frame `px` to
/// `out`, row by row; a partial block at the right or bottom edge is left out.
fn bin(px: &[u8], width: usize, scale: usize, out: &mut Vec<u8>) {
    let (w, h) = (width / scale, px.len() / width / scale);
    let area = (scale * scale) as u32;
    for by in 0..h {
        for bx in 0..w {
            let sum: u32 = (0..scale)
                .flat_map(|dy| {
                    let row = (by * scale + dy) * width + bx * scale;
                    px[row..row + scale].iter().map(|&v| v as u32)
                })
                .sum();
            out.push(((sum + area / 2) / area) as u8);
        }
    }
}

fn dist(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y) * (x - y))
        .sum::<f64>()
        .sqrt()
}

impl Sim {
    /// An arm of `cfg` for `stage`, not reset yet.
    pub fn new(cfg: SimConfig, stage: u8, options: Options) -> Result<Sim, String> {
        if !(1..=2).contains(&stage) {
            return Err("stage is 1 or 2".into());
        }
        if !(0.0..=RANDOMISE_MAX).contains(&options.randomise) {
            return Err(format!(
                "randomise is a fraction in [0, {RANDOMISE_MAX}], got {}",
                options.randomise
            ));
        }
        // every plant `randomise` can draw is valid: each bound the configuration's
        // validation checks is on one value, so the extreme factors are the cases to check
        let r = options.randomise;
        for f in [1.0 - r, 1.0 + r] {
            Sim::scaled(&cfg, || f).validate().map_err(|e| {
                if r > 0.0 {
                    format!("randomise {r}: a plant it can draw is not valid: {e}")
                } else {
                    e.to_string()
                }
            })?;
        }
        let plant = Sim::build_plant(&cfg, &options, 0)?;
        let k = if stage == 1 { 4 } else { 2 };
        Ok(Sim {
            cfg,
            options,
            stage,
            plant,
            started: false,
            plant_seed: 0,
            target: Target::NONE,
            track: Tracker::default(),
            commanded: [0.0; 5],
            lights: vec![0.0; 2 * k],
            status: vec![3; k],
            truth: Truth::default(),
            moves: 0,
            episode_seed: 0,
        })
    }

    /// The plant of an episode's `seed`: the options' randomised joints, stepped at the
    /// options' `dt_s`.
    fn build_plant(cfg: &SimConfig, options: &Options, seed: u64) -> Result<Plant, String> {
        let mut plant =
            Plant::new(&Sim::plant_config(cfg, options, seed), seed).map_err(|e| e.to_string())?;
        Sim::step_as_the_options_say(&mut plant, options)?;
        Ok(plant)
    }

    /// `plant` stepped at the options' `dt_s` (the step is not part of a plant's saved
    /// state), its camera processor fitting hidden lights with the analytic Jacobian when
    /// `dt_s` is set ([`trn_plant::markers::Fit::Analytic`]) and as the lab does otherwise.
    fn step_as_the_options_say(plant: &mut Plant, options: &Options) -> Result<(), String> {
        plant
            .set_exact_step(options.dt_s)
            .map_err(|e| format!("dt_s: {e}"))?;
        plant.set_fit(match options.dt_s {
            Some(_) => Fit::Analytic,
            None => Fit::Differences,
        });
        Ok(())
    }

    /// An arm restored from its saved state: its plant's step set again from its options.
    pub(crate) fn restored(mut self) -> Result<Sim, String> {
        Sim::step_as_the_options_say(&mut self.plant, &self.options)?;
        Ok(self)
    }

    /// The configuration of a plant built from `seed`: the options' randomised joints.
    fn plant_config(cfg: &SimConfig, options: &Options, seed: u64) -> SimConfig {
        let r = options.randomise;
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed ^ 0x0DA1_B0A7_5EED);
        Sim::scaled(cfg, || {
            if r > 0.0 {
                uniform(&mut rng, 1.0 - r, 1.0 + r)
            } else {
                1.0
            }
        })
    }

    /// `cfg` with each joint's natural frequency, damping ratio, pressure lag and loop
    /// width multiplied by successive `factor()`s.
    fn scaled(cfg: &SimConfig, mut factor: impl FnMut() -> f64) -> SimConfig {
        let mut c = cfg.clone();
        for j in &mut c.joints {
            j.natural_freq_hz *= factor();
            j.damping_ratio *= factor();
            j.pressure_tau_s *= factor();
            j.hysteresis_width *= factor();
        }
        c
    }

    /// The arm settles and the cameras read, as the camera processor serves a capture.
    fn capture(&mut self) {
        self.plant.settle();
        let (xy, status) = if self.stage == 1 {
            reading(&self.plant.gripper_lights_filled(&mut self.track).0)
        } else {
            reading(&self.plant.gripper_centre_filled(&mut self.track).0)
        };
        self.lights = xy;
        self.status = status;
        let (lights_true, status) = if self.stage == 1 {
            reading(&self.plant.observe_gripper_lights_true())
        } else {
            reading(&self.plant.observe_gripper_centre_true())
        };
        let pose = self.plant.gripper_pose();
        let (mm, deg) = pose.error_to(&self.target.pose);
        self.truth = Truth {
            lights_true,
            in_view: status.iter().map(|&s| s == 0).collect(),
            joint_angles_deg: pose.joint_angles_deg,
            gripper_mm: pose.centre_mm,
            pose_error_mm: mm,
            pose_error_deg: deg,
        };
    }

    /// The target's readings for this stage (noisy as measured, and noise-free).
    fn target_of(&self) -> (Vec<f64>, Vec<f64>) {
        let f = |v: &[f32]| v.iter().map(|&x| x as f64).collect::<Vec<_>>();
        if self.stage == 1 {
            (f(&self.target.v), f(&self.target.v_true))
        } else {
            (f(&self.target.c), f(&self.target.c_true))
        }
    }

    /// The last reading: pixels, status codes, and the target as measured.
    pub(crate) fn observation(&self) -> (&[f64], &[u8], Vec<f64>) {
        (&self.lights, &self.status, self.target_of().0)
    }

    /// The last reading as the environment observes it, appended to `obs`: pixels and
    /// target as float32, each clipped to `bounds` (a NaN stays NaN, as numpy's
    /// `maximum`/`minimum` leave it), status codes as bytes.
    pub(crate) fn observation_into(&self, bounds: &Bounds, obs: &mut ObservationBytes) {
        let (lights, status, target) = self.observation();
        obs.lights
            .extend(bounds.clip(lights).flat_map(f32::to_ne_bytes));
        obs.status.extend_from_slice(status);
        obs.target
            .extend(bounds.clip(&target).flat_map(f32::to_ne_bytes));
    }

    /// Whether `reset(seed)` gives the same arm whatever this one went through (a
    /// persistent arm carries its plant over instead).
    pub(crate) fn resets_afresh(&self) -> bool {
        !self.options.persistent
    }

    /// Starts building the episode that `reset(seed)` gives, from a copy of this arm (see
    /// `crate::ahead`); `None` for an arm that carries its plant over, whose next episode
    /// depends on this one.
    pub(crate) fn build_ahead(&self, seed: u64, name: String) -> Option<Ahead<Sim>> {
        if !self.resets_afresh() {
            return None;
        }
        let mut sim = self.clone();
        Ahead::start(seed, name, move || sim.reset(seed).map(|()| sim))
    }

    /// The reset to `seed`, taking the episode built ahead for it when it is ready (then
    /// `Ok(true)`), else building it here.
    pub(crate) fn reset_taking(
        &mut self,
        seed: u64,
        ahead: Option<Ahead<Sim>>,
    ) -> Result<bool, String> {
        match Ahead::take(ahead, seed) {
            Some(ready) => {
                *self = ready;
                Ok(true)
            }
            None => self.reset(seed).map(|()| false),
        }
    }

    /// A new episode from `seed` (see the module).
    pub fn reset(&mut self, seed: u64) -> Result<(), String> {
        if !(self.options.persistent && self.started) {
            self.plant = Sim::build_plant(&self.cfg, &self.options, seed)?;
            self.plant_seed = seed;
            self.started = true;
        }
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed ^ 0x5EED_0FA5_C1A5);
        let (held, target) =
            HeldOut::set_realised(&self.plant, &mut rng, 1, false).map_err(|e| e.to_string())?[0];
        self.target = target;
        let mut start = held.start;
        if self.stage == 2 {
            start[3] = held.pressures[3];
            start[4] = held.pressures[4];
        }
        self.plant.command(&start);
        self.commanded = start;
        self.track = Tracker::default();
        self.moves = 0;
        self.episode_seed = seed;
        self.capture();
        Ok(())
    }

    /// The frames of the arm's lights as the cameras take them now, one capture each, one
    /// light per frame as the camera processor lights them (stage 1: p then q; stage 2: the
    /// centre light), every pixel rendered (`trn_plant::pixels`, the plant's `[pixels]`
    /// section), each `scale` x `scale` block of pixels averaged (binning; rounded):
    /// `(width, height, frames per camera, samples)`, the samples camera by camera, frame
    /// by frame, row by row. The noise is drawn from the episode's seed and the move, so an
    /// arm restored from its state gives the same frames.
    pub fn frames(&self, scale: u32) -> Result<(u32, u32, usize, Vec<u8>), String> {
        let pose = self.plant.gripper_pose();
        let marks = if self.stage == 1 {
            lights(self.plant.config(), &pose).to_vec()
        } else {
            vec![pose.centre_mm]
        };
        let protocol = CaptureProtocol::sequential(marks.len()).map_err(|e| e.to_string())?;
        let vision = PixelVision::from_config(&self.plant.config().pixels);
        let (mut w, mut h, mut out) = (0, 0, Vec::new());
        for cam in 0..2 {
            let seed = self.episode_seed ^ ((self.moves as u64) << 40) ^ ((cam as u64) << 56);
            for f in self
                .plant
                .capture_frames(cam, &marks, &protocol, &vision, seed)
                .map_err(|e| e.to_string())?
            {
                (w, h) = (f.width() / scale, f.height() / scale);
                bin(f.as_raw(), f.width() as usize, scale as usize, &mut out);
            }
        }
        Ok((w, h, protocol.frames(), out))
    }

    /// One move (see [`Arm::step`]).
    pub fn step(&mut self, action: &[f32]) -> Result<(), String> {
        let n = self.joints();
        if action.len() != n || action.iter().any(|a| !a.is_finite()) {
            return Err(format!("an action is {n} finite pressures, got {action:?}"));
        }
        for (c, a) in self.commanded.iter_mut().zip(action) {
            *c = a.clamp(-1.0, 1.0);
        }
        let cmds: Vec<(usize, f32)> = (0..n).map(|j| (j, self.commanded[j])).collect();
        self.plant.command_joints(&cmds);
        self.moves += 1;
        self.capture();
        Ok(())
    }

    pub(crate) fn joints(&self) -> usize {
        if self.stage == 1 {
            5
        } else {
            3
        }
    }

    pub(crate) fn info<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let d = PyDict::new(py);
        for (key, value) in self.info_values() {
            d.set_item(key, value.into_py(py)?)?;
        }
        Ok(d)
    }

    /// The measured error (pixels) from the target: the info's `error_px`, `None` when a
    /// reading is not valid.
    fn error_px(&self) -> Option<f64> {
        let valid = self.status.iter().all(|&s| s == 0);
        valid.then(|| dist(&self.lights, &self.target_of().0))
    }

    /// The reward, whether the episode ended at the target (terminated) and whether it ran
    /// out of moves (truncated), by `rule`.
    pub(crate) fn outcome(&self, rule: &Outcome) -> (f64, bool, bool) {
        let err = self.error_px();
        let terminated = err.is_some_and(|e| e <= rule.tolerance_px);
        let truncated = !terminated && self.moves as u64 >= rule.max_moves;
        (err.map_or(-rule.diagonal, |e| -e), terminated, truncated)
    }

    /// The info's keys and values, in the info's order.
    pub(crate) fn info_values(&self) -> Vec<(&'static str, InfoValue)> {
        use InfoValue::*;
        let (_, target_true) = self.target_of();
        let t = &self.truth;
        let in_view = t.in_view.iter().all(|&v| v);
        let noise_floor_px = if self.stage == 1 {
            self.target.noise_v
        } else {
            self.target.noise_c
        } as f64;
        vec![
            ("error_px", Maybe(self.error_px())),
            (
                "error_true_px",
                Maybe(in_view.then(|| dist(&t.lights_true, &target_true))),
            ),
            ("lights_true", Points(t.lights_true.clone())),
            ("lights_true_in_view", Flags(t.in_view.clone())),
            ("target_true", Points(target_true)),
            (
                "pressures",
                Floats(self.commanded.iter().map(|&p| p as f64).collect()),
            ),
            ("joint_angles_deg", Floats(t.joint_angles_deg.to_vec())),
            (
                "gripper_mm",
                Floats(<[f64; 3]>::from(t.gripper_mm).to_vec()),
            ),
            (
                "target_gripper_mm",
                Floats(<[f64; 3]>::from(self.target.pose.centre_mm).to_vec()),
            ),
            ("pose_error_mm", Scalar(t.pose_error_mm as f64)),
            ("pose_error_deg", Scalar(t.pose_error_deg as f64)),
            ("noise_floor_px", Scalar(noise_floor_px)),
            ("time_s", Scalar(self.plant.time_s())),
            ("moves", Count(self.moves as u64)),
            ("plant_seed", Count(self.plant_seed)),
        ]
    }
}

/// How a move's reading is scored (the environment's `tolerance_px`, `max_moves` and the
/// image's diagonal): the reward is minus the measured error in pixels (minus the diagonal
/// when a reading is not valid), the episode ends at an error within the tolerance and is
/// cut off after `max_moves` moves.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Outcome {
    pub(crate) tolerance_px: f64,
    pub(crate) max_moves: u64,
    pub(crate) diagonal: f64,
}

/// The box an observed point is clipped to: `(x low, y low, x high, y high)`, pixels.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Bounds(pub(crate) [f32; 4]);

impl Bounds {
    /// `xy` (x and y of each point in turn) as float32, each clipped to its axis' range.
    fn clip<'a>(&'a self, xy: &'a [f64]) -> impl Iterator<Item = f32> + 'a {
        let [x0, y0, x1, y1] = self.0;
        xy.iter().enumerate().map(move |(k, &v)| {
            let (lo, hi) = if k % 2 == 0 { (x0, x1) } else { (y0, y1) };
            let v = v as f32;
            // numpy's maximum then minimum: a NaN is kept
            if v < lo {
                lo
            } else if v > hi {
                hi
            } else {
                v
            }
        })
    }
}

/// Pixels, status codes and targets as Python byte arrays (see [`ObservationBytes`]).
pub(crate) type ObservationArrays<'py> = (
    Bound<'py, PyByteArray>,
    Bound<'py, PyByteArray>,
    Bound<'py, PyByteArray>,
);

/// Observations as native-endian bytes, arm after arm: pixels (float32), status codes
/// (uint8), targets (float32); numpy's `frombuffer` makes the arrays of them.
#[derive(Default)]
pub(crate) struct ObservationBytes {
    pub(crate) lights: Vec<u8>,
    pub(crate) status: Vec<u8>,
    pub(crate) target: Vec<u8>,
}

impl ObservationBytes {
    pub(crate) fn into_py<'py>(self, py: Python<'py>) -> ObservationArrays<'py> {
        (
            PyByteArray::new(py, &self.lights),
            PyByteArray::new(py, &self.status),
            PyByteArray::new(py, &self.target),
        )
    }
}

/// A value of an arm's info (its Python type in `Arm.info()`).
pub(crate) enum InfoValue {
    /// A float.
    Scalar(f64),
    /// A float, or None (an error that a light not read leaves undefined).
    Maybe(Option<f64>),
    /// A list of floats.
    Floats(Vec<f64>),
    /// A list of floats, x and y of each point in turn.
    Points(Vec<f64>),
    /// A list of bools.
    Flags(Vec<bool>),
    /// An int.
    Count(u64),
}

impl InfoValue {
    fn into_py<'py>(self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        match self {
            InfoValue::Scalar(x) => x.into_bound_py_any(py),
            InfoValue::Maybe(x) => x.into_bound_py_any(py),
            InfoValue::Floats(v) | InfoValue::Points(v) => v.into_bound_py_any(py),
            InfoValue::Flags(v) => v.into_bound_py_any(py),
            InfoValue::Count(n) => n.into_bound_py_any(py),
        }
    }
}

pub(crate) fn value_err(e: String) -> PyErr {
    PyValueError::new_err(e)
}

/// A named plant or a TOML file, as `--config` takes them.
pub(crate) fn resolve(config: &str) -> PyResult<SimConfig> {
    SimConfig::resolve(Some(std::path::Path::new(config)))
        .map_err(|e| PyValueError::new_err(e.to_string()))
}

/// The simulated arm, a target and the last reading (see the module).
#[pyclass(module = "trn_softarm._native")]
pub struct Arm {
    sim: Sim,
    /// The next episode, being built (see [`crate::ahead`]).
    ahead: Option<Ahead<Sim>>,
    /// Resets that took an episode built ahead.
    taken: u64,
}

impl Arm {
    fn of(sim: Sim) -> Arm {
        Arm {
            sim,
            ahead: None,
            taken: 0,
        }
    }

    /// The configuration its plants are built from (the calibrated model's arm).
    pub(crate) fn sim_config(&self) -> &SimConfig {
        &self.sim.cfg
    }

    /// The plant as it is now (what the oracle solves on).
    pub(crate) fn plant(&self) -> &Plant {
        &self.sim.plant
    }
}

#[pymethods]
impl Arm {
    /// An arm of the named plant (`realistic`, `ideal`, `aging`, or a TOML file) for stage
    /// 1 (5 pressures, lights p and q) or 2 (3 pressures, the gripper-centre light); the
    /// options: see the module.
    #[new]
    #[pyo3(signature = (config = "realistic", stage = 1, dt_s = None, persistent = false, randomise = 0.0))]
    fn new(
        config: &str,
        stage: u8,
        dt_s: Option<f64>,
        persistent: bool,
        randomise: f64,
    ) -> PyResult<Arm> {
        let options = Options {
            dt_s,
            persistent,
            randomise,
        };
        Ok(Arm::of(
            Sim::new(resolve(config)?, stage, options).map_err(value_err)?,
        ))
    }

    /// A new episode from `seed`: the plant (unless persistent), the target and the start
    /// pose; the arm's first reading follows.
    fn reset(&mut self, py: Python<'_>, seed: u64) -> PyResult<()> {
        let (sim, ahead) = (&mut self.sim, self.ahead.take());
        let took = py
            .detach(|| sim.reset_taking(seed, ahead))
            .map_err(PyRuntimeError::new_err)?;
        self.taken += u64::from(took);
        Ok(())
    }

    /// Starts building the episode that `reset(seed)` gives, on a thread of the lowest
    /// priority (see `crate::ahead`): that reset takes it when it is ready. Nothing is built
    /// for a persistent arm, whose next episode depends on this one.
    fn prepare(&mut self, seed: u64) {
        Ahead::prepare(&mut self.ahead, seed, || {
            self.sim.build_ahead(seed, "trn-arm-ahead".into())
        });
    }

    /// Whether the next episode is built and waiting for its reset.
    #[getter]
    fn ready_ahead(&self) -> bool {
        self.ahead.as_ref().is_some_and(Ahead::is_ready)
    }

    /// Resets so far that took an episode built ahead.
    #[getter]
    fn resets_built_ahead(&self) -> u64 {
        self.taken
    }

    /// One move: the pressures of the joints this stage drives (5 or 3, each in [-1, 1]),
    /// then the cameras' reading.
    fn step(&mut self, py: Python<'_>, action: Vec<f32>) -> PyResult<()> {
        let sim = &mut self.sim;
        py.detach(|| sim.step(&action)).map_err(value_err)
    }

    /// Joints this stage drives.
    #[getter]
    fn joints(&self) -> usize {
        self.sim.joints()
    }

    /// The stage (1 or 2).
    #[getter]
    fn stage(&self) -> u8 {
        self.sim.stage
    }

    /// Both cameras' image size (width, height), pixels.
    #[getter]
    fn image_size(&self) -> (u32, u32) {
        self.sim.cfg.image_size()
    }

    /// The last reading: pixels (x, y of each light in camera 0 then 1), status codes, and
    /// the target as measured.
    fn observation(&self) -> (Vec<f64>, Vec<u8>, Vec<f64>) {
        let (xy, status, target) = self.sim.observation();
        (xy.to_vec(), status.to_vec(), target)
    }

    /// The last reading as the environment observes it: `(pixels, status codes, target)`
    /// as native-endian bytes (float32, uint8, float32), pixels and target clipped to
    /// `bounds` = `(x low, y low, x high, y high)`.
    fn observation_clipped<'py>(
        &self,
        py: Python<'py>,
        bounds: [f32; 4],
    ) -> ObservationArrays<'py> {
        let mut obs = ObservationBytes::default();
        self.sim.observation_into(&Bounds(bounds), &mut obs);
        obs.into_py(py)
    }

    /// The cameras' frames of the arm's lights now (see `Sim::frames`): `(width, height,
    /// frames per camera, samples)`, each `scale` x `scale` block of pixels averaged.
    #[pyo3(signature = (scale = 4))]
    fn frames<'py>(
        &self,
        py: Python<'py>,
        scale: u32,
    ) -> PyResult<(u32, u32, usize, Bound<'py, PyBytes>)> {
        if !(1..=16).contains(&scale) {
            return Err(PyValueError::new_err("scale is 1..=16"));
        }
        let sim = &self.sim;
        let (w, h, n, px) = py
            .detach(|| sim.frames(scale))
            .map_err(PyRuntimeError::new_err)?;
        Ok((w, h, n, PyBytes::new(py, &px)))
    }

    /// `(reward, terminated, truncated)` of the last move: the reward is minus the measured
    /// error (pixels), or minus `diagonal` when a reading is not valid; terminated at an
    /// error within `tolerance_px`; truncated, when not terminated, at `max_moves` moves.
    fn outcome(&self, tolerance_px: f64, max_moves: u64, diagonal: f64) -> (f64, bool, bool) {
        self.sim.outcome(&Outcome {
            tolerance_px,
            max_moves,
            diagonal,
        })
    }

    /// What the agent is not shown: the noise-free truth, the errors, the arm's state.
    fn info<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        self.sim.info(py)
    }

    /// The arm's whole state as bytes (restored bit for bit by `Arm.from_state`).
    fn state<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyBytes>> {
        let b =
            postcard::to_allocvec(&self.sim).map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
        Ok(PyBytes::new(py, &b))
    }

    /// The arm whose state `state()` gave.
    #[staticmethod]
    fn from_state(state: &[u8]) -> PyResult<Arm> {
        let sim = postcard::from_bytes::<Sim>(state)
            .map_err(|e| e.to_string())
            .and_then(Sim::restored)
            .map_err(|e| PyValueError::new_err(format!("not an arm's state: {e}")))?;
        Ok(Arm::of(sim))
    }

    /// Pickling (and `copy.deepcopy`): the state, restored by `Arm.from_state`.
    fn __reduce__<'py>(
        &self,
        py: Python<'py>,
    ) -> PyResult<(Bound<'py, PyAny>, (Bound<'py, PyBytes>,))> {
        let from = py
            .import("trn_softarm._native")?
            .getattr("arm_from_state")?;
        Ok((from, (self.state(py)?,)))
    }

    /// The scene in 3-D (mm, base frame): the arm's joints from the base to the gripper
    /// centre, its lights p and q, the target's gripper centre and lights, the cameras.
    fn geometry<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let s = &self.sim;
        let chain = s.plant.chain();
        let d = PyDict::new(py);
        // each point a list [x, y, z]
        let xyz = <[f64; 3]>::from;
        let links = chain.links();
        d.set_item("links", links.map(xyz))?;
        d.set_item("lights", lights(&s.cfg, &chain.pose).map(xyz))?;
        let t = forward(&s.cfg, &s.target.pose.joint_angles_deg.map(f64::to_radians));
        d.set_item(
            "target_links",
            [t.shoulder, t.elbow, t.wrist, t.pose.centre_mm].map(xyz),
        )?;
        d.set_item("target_lights", lights(&s.cfg, &t.pose).map(xyz))?;
        let cams: Vec<[f64; 3]> = s.cfg.cameras.iter().map(|c| c.position_mm).collect();
        d.set_item("cameras", cams)?;
        Ok(d)
    }

    /// Both camera images side by side, each `1 / scale` of the camera's resolution:
    /// `(width, height, rgb bytes)` (row-major, 3 bytes a pixel).
    #[pyo3(signature = (scale = 2))]
    fn render(&self, scale: u32) -> PyResult<(u32, u32, Vec<u8>)> {
        if !(1..=16).contains(&scale) {
            return Err(PyValueError::new_err("scale is 1..=16"));
        }
        let s = &self.sim;
        let (target, _) = s.target_of();
        let scene = render::Scene {
            cfg: &s.cfg,
            chain: s.plant.chain(),
            lights: &s.lights,
            status: &s.status,
            target: &target,
        };
        Ok(render::cameras(&scene, scale))
    }
}

/// The arm whose state `Arm.state()` gave (what unpickling calls).
#[pyfunction]
pub fn arm_from_state(state: &[u8]) -> PyResult<Arm> {
    Arm::from_state(state)
}

/// The cameras of a named plant (or a TOML file) as ideal pinholes (`trn_plant::camera::Pinhole`:
/// `position_mm`, `axes`, `focal_px`, `resolution`), a JSON list.
#[pyfunction]
#[pyo3(signature = (name = "realistic"))]
pub fn camera_pinholes(name: &str) -> PyResult<String> {
    let cfg = resolve(name)?;
    let pinholes: Vec<_> = cfg
        .cameras
        .iter()
        .map(|c| Camera::new(c).pinhole())
        .collect();
    serde_json::to_string(&pinholes).map_err(|e| PyRuntimeError::new_err(e.to_string()))
}

/// The full configuration of a named plant (or a TOML file) as JSON.
#[pyfunction]
#[pyo3(signature = (name = "realistic"))]
pub fn config_json(name: &str) -> PyResult<String> {
    serde_json::to_string(&resolve(name)?).map_err(|e| PyRuntimeError::new_err(e.to_string()))
}
