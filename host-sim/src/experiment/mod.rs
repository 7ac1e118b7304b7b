//! The experiment: the runner that drives trials over the bus against the simulated rig,
//! scoring, reports, plots and the `trn` command line.
//!
//! One trial: [`runner`] sets up the plant ([`targets`]) and sends the target; [`rig`] serves
//! the bus with the plant's nodes ([`crate::nodes`]) until the controller reports; the
//! trial's [`records::TrialRecord`] goes into the run's log, which [`scoring`] and
//! [`metrics`] turn into the [`report::Report`]. [`schedule`] orders the trials; [`run`]
//! opens the bus ([`crate::transport`]) and ties it together.

pub mod checkpoint_file;
pub mod cli;
pub mod compare;
pub mod conformance;
pub mod lifelong;
pub mod metrics;
#[cfg(feature = "plot")]
pub mod plot;
pub mod records;
pub mod report;
pub mod rig;
pub mod run;
pub mod runner;
pub mod schedule;
pub mod scoring;
pub mod sim_state;
pub mod summary;
pub mod sweep;
pub mod targets;

pub use report::Report;
