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
    #[serde(with = "super::fixint")]
    pub code: u16,
    /// Code-specific detail.
    #[serde(with = "super::fixint")]
    pub detail: u32,
}

/// Emergency stop: every servo drive vents, the controller stops the trial.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, MaxSize)]
pub struct Emergency {
    /// Why.
    pub reason: EmergencyReason,
}

/// Number of controller presets on the wire (`SessionConfig::preset` is below it).
pub const PRESET_CODES: u8 = 3;
/// Number of ablations on the wire (`SessionConfig::ablation` is below it).
pub const ABLATION_CODES: u8 = 5;
/// Number of control laws on the wire (`SessionConfig::law` is below it).
pub const LAW_CODES: u8 = 4;
/// Largest image side a session may announce, in pixels.
pub const IMAGE_SIDE_MAX: u16 = 8192;

/// The run parameters of a session, sent by the runner to the controller before its first
/// `ModeChange` and echoed by the controller to `Broadcast` once in force (see SPEC.md 3.2).
/// A controller that is given its configuration some other way may check it against this.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, MaxSize)]
pub struct SessionConfig {
    /// Seed of the initial tables.
    #[serde(with = "super::fixint")]
    pub seed: u64,
    /// Controller preset: 0 project, 1 paper, 2 lifelong (`trn_controller::presets::Preset`).
    pub preset: u8,
    /// Ablation: 0 none, 1 no neighbourhood, 2 no priming, 3 no fine moves, 4 no secant
    /// correction within a trial.
    pub ablation: u8,
    /// Camera image width, pixels (the span of the initial stage-1/2 weights).
    #[serde(with = "super::fixint")]
    pub image_width: u16,
    /// Camera image height, pixels.
    #[serde(with = "super::fixint")]
    pub image_height: u16,
    /// Long messages as CAN FD frames (true) or segmented CAN 2.0 frames (false) from now on.
    pub fd: bool,
    /// Keep the tables the controller holds (loaded from a checkpoint) instead of seeding new
    /// ones; the controller's configuration must then already be the one described here.
    pub keep_tables: bool,
    /// Control law: 0 the TRN, 1 the Broyden servo baseline, 2 a model-based reference
    /// controller outside the controller crate (`trn_controller::Law`).
    pub law: u8,
}
