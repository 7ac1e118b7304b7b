//! `trn-bench`: the run engine: one run of a controller on the simulated SoftArm, a
//! [`RunSpec`] in and a [`Report`] out, as a library (the command line, the studies
//! (`trn-studies`), the conformance suite (`trn-conformance`) and the tests call it; it has
//! no command line of its own, prints nothing and reads no signal).
//!
//! - A run is described by one [`RunSpec`] ([`spec`]) and run by [`run::run`]: it opens the
//!   bus the specification names ([`trn_transport`]), with the controller on it, and drives
//!   the trials against the simulated rig.
//! - One trial: [`runner`] sets up the plant ([`targets`]) and sends the target; [`rig`]
//!   serves the bus with the plant's nodes ([`trn_plant::nodes`]) until the controller
//!   reports; the trial's [`records::TrialRecord`] goes into the run's log, which [`scoring`]
//!   and [`metrics`] turn into the [`report::Report`]. [`schedule`] orders the trials.
//! - Time: in process everything runs on one simulated clock ([`trn_transport::SimClock`]);
//!   on a real bus on the wall clock. The rig and the runner read it through the rig.
//! - The conformance command: a session hands its runner to the [`suite::Suite`] the run
//!   was given ([`run::run_with`]; `trn-conformance` has the suite); [`journal`] reads a
//!   controller's messages back.
//! - Files: every output follows one rule ([`output`]; the rule itself, a leaf below every
//!   writer: [`fsio`]); checkpoints ([`checkpoint_file`]) and the simulator's state beside
//!   them ([`sim_state`], with the curve a continued run takes over: [`history`]).
//! - Figures as text ([`format`](mod@format): the studies' tables, the lines of the summary the command
//!   line prints).
//! - The controller's learned tables: [`trn_transport::board`] boots the host's controller with its store
//!   (in memory or a tables file); [`tables`] reads them out over the bus, writes a
//!   checkpoint in, and begins a session on a controller that may hold learned tables.

pub mod checkpoint_file;
mod error;
pub mod format;
pub mod fsio;
pub mod history;
pub mod journal;
pub mod metrics;
pub mod observe;
pub mod output;
pub mod patience;
pub mod ports;
pub mod provenance;
pub mod records;
pub mod report;
pub mod rig;
pub mod run;
pub mod runner;
pub mod schedule;
pub mod scoring;
pub mod seeds;
mod session;
pub mod sim_state;
pub mod spec;
pub mod suite;
pub mod tables;
pub mod trial_csv;

/// The helpers of the printed summary under the names they had when the lab printed it
/// (the summary is the command line's now): [`format::px`], [`format::protocol_line`],
/// [`report::trials_to_reach`].
pub mod summary {
    pub use crate::format::{protocol_line, px};
    pub use crate::report::trials_to_reach;
}

pub use error::{io, LabError, Result};
pub use observe::{Observer, Unobserved};
pub use provenance::Provenance;
pub use report::Report;
pub use seeds::Seeds;
pub use spec::{BusChoice, Command, ControllerChoice, Outputs, Profile, RunConfig, RunSpec};
/// Where targets come from: the plant's ([`trn_plant::targets`]), here under the path it had.
pub use trn_plant::targets;
