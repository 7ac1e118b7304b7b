//! `trn-sim`: the simulated SoftArm plant and the experiment around the TRN controller.
//!
//! - [`arm`]: the plant: hysteretic pneumatic joints behind servo drives, kinematics,
//!   stereo cameras, cylinders.
//! - [`experiment`]: the plant's CAN nodes, the experiment runner, reports, plots and the
//!   `trn` command line.

pub mod arm;
pub mod experiment;

/// The plant under its conventional name.
pub use arm as plant;
