//! [`Arm`]: the simulated SoftArm as the core of a reaching environment, as the lab's
//! held-out evaluation sets a trial up.
//!
//! `reset(seed)` builds the plant from `seed`, draws a deployment-style target (a twin arm
//! in the same state goes from rest along its own random path to random pressures; its
//! lights, read by the camera processor, are the target: `trn_plant::targets::HeldOut`) and
//! moves the arm to a start pose of its own (stage 2: with the target's wrist pressures,
//! since stage 2 drives joints 0..=2 only). `step(action)` commands the pressures through
//! the servo drives' 12-bit commands and reads the cameras as the camera processor does
//! (settle, stereo check, new frames, hidden lights filled from the marker fit): one move.

use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use rand_core::SeedableRng;
use rand_xoshiro::Xoshiro256PlusPlus;
use trn_plant::kinematics::{forward, lights};
use trn_plant::markers::Tracker;
use trn_plant::targets::{HeldOut, Target};
use trn_plant::vec3::V3;
use trn_plant::{Plant, PointStatus, Readings, SimConfig};

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

/// The simulated arm, a target and the last reading (see the module).
#[pyclass(module = "trn_softarm._native")]
pub struct Arm {
    cfg: SimConfig,
    stage: u8,
    plant: Plant,
    target: Target,
    /// The camera processor's memory of where the markers were.
    track: Tracker,
    commanded: [f32; 5],
    lights: Vec<f64>,
    status: Vec<u8>,
    moves: u32,
}

impl Arm {
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

    /// Noise-free projections of this stage's lights now, and whether each is in view.
    fn truth(&mut self) -> (Vec<f64>, Vec<bool>) {
        let (xy, status) = if self.stage == 1 {
            reading(&self.plant.observe_gripper_lights_true())
        } else {
            reading(&self.plant.observe_gripper_centre_true())
        };
        (xy, status.iter().map(|&s| s == 0).collect())
    }
}

fn dist(a: &[f64], b: &[f64]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y) * (x - y))
        .sum::<f64>()
        .sqrt()
}

#[pymethods]
impl Arm {
    /// An arm of the named plant (`realistic`, `ideal`, `aging`, or a TOML file) for stage
    /// 1 (5 pressures, lights p and q) or 2 (3 pressures, the gripper-centre light).
    #[new]
    #[pyo3(signature = (config = "realistic", stage = 1))]
    fn new(config: &str, stage: u8) -> PyResult<Arm> {
        if !(1..=2).contains(&stage) {
            return Err(PyValueError::new_err("stage is 1 or 2"));
        }
        let cfg = SimConfig::resolve(Some(std::path::Path::new(config)))
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        let plant = Plant::new(&cfg, 0).map_err(|e| PyValueError::new_err(e.to_string()))?;
        let k = if stage == 1 { 4 } else { 2 };
        Ok(Arm {
            cfg,
            stage,
            plant,
            target: Target::NONE,
            track: Tracker::default(),
            commanded: [0.0; 5],
            lights: vec![0.0; 2 * k],
            status: vec![3; k],
            moves: 0,
        })
    }

    /// A new episode from `seed`: the plant, the target and the start pose; the arm's first
    /// reading follows.
    fn reset(&mut self, seed: u64) -> PyResult<()> {
        self.plant =
            Plant::new(&self.cfg, seed).map_err(|e| PyValueError::new_err(e.to_string()))?;
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed ^ 0x5EED_0FA5_C1A5);
        let held = HeldOut::set(&self.plant, &mut rng, 1, false)
            .map_err(|e| PyRuntimeError::new_err(e.to_string()))?[0];
        self.target = held
            .realise(&self.plant, false)
            .map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
        let mut start = held.start;
        if self.stage == 2 {
            start[3] = held.pressures[3];
            start[4] = held.pressures[4];
        }
        self.plant.command(&start);
        self.commanded = start;
        self.track = Tracker::default();
        self.moves = 0;
        self.capture();
        Ok(())
    }

    /// One move: the pressures of the joints this stage drives (5 or 3, each in [-1, 1]),
    /// then the cameras' reading.
    fn step(&mut self, action: Vec<f32>) -> PyResult<()> {
        let n = self.joints();
        if action.len() != n || action.iter().any(|a| !a.is_finite()) {
            return Err(PyValueError::new_err(format!(
                "an action is {n} finite pressures, got {action:?}"
            )));
        }
        for (c, a) in self.commanded.iter_mut().zip(&action) {
            *c = a.clamp(-1.0, 1.0);
        }
        let cmds: Vec<(usize, f32)> = (0..n).map(|j| (j, self.commanded[j])).collect();
        self.plant.command_joints(&cmds);
        self.moves += 1;
        self.capture();
        Ok(())
    }

    /// Joints this stage drives.
    #[getter]
    fn joints(&self) -> usize {
        if self.stage == 1 {
            5
        } else {
            3
        }
    }

    /// The stage (1 or 2).
    #[getter]
    fn stage(&self) -> u8 {
        self.stage
    }

    /// Both cameras' image size (width, height), pixels.
    #[getter]
    fn image_size(&self) -> (u32, u32) {
        self.cfg.image_size()
    }

    /// The last reading: pixels (x, y of each light in camera 0 then 1), status codes, and
    /// the target as measured.
    fn observation(&self) -> (Vec<f64>, Vec<u8>, Vec<f64>) {
        (self.lights.clone(), self.status.clone(), self.target_of().0)
    }

    /// What the agent is not shown: the noise-free truth, the errors, the arm's state.
    fn info<'py>(&mut self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let (target, target_true) = self.target_of();
        let (truth, in_view) = self.truth();
        let d = PyDict::new(py);
        let valid = self.status.iter().all(|&s| s == 0);
        d.set_item("error_px", valid.then(|| dist(&self.lights, &target)))?;
        d.set_item(
            "error_true_px",
            in_view
                .iter()
                .all(|&v| v)
                .then(|| dist(&truth, &target_true)),
        )?;
        d.set_item("lights_true", truth)?;
        d.set_item("lights_true_in_view", in_view)?;
        d.set_item("target_true", target_true)?;
        d.set_item("pressures", self.commanded.to_vec())?;
        d.set_item(
            "joint_angles_deg",
            self.plant.gripper_pose().joint_angles_deg.to_vec(),
        )?;
        d.set_item("gripper_mm", self.plant.gripper_pose().centre_mm.to_vec())?;
        d.set_item("target_gripper_mm", self.target.pose.centre_mm.to_vec())?;
        let (mm, deg) = self.plant.pose_error(&self.target.pose);
        d.set_item("pose_error_mm", mm as f64)?;
        d.set_item("pose_error_deg", deg as f64)?;
        d.set_item(
            "noise_floor_px",
            if self.stage == 1 {
                self.target.noise_v
            } else {
                self.target.noise_c
            } as f64,
        )?;
        d.set_item("time_s", self.plant.time_s())?;
        d.set_item("moves", self.moves)?;
        Ok(d)
    }

    /// The scene in 3-D (mm, base frame): the arm's joints from the base to the gripper
    /// centre, its lights p and q, the target's gripper centre and lights, the cameras.
    fn geometry<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyDict>> {
        let chain = self.plant.chain();
        let d = PyDict::new(py);
        let links: Vec<V3> = vec![
            [0.0, 0.0, 0.0],
            chain.shoulder,
            chain.elbow,
            chain.wrist,
            chain.pose.centre_mm,
        ];
        d.set_item("links", links)?;
        d.set_item("lights", lights(&self.cfg, &chain.pose).to_vec())?;
        let t = forward(
            &self.cfg,
            &self.target.pose.joint_angles_deg.map(f64::to_radians),
        );
        d.set_item(
            "target_links",
            vec![t.shoulder, t.elbow, t.wrist, t.pose.centre_mm],
        )?;
        d.set_item("target_lights", lights(&self.cfg, &t.pose).to_vec())?;
        let cams: Vec<[f64; 3]> = self.cfg.cameras.iter().map(|c| c.position_mm).collect();
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
        let (target, _) = self.target_of();
        let scene = render::Scene {
            cfg: &self.cfg,
            chain: self.plant.chain(),
            lights: &self.lights,
            status: &self.status,
            target: &target,
        };
        Ok(render::cameras(&scene, scale))
    }
}

/// The full configuration of a named plant (or a TOML file) as JSON.
#[pyfunction]
#[pyo3(signature = (name = "realistic"))]
pub fn config_json(name: &str) -> PyResult<String> {
    let cfg = SimConfig::resolve(Some(std::path::Path::new(name)))
        .map_err(|e| PyValueError::new_err(e.to_string()))?;
    serde_json::to_string(&cfg).map_err(|e| PyRuntimeError::new_err(e.to_string()))
}
