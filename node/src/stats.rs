//! The controller node's counters.

use crate::health::BusCounters;

/// Counters of what the node saw.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct NodeStats {
    /// Trials started.
    pub trials: u32,
    /// Trials aborted (invalid observations, timeouts, rejected inputs, drives not normal).
    pub aborted: u32,
    /// Answers ignored because they were not the awaited one (late, duplicated, foreign).
    pub stale_answers: u32,
    /// Requests repeated after a timeout (commands, captures, the gripper's close).
    pub retries: u32,
    /// Commands repeated because a drive confirmed another value than commanded.
    pub corrected_commands: u32,
    /// Targets received again (repeats of the runner): ignored or answered from the cache.
    pub repeated_targets: u32,
    /// Messages not meant for the controller, ignored.
    pub ignored: u32,
    /// Frames dropped by the reassembler (malformed, lost or corrupt segments).
    pub frame_errors: u32,
    /// Observations with an estimated point that were used (trials that do not learn).
    pub estimated: u32,
    /// The CAN controller's state and counters, as the board reads them
    /// ([`crate::ControllerNode::bus_health`]; zero where nothing reads them).
    pub bus: BusCounters,
}
