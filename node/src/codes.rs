//! The controller node's `ErrorReport` codes (protocol/SPEC.md, section 7) and the stable
//! numbers of the controller's errors.

use trn_controller::Error as CtrlError;

/// A trial ended without a result; detail = trial. Always preceded by the reason.
pub const TRIAL_ABORTED: u16 = 0x0100;
/// An observation had an invalid point (an estimated one in a trial that learns);
/// detail = `point index << 8 | PointStatus as u8`. The trial is aborted.
pub const INVALID_OBSERVATION: u16 = 0x0101;
/// No observation arrived after the capture request and its retries; detail = the
/// request's sequence number. The trial is aborted.
pub const OBSERVATION_TIMEOUT: u16 = 0x0102;
/// The controller rejected an input; detail = the controller error's code (see
/// [`controller_error_code`]). The trial (if any) is aborted.
pub const CONTROLLER_ERROR: u16 = 0x0103;
/// A grasp target arrived without its `GraspRequest` or first half; detail = trial.
/// Nothing starts.
pub const OUT_OF_ORDER: u16 = 0x0104;
/// The outbox overflowed (a bug): detail = messages dropped.
pub const OUTBOX_FULL: u16 = 0x0105;
/// A servo drive is not in its normal state (it holds or vents after losing the heartbeat):
/// the move did not happen as commanded, nothing is learned from it; detail = `joint << 8 |
/// SafeState as u8`. The trial is aborted.
pub const SERVO_NOT_NORMAL: u16 = 0x0106;
/// A servo drive did not confirm a command after its retries; detail = `joint << 16 | seq`.
/// The trial is aborted.
pub const SERVO_TIMEOUT: u16 = 0x0107;
/// The gripper did not confirm a command after its retries; detail = trial.
pub const GRIPPER_TIMEOUT: u16 = 0x0108;

/// In `Priming` mode a stage-1 target came without its `SupervisedPressure` (lost or late):
/// nothing starts, the runner repeats both; detail = trial.
pub const MISSING_SUPERVISION: u16 = 0x0109;

/// A `SessionConfig` was refused; nothing changed (the previous configuration and tables stay);
/// detail = one of the `CONFIG_*` reasons below.
pub const CONFIG_REJECTED: u16 = 0x010A;
/// `CONFIG_REJECTED` detail: not in `Idle`, or a trial is in progress.
pub const CONFIG_NOT_IDLE: u32 = 1;
/// `CONFIG_REJECTED` detail: `keep_tables`, but the controller's tables were learned under
/// another configuration.
pub const CONFIG_MISMATCH: u32 = 2;
/// `CONFIG_REJECTED` detail: the controller refused the configuration (`set_config`).
pub const CONFIG_INVALID: u32 = 3;
/// `CONFIG_REJECTED` detail: the configuration is valid but this controller does not run it
/// (a control law it does not implement: the project's controller and the firmware run the
/// TRN and the Broyden servo, not the host's model-based reference).
pub const CONFIG_UNSUPPORTED: u32 = 4;

/// A destructive operation was refused by the guard of the learned tables; nothing changed.
/// detail = `op << 8 | reason`: op 1 re-seed (a `SessionConfig` with `keep_tables = false` on
/// tables that learned), 2 table write, 3 erase of the stored copy; reason
/// ([`crate::Refusal`]) 1 no nonce, 2 stale, 3 used (a replay), 4 wrong, 5 the node cannot
/// issue nonces. After a refused `SessionConfig` the node refuses trials until a session is
/// accepted ([`SESSION_REQUIRED`]).
pub const GUARD_REFUSED: u16 = 0x010B;

/// A trial's target was refused because the node holds tables that learned and no session is
/// in force (at boot with restored tables, after `ModeChange{Idle}`, after a refused
/// `SessionConfig`, after tables were written in): nothing starts; detail = trial.
pub const SESSION_REQUIRED: u16 = 0x010C;

/// An operation on the tables or their stored copy failed or was refused; nothing was
/// applied. detail = `op << 8 | reason`, with a flash error code (1 not aligned, 2 out of
/// bounds, 3 other, 0xFE read back differs) or a checkpoint error in bits 16..24.
pub const TABLES_FAILED: u16 = 0x010D;

/// The node's CAN controller changed state, or lost received frames (sent with
/// [`BUS_COUNTS`], at most once a second, never while bus-off; `crate::BusCounters`):
/// detail = `state << 16 | TEC << 8 | REC`, state 0 error-active, 1 error-warning,
/// 2 error-passive (`crate::BusState`; never 3, bus-off: the report waits until the node is
/// back on the bus). A status report: nothing stops.
pub const BUS_STATE: u16 = 0x010E;
/// The CAN controller's counters, right after [`BUS_STATE`]: detail = `bus-offs << 16 |
/// receive overruns`, each saturating at 0xFFFF.
pub const BUS_COUNTS: u16 = 0x010F;

/// Sent once at boot by a board: why the part last reset (`crate::reset`); detail =
/// `cause << 24 | detail`: cause 0 unknown, 1 power-on or brown-out, 2 reset pin, 3
/// watchdog, 4 panic (detail: its source line), 5 hard fault (detail: the low 24 bits of the
/// faulting instruction's address), 6 another software reset. A status report.
pub const RESET_CAUSE: u16 = 0x0110;

/// `TABLES_FAILED` operations (bits 8..16 of the detail).
pub mod table_op {
    /// Reading a chunk out (`TableReadRequest`).
    pub const READ: u32 = 1;
    /// Starting a write (`TableWriteBegin`).
    pub const WRITE_BEGIN: u32 = 2;
    /// A chunk written in (`TableWriteChunk`).
    pub const WRITE_CHUNK: u32 = 3;
    /// Verifying and applying the image (`TableWriteEnd`).
    pub const APPLY: u32 = 4;
    /// Saving to the stored copy.
    pub const SAVE: u32 = 5;
    /// Erasing the stored copies.
    pub const ERASE: u32 = 6;
}

/// `TABLES_FAILED` reasons (bits 0..8 of the detail).
pub mod table_reason {
    /// The controller holds no TRN tables (a law without them).
    pub const NO_TABLES: u32 = 1;
    /// The node has no store (nothing to save to, no staging area for a write).
    pub const NO_STORE: u32 = 2;
    /// Not now: a write outside `Idle` or while a trial runs; a read while a trial runs.
    pub const BUSY: u32 = 3;
    /// Beyond the image (a chunk index), or an image longer than any checkpoint.
    pub const OUT_OF_RANGE: u32 = 4;
    /// No write in progress (an end without its begin).
    pub const NOT_STARTED: u32 = 5;
    /// The end of a write before every chunk came.
    pub const INCOMPLETE: u32 = 6;
    /// The image's CRC is not the one announced.
    pub const CRC_MISMATCH: u32 = 7;
    /// The image's configuration fingerprint is not the one announced.
    pub const FINGERPRINT_MISMATCH: u32 = 8;
    /// The image is not a checkpoint this build restores (bits 16..24: which refusal, the
    /// low byte of its [`super::controller_error_code`] `0xB00..=0xB06`: 0 length, 1 magic,
    /// 2 version, 3 shape, 4 CRC, 5 contents, 6 changed; 0xFF another error).
    pub const IMAGE: u32 = 9;
    /// The flash refused an operation (bits 16..24: its code).
    pub const FLASH: u32 = 10;
    /// The tables changed while they were saved (the save starts again after the trial).
    pub const CHANGED: u32 = 11;
}

/// True for the codes the node sends as the reason of an abort, right before
/// `TRIAL_ABORTED`; refusals that start nothing (`OUT_OF_ORDER`, `MISSING_SUPERVISION`,
/// `CONFIG_REJECTED`), `GRIPPER_TIMEOUT` and `TRIAL_ABORTED` itself are not.
pub fn aborts_trial(code: u16) -> bool {
    matches!(
        code,
        INVALID_OBSERVATION
            | OBSERVATION_TIMEOUT
            | CONTROLLER_ERROR
            | SERVO_NOT_NORMAL
            | SERVO_TIMEOUT
    )
}

/// A stable numeric code for each controller error (sent in `ErrorReport.detail`).
pub fn controller_error_code(e: &CtrlError) -> u32 {
    match e {
        CtrlError::NonFiniteInput { index } => 0x100 | *index as u32,
        CtrlError::InputOutOfRange { index, .. } => 0x200 | *index as u32,
        CtrlError::InvalidPressure { index } => 0x300 | *index as u32,
        CtrlError::ZeroLengthDv => 0x400,
        CtrlError::UnexpectedObservation => 0x500,
        CtrlError::WrongObservationKind => 0x600,
        CtrlError::Busy => 0x700,
        CtrlError::TargetOutsideLearnedRegion { .. } => 0x800,
        CtrlError::FineMoveBudget => 0x900,
        CtrlError::UnsupportedLaw => 0xA00,
        CtrlError::CheckpointLength { .. } => 0xB00,
        CtrlError::CheckpointMagic => 0xB01,
        CtrlError::CheckpointVersion { .. } => 0xB02,
        CtrlError::CheckpointShape => 0xB03,
        CtrlError::CheckpointCrc { .. } => 0xB04,
        CtrlError::CheckpointContents => 0xB05,
        CtrlError::CheckpointChanged => 0xB06,
        _ => 0xF00,
    }
}
