//! The session and its health: modes, heartbeats, errors, emergencies.

use postcard::experimental::max_size::MaxSize;
use serde::{Deserialize, Serialize};

/// Operating state announced in heartbeats.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, MaxSize)]
pub enum NodeState {
    /// Starting up, not yet operational.
    Booting,
    /// Operating normally.
    Operational,
    /// In its safe state.
    SafeState,
    /// Faulted.
    Fault,
}

/// Operating mode of the experiment.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, MaxSize)]
pub enum Mode {
    /// No trials running.
    Idle,
    /// Supervised priming trials.
    Priming,
    /// Unsupervised training trials.
    Training,
    /// Mature network: no learning.
    Mature,
}

/// Why an emergency was raised.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, MaxSize)]
pub enum EmergencyReason {
    /// Operator pressed stop.
    Operator,
    /// A node lost the controller heartbeat.
    HeartbeatLost,
    /// Pressure or actuator fault.
    PressureFault,
    /// The controller itself faulted.
    ControllerFault,
    /// Bus errors (bus-off, persistent protocol errors).
    BusFault,
}

/// Heartbeat, sent by every node every 100 ms.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, MaxSize)]
pub struct Heartbeat {
    /// Wrapping counter, +1 per heartbeat.
    pub counter: u8,
    /// The sender's state.
    pub state: NodeState,
}

/// Change the operating mode.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, MaxSize)]
pub struct ModeChange {
    /// The new mode.
    pub mode: Mode,
}

/// An error report (codes are node specific, see SPEC.md).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, MaxSize)]
pub struct ErrorReport {
    /// Error code.
    #[serde(with = "postcard::fixint::le")]
    pub code: u16,
    /// Code-specific detail.
    #[serde(with = "postcard::fixint::le")]
    pub detail: u32,
}

/// Emergency stop: every servo drive vents, the controller stops the trial.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, MaxSize)]
pub struct Emergency {
    /// Why.
    pub reason: EmergencyReason,
}
