//! The conformance suite as a session runs it: the engine opens the bus, probes the
//! controller and clears its tables, then hands its runner to a [`Suite`] (the
//! `trn-conformance` crate's, above this one) and keeps the checks it returns in the report.

use std::time::Duration;

use embedded_can::blocking::Can;
use trn_protocol::bus::ReceiveTimeout;
use trn_protocol::{CanFrame, SessionConfig};

use crate::error::{LabError, Result};
use crate::report::Check;
use crate::runner::Runner;
use crate::tables::Spoken;

/// How long to wait: for an answer that must come, and for quiet after an answer (to see
/// that nothing else follows).
#[derive(Debug, Clone, Copy)]
pub struct Patience {
    /// The longest a sequence may take.
    pub answer: Duration,
    /// How long nothing more may happen after a refusal or a repeat's answer.
    pub quiet: Duration,
    /// A controller heard within this is alive (its heartbeats come every 100 ms of its
    /// clock): the heartbeat supervision's timeout.
    pub alive: Duration,
}

/// A conformance suite: drives the controller on `runner`'s bus, `session` the
/// configuration it sends first, and returns its checks.
pub trait Suite {
    /// Runs the suite.
    fn run<P>(
        &self,
        runner: &mut Runner<P>,
        session: SessionConfig,
        patience: Patience,
        spoken: Spoken,
    ) -> Result<Vec<Check>>
    where
        P: Can<Frame = CanFrame, Error = trn_protocol::Error> + ReceiveTimeout;
}

/// No suite: a run of the conformance command is refused (the engine alone,
/// [`crate::run::run`]).
#[derive(Debug, Clone, Copy, Default)]
pub struct NoSuite;

/// Why the engine alone does not run the conformance suite.
pub(crate) fn no_suite() -> LabError {
    LabError::Usage(
        "the conformance suite is not part of the run engine: run it with trn_conformance::run_spec (`trn conformance`)".into(),
    )
}

impl Suite for NoSuite {
    fn run<P>(
        &self,
        _: &mut Runner<P>,
        _: SessionConfig,
        _: Patience,
        _: Spoken,
    ) -> Result<Vec<Check>>
    where
        P: Can<Frame = CanFrame, Error = trn_protocol::Error> + ReceiveTimeout,
    {
        Err(no_suite())
    }
}
