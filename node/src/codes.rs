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
        _ => 0xF00,
    }
}
