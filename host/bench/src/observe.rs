//! What a run tells whoever watches it while it goes on ([`Observer`]): the command line's
//! progress bar, a live view, a test. The lab itself prints nothing and reads no signal: an
//! observer that answers `stop_requested` ends the run at the next trial boundary.

use crate::records::TrialRecord;
use crate::report::Report;

/// Watches a run. Every method has a default that does nothing.
pub trait Observer {
    /// The run starts; it will have about `trials` trials on the bus.
    fn start(&mut self, _trials: u64) {}
    /// A part of the run begins (`training`, `snapshot`, `eval`, `grasp`).
    fn phase(&mut self, _name: &str) {}
    /// A trial ended (its record as the runner saw it).
    fn trial(&mut self, _record: &TrialRecord) {}
    /// A line worth showing beside the progress (the recent training error).
    fn message(&mut self, _text: &str) {}
    /// Something the user must see whatever the progress shows: what the run is about to
    /// erase or replace on the controller, what it found there.
    fn notice(&mut self, _text: &str) {}
    /// The run ended (well or not).
    fn finish(&mut self) {}
    /// The run is over and `report` is whole: called once, before the run's files (the
    /// report, the CSV) are written, so that what the observer shows of it (the command
    /// line's summary) is not lost when a write then fails (a full disk). Not called for a
    /// run that failed.
    fn ran(&mut self, _report: &Report) {}
    /// True when the run should stop at the next trial boundary (an interrupt): it then
    /// ends as an interrupted run, with what it did so far.
    fn stop_requested(&self) -> bool {
        false
    }
}

/// An observer that watches nothing.
#[derive(Debug, Clone, Copy, Default)]
pub struct Unobserved;

impl Observer for Unobserved {}
