//! `trn-sim`: the command line of the project, over the libraries: `trn` (train, evaluate,
//! compare, sweep, lifelong, study, merge, conformance), `controller-node` (the controller
//! as a process on SocketCAN), `sim-pictures`; options ([`cli`]) turned into the lab's
//! specifications ([`args`]), the progress bar and interrupts of a run ([`progress`]) and of
//! a study ([`studies`]), the summary printed after a run ([`summary`]), plots ([`plot`],
//! [`picture`]).
//!
//! The layers below, each usable alone: `trn-plant` (the simulated arm and its CAN nodes),
//! `trn-transport` (the buses and where the controller runs), `trn-bench` (runs, studies,
//! reports).

pub mod args;
pub mod cli;
pub mod decode;
mod error;
pub mod live;
#[cfg(feature = "plot")]
pub mod picture;
#[cfg(feature = "plot")]
pub mod plot;
pub mod progress;
pub mod studies;
pub mod summary;

pub use error::{CliError, Result};
