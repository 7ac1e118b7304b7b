//! The physical limit as a controller (`--controller oracle`, in process only): it solves
//! for the target on an exact copy of the plant as it is at that moment (every joint's
//! hysteresis history, creep, drift, wear; [`trn_plant::Plant::expected`]: the same plant
//! whose next moves carry no process noise), and after each move solves again from the
//! plant's new state. What stands between it and the target is only what no controller can
//! know beforehand: the process noise of the move, the camera noise of the target and of
//! the reading it stops on. Every figure of the comparison is also given as a ratio to its.

use std::cell::RefCell;
use std::rc::Rc;

use nalgebra::SVector;
use trn_controller::Config;
use trn_plant::Plant;

use crate::model_based::{ArmModel, ModelBased};

/// The plant of a rig, shared with a controller that may look at its true state (the
/// oracle, in process only): the rig never holds a borrow across a wait on the bus, when
/// such a controller runs.
pub type SharedPlant = Rc<RefCell<Plant>>;

/// Where the oracle reads the plant: shared with the rig that moves it ([`SharedPlant`]),
/// or a copy handed to it before each decision (a [`Plant`]; the Python binding's).
pub trait PlantSource {
    /// `f` of the plant as it is now.
    fn read<R>(&self, f: impl FnOnce(&Plant) -> R) -> R;
}

impl PlantSource for SharedPlant {
    fn read<R>(&self, f: impl FnOnce(&Plant) -> R) -> R {
        f(&self.borrow())
    }
}

impl PlantSource for Plant {
    fn read<R>(&self, f: impl FnOnce(&Plant) -> R) -> R {
        f(self)
    }
}

/// The live plant, read (never changed) at each decision.
pub struct LiveModel<S = SharedPlant> {
    /// The plant it reads.
    pub plant: S,
}

impl<S: PlantSource> ArmModel for LiveModel<S> {
    fn image<const D: usize>(&mut self, p: &[f64; 5]) -> Option<SVector<f64, D>> {
        let mut copy = self.plant.read(Plant::expected);
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
        self.plant.read(|plant| {
            let mut p = [0.0; 5];
            for (x, j) in p.iter_mut().zip(plant.joints()) {
                *x = j.commanded();
            }
            p
        })
    }

    fn resolves(&self) -> bool {
        true
    }

    fn law_code(&self) -> u8 {
        crate::law_code::ORACLE
    }

    /// Four steps of the drives' 12-bit command (one is 2 / 4095 of the range).
    fn step_size(&self) -> f64 {
        4.0 * 2.0 / 4095.0
    }
}

/// The oracle controller, reading the plant from `S`.
pub type Oracle<S = SharedPlant> = ModelBased<LiveModel<S>>;

impl<S: PlantSource> Oracle<S> {
    /// The oracle of the plant `plant` (shared with the rig that moves it), stopping by
    /// `cfg`'s mature tolerance and cap.
    pub fn new(plant: S, cfg: Config) -> Oracle<S> {
        ModelBased::on(LiveModel { plant }, cfg)
    }
}
