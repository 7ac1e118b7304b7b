//! `trn-sim`: the simulated SoftArm plant and the experiment around the TRN controller.
//!
//! - [`plant`]: the plant: hysteretic pneumatic joints behind servo drives, kinematics,
//!   stereo cameras, cylinders.
//! - [`nodes`]: the plant's CAN nodes (servo drives, camera processor, gripper) as sans-IO
//!   state machines.
//! - [`experiment`]: the runner, the rig that serves the bus, scoring, reports, plots and
//!   the `trn` command line.
//! - [`transport`]: the bus forms and the controller's side of a run (thread, process,
//!   firmware in QEMU).

mod error;
pub mod experiment;
pub mod nodes;
pub mod plant;
pub mod reference;
pub mod transport;

pub use error::{Error, Result};
