//! The physical limit as a controller (`--controller oracle`, in process only): it solves
//! for the target on an exact copy of the plant as it is at that moment (every joint's
//! hysteresis history, creep, drift, wear; [`trn_plant::Plant::expected`]: the same plant
//! whose next moves carry no process noise), and after each move solves again from the
//! plant's new state. What stands between it and the target is only what no controller can
//! know beforehand: the process noise of the move, the camera noise of the target and of
//! the reading it stops on. Every figure of the comparison is also given as a ratio to its.

use nalgebra::SVector;
use trn_controller::Config;

use crate::model_based::{ArmModel, ModelBased};
use crate::rig::SharedPlant;
use crate::spec::ControllerChoice;

/// The live plant, read (never changed) at each decision.
pub struct LiveModel {
    plant: SharedPlant,
}

impl ArmModel for LiveModel {
    fn image<const D: usize>(&mut self, p: &[f64; 5]) -> Option<SVector<f64, D>> {
        let mut copy = self.plant.borrow().expected();
        if D == 8 {
            copy.command(&p.map(|x| x as f32));
        } else {
            // stage 2 moves joints 0..=2; the wrist keeps what it holds
            copy.command_joints(&[(0, p[0] as f32), (1, p[1] as f32), (2, p[2] as f32)]);
        }
        copy.settle();
        let v: Option<[f32; D]> = if D == 8 {
            copy.observe_gripper_lights_true().to_vector()
        } else {
            copy.observe_gripper_centre_true().to_vector()
        };
        v.map(|v| SVector::from_fn(|i, _| v[i] as f64))
    }

    /// The pressures the arm holds now (the runner may have moved it between trials).
    fn start(&self, _held: [f64; 5], _joints: usize) -> [f64; 5] {
        let plant = self.plant.borrow();
        let mut p = [0.0; 5];
        for (x, j) in p.iter_mut().zip(plant.joints()) {
            *x = j.commanded();
        }
        p
    }

    fn resolves(&self) -> bool {
        true
    }

    fn law(&self) -> ControllerChoice {
        ControllerChoice::Oracle
    }

    /// Four steps of the drives' 12-bit command (one is 2 / 4095 of the range).
    fn step_size(&self) -> f64 {
        4.0 * 2.0 / 4095.0
    }
}

/// The oracle controller.
pub type Oracle = ModelBased<LiveModel>;

impl Oracle {
    /// The oracle of the plant `plant` (shared with the rig that moves it), stopping by
    /// `cfg`'s mature tolerance and cap.
    pub fn new(plant: SharedPlant, cfg: Config) -> Oracle {
        ModelBased::on(LiveModel { plant }, cfg)
    }
}
