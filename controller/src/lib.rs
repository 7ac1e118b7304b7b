//! A topology representing network (TRN) controller for a hysteretic soft robot arm,
//! after K. Sarkar and K. Schulten, "Topology Representing Network in Robotics".
//!
//! `no_std`, no allocation, f32 arithmetic. Two statically sized networks:
//! stage 1 ([`Stage1Net`]: 1000 neurons, 8-D camera weights, 5 pressures, 5x8 Jacobians)
//! places and orients the gripper in front of a cylinder; stage 2 ([`Stage2Net`]: 200
//! neurons, 4-D, 3 pressures, 3x4 Jacobians) moves it onto the cylinder centre.
//!
//! The controller never blocks, never reads a clock and does no I/O: a [`Task`] goes in,
//! [`Command`]s come out, and each camera [`Observation`] is passed back in
//! ([`Controller::begin`], [`Controller::observe`]). The same code serves supervised
//! priming, unsupervised training, mature operation and the two-stage grasp.
//!
//! Modules, from the leaves up (no module imports one that imports it back):
//! - [`config`], `crc`, [`entry`], `error` ([`Error`]): numbers, the checksum, what a table stores,
//!   the errors.
//! - [`trial`]: what every stage law shares (a trial's outcome, its next step, the fine-move
//!   rule, the input check); [`law`]: the [`law::StageLaw`] trait a stage's law implements.
//! - [`rank`]: closeness ranking (8.2-8.4), full sort or partial selection.
//! - [`rules`]: the averaged output and every update (8.5-8.30), with the deviations named.
//! - [`stage`]: one network's learning step as a state machine (coarse move, fine moves
//!   until the tolerance (8.7) or a cap, updates).
//! - [`config`]: every constant; [`Config::paper`] beside [`Config::project_default`].
//! - [`presets`]: the named configurations every build (host, firmware) shares.
//! - [`checkpoint`]: postcard checkpoints with a version and a CRC, whole or in pieces.
//! - [`persist`]: what a node asks of the store that keeps the tables ([`persist::TableStore`]).
//! - [`broyden`]: the classical alternative without training (uncalibrated visual servoing
//!   with a Broyden Jacobian), selectable in place of the TRN ([`Law`]).
//! - [`Controller`]: the two-stage grasp over the laws (it picks a stage's law in one
//!   place); [`Control`]: the seam to the CAN node, with [`WithStore`] (a controller and its
//!   store as one).
#![cfg_attr(not(any(test, feature = "std")), no_std)]
#![deny(unsafe_code)]
#![warn(missing_docs)]
// Index loops over the fixed small dimensions (D, M) read like the equations they implement.
#![allow(clippy::needless_range_loop)]

#[macro_use]
mod wire;
pub mod broyden;
pub mod checkpoint;
pub mod config;
mod control;
mod controller;
mod crc;
pub mod entry;
mod error;
#[cfg(all(target_arch = "arm", target_abi = "eabihf", not(feature = "compact")))]
#[allow(unsafe_code)]
mod kernels;
pub mod law;
pub mod net;
pub mod persist;
pub mod presets;
pub mod rank;
pub mod rules;
pub mod stage;
pub mod trial;

pub use config::{Config, Law, StageConfig};
pub use control::{Control, Tables, WithStore};
pub use controller::{
    Command, Controller, Observation, ObserveKind, Outcome, Stage1, Stage2, Task, EXP_START,
    JOINTS, RANKS,
};
pub use error::{Error, Result};
pub use net::{Stage1Net, Stage2Net, Trn};
pub use stage::{FineMoves, StageOutcome, StageStep};
