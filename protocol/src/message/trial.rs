//! Trials: targets, supervised pressures, grasps, reports, the gripper.

use postcard::experimental::max_size::MaxSize;
use serde::{Deserialize, Serialize};

/// `fine_moves` of a target: the controller's own rule decides (stop within its tolerance,
/// or at its cap on fine moves).
pub const FINE_MOVES_POLICY: u8 = 0xFF;

/// Largest fixed budget of fine moves a target may ask for.
pub const FINE_MOVES_MAX: u8 = 31;

/// Stage-1 target for a trial (runner -> controller). With `grasp`, `v` are the target
/// lights p, q for the grasp approach.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, MaxSize)]
pub struct Stage1Target {
    /// Trial number.
    #[serde(with = "super::fixint")]
    pub trial: u32,
    /// Learning enabled for this trial.
    pub learn: bool,
    /// Part of a grasp trial (after a [`GraspRequest`]).
    pub grasp: bool,
    /// Fine moves: exactly this many after the coarse move (0..=[`FINE_MOVES_MAX`], never
    /// stopping early: the evaluation's fixed move budget), or [`FINE_MOVES_POLICY`].
    pub fine_moves: u8,
    /// 8-D target `[p0x, p0y, p1x, p1y, q0x, q0y, q1x, q1y]`, pixels.
    pub v: [f32; 8],
}

/// Stage-2 target for a trial (runner -> controller). With `grasp`, `c` is the
/// cylinder centre in both cameras.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, MaxSize)]
pub struct Stage2Target {
    /// Trial number.
    #[serde(with = "super::fixint")]
    pub trial: u32,
    /// Learning enabled for this trial.
    pub learn: bool,
    /// Part of a grasp trial.
    pub grasp: bool,
    /// Fine moves: exactly this many after the coarse move (0..=[`FINE_MOVES_MAX`], never
    /// stopping early: the evaluation's fixed move budget), or [`FINE_MOVES_POLICY`].
    pub fine_moves: u8,
    /// 4-D target `[g0x, g0y, g1x, g1y]`, pixels.
    pub c: [f32; 4],
}

/// Supervised pressures for a priming trial (runner -> controller); precedes the
/// [`Stage1Target`] of the same trial.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, MaxSize)]
pub struct SupervisedPressure {
    /// Trial number.
    #[serde(with = "super::fixint")]
    pub trial: u32,
    /// Normalised pressure difference per joint, each in [-1, 1].
    pub p: [f32; 5],
}

/// Start a grasp trial (runner -> controller); followed by a `Stage1Target` and a
/// `Stage2Target` of the same trial, both with `grasp = true`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, MaxSize)]
pub struct GraspRequest {
    /// Trial number.
    #[serde(with = "super::fixint")]
    pub trial: u32,
}

/// Result of a trial (controller -> runner; node = controller, the source).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, MaxSize)]
pub struct TrialReport {
    /// Trial number.
    #[serde(with = "super::fixint")]
    pub trial: u32,
    /// Last stage reached: 0 = supervised priming, 1 = stage 1, 2 = stage 2.
    pub stage: u8,
    /// Error after the coarse move, pixels (≥ 0).
    pub coarse_error_px: f32,
    /// Error at the end of the trial, pixels (≥ 0).
    pub final_error_px: f32,
    /// Number of fine moves made.
    pub fine_moves: u8,
    /// The fine-move cap was hit.
    pub cap_hit: bool,
}

/// Open or close the gripper.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, MaxSize)]
pub struct GripperCommand {
    /// `true` closes, `false` opens.
    pub close: bool,
}

/// Gripper state.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, MaxSize)]
pub struct GripperStatus {
    /// The gripper is closed.
    pub closed: bool,
}
