//! The training curve and the frozen snapshots of a run: what a continued run takes over
//! from the run it continues (in the simulator's state, [`crate::sim_state`]) and what the
//! report shows of it ([`crate::report`]). Plain data, below both.

use serde::{Deserialize, Serialize};

/// The training curve and snapshots of a run: what a continued run takes over from the
/// run it continues.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct History {
    /// Final error of each stage-1 training trial (pixels).
    pub stage1_error_px: Vec<f32>,
    /// Final error of each stage-2 training trial (pixels).
    pub stage2_error_px: Vec<f32>,
    /// Stage-1 fine moves per training trial.
    pub fine_moves: Vec<u8>,
    /// Stage-2 fine moves per training trial.
    pub fine_moves_stage2: Vec<u8>,
    /// The frozen snapshots.
    pub learning_curve: Vec<SnapshotPoint>,
}

/// One frozen snapshot of the learning curve.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct SnapshotPoint {
    /// Training trials per network before the snapshot.
    pub trial: usize,
    /// Mean noise-free stage-1 error after each move (0 = coarse).
    pub stage1_true_px: Vec<f32>,
    /// The same for stage 2.
    pub stage2_true_px: Vec<f32>,
    /// The same combined.
    pub combined_true_px: Vec<f32>,
    /// Mean measured combined error after each move.
    #[serde(default)]
    pub combined_measured_px: Vec<f32>,
    /// The camera-noise floor of the measured combined error.
    #[serde(default)]
    pub noise_floor_px: f32,
    /// Trials of the snapshot that failed.
    pub failed_trials: usize,
    /// Grasps in the snapshot (0: none).
    #[serde(default)]
    pub grasps: usize,
    /// Of those, grasps whose cylinder the twin arm (in the arm's present state of drift and
    /// wear) can no longer hold or see: not targets, left out of the success rate.
    #[serde(default)]
    pub grasps_unreachable: usize,
    /// Fraction of the other grasps that succeeded (NaN: none).
    #[serde(default)]
    pub grasp_success: f32,
    /// Failed grasps by cause (as [`crate::report::GraspSummary::failure_causes`]).
    #[serde(default)]
    pub grasp_failures: std::collections::BTreeMap<String, usize>,
}
