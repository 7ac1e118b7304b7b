//! The JSON report of a run: learning curves and summaries.

use serde::{Deserialize, Serialize};

use super::scoring::combined;

/// One trial of the training curve.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct TrialPoint {
    /// Final error of the stage-1 trial (pixels, 8-D).
    pub stage1_px: f32,
    /// Final error of the stage-2 trial (pixels, 4-D).
    pub stage2_px: f32,
    /// Error after the stage-1 coarse move (pixels).
    pub stage1_coarse_px: f32,
    /// Fine moves of the stage-1 trial.
    pub stage1_fine_moves: u8,
    /// Fine moves of the stage-2 trial.
    pub stage2_fine_moves: u8,
}

/// Summary of held-out evaluation (no learning).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct EvalSummary {
    /// Held-out targets per network.
    pub targets: usize,
    /// Mean stage-1 error after the coarse move and after each fine move (pixels).
    pub stage1_error_by_move_px: Vec<f32>,
    /// Mean stage-2 error after the coarse move and after each fine move (pixels).
    pub stage2_error_by_move_px: Vec<f32>,
    /// Mean final stage-1 error, noisy target vs noisy observation (pixels).
    pub stage1_final_px: f32,
    /// Mean final stage-2 error, noisy target vs noisy observation (pixels).
    pub stage2_final_px: f32,
    /// Mean final stage-1 error from noise-free projections (pixels).
    pub stage1_final_true_px: f32,
    /// Mean final stage-2 error from noise-free projections (pixels).
    pub stage2_final_true_px: f32,
    /// Mean stage-1 fine moves.
    pub stage1_fine_moves: f32,
    /// Mean stage-2 fine moves.
    pub stage2_fine_moves: f32,
    /// Trials that ended at the cap on fine moves.
    pub cap_hits: usize,
    /// Mean position error of the gripper at the end of stage 1 against the target pose (mm).
    pub stage1_error_mm: f32,
    /// Mean orientation error at the end of stage 1 against the target pose (degrees).
    pub stage1_error_deg: f32,
}

/// Summary of full grasps.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct GraspSummary {
    /// Grasps attempted.
    pub grasps: usize,
    /// Fraction that succeeded.
    pub success_rate: f32,
    /// Mean combined error sqrt(e1^2 + e2^2), noisy (pixels).
    pub combined_error_px: f32,
    /// Mean combined error from noise-free projections (pixels).
    pub combined_error_true_px: f32,
    /// Mean distance of the gripper centre to the cylinder centre (mm).
    pub error_mm: f32,
    /// Mean deviation from perpendicular between gripper and cylinder axis (degrees).
    pub error_deg: f32,
    /// Mean fine moves per grasp (both stages).
    pub fine_moves: f32,
}

/// The report of `trn train` / `trn eval` / `trn grasp` (`--report FILE.json`).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Report {
    /// Command that produced it.
    pub command: String,
    /// Controller preset (`project` or `paper`, plus ablation).
    pub preset: String,
    /// Training trials per network.
    pub trials: usize,
    /// Seed of the run.
    pub seed: u64,
    /// Bus used (`inproc`, `socketcan:vcan0`, ...).
    pub bus: String,
    /// Final error of each stage-1 training trial (pixels).
    pub stage1_error_px: Vec<f32>,
    /// Final error of each stage-2 training trial (pixels).
    pub stage2_error_px: Vec<f32>,
    /// sqrt(stage1^2 + stage2^2) per training trial (pixels), as Fig. 8.6.
    pub combined_error_px: Vec<f32>,
    /// Stage-1 fine moves per training trial.
    pub fine_moves: Vec<u8>,
    /// Stage-2 fine moves per training trial.
    pub fine_moves_stage2: Vec<u8>,
    /// Mean combined error over the held-out grasp targets, noisy target vs noisy
    /// observation, as the paper measures (pixels).
    pub final_error_px: f32,
    /// The same from noise-free ground-truth projections (pixels).
    pub final_error_true_px: f32,
    /// What the camera noise alone gives for the same measure (pixels).
    pub noise_floor_px: f32,
    /// Mean fine moves per network trial in the held-out evaluation.
    pub fine_moves_mean: f32,
    /// Trials (training and evaluation) that ended at the cap on fine moves.
    pub correction_cap_hits: usize,
    /// Trials the controller aborted (a light out of view or hidden, a rejected input); their
    /// errors are NaN in the curves and left out of the means.
    pub aborted_trials: usize,
    /// Fraction of successful grasps.
    pub grasp_success_rate: f32,
    /// Mean gripper-to-cylinder-centre distance of the grasps (mm).
    pub error_mm: f32,
    /// Mean deviation from perpendicular of the grasps (degrees).
    pub error_deg: f32,
    /// Wall-clock duration of the run (seconds).
    pub wall_s: f64,
    /// Held-out evaluation per network.
    pub eval: EvalSummary,
    /// Grasps.
    pub grasp: GraspSummary,
}

impl Report {
    /// Appends one training trial to the curves.
    pub fn push_trial(&mut self, p: &TrialPoint) {
        self.stage1_error_px.push(p.stage1_px);
        self.stage2_error_px.push(p.stage2_px);
        self.combined_error_px
            .push(combined(p.stage1_px, p.stage2_px));
        self.fine_moves.push(p.stage1_fine_moves);
        self.fine_moves_stage2.push(p.stage2_fine_moves);
    }
}

/// Mean of the finite values of a slice (0 when there are none). Aborted trials are NaN in
/// the curves and counted in [`Report::aborted_trials`], not averaged.
pub fn mean(x: &[f32]) -> f32 {
    let (sum, n) = x
        .iter()
        .filter(|v| v.is_finite())
        .fold((0.0, 0usize), |(s, n), v| (s + v, n + 1));
    if n == 0 {
        0.0
    } else {
        sum / n as f32
    }
}

/// Moving average with a centred window of `w` trials (for plots and "by trial N" figures).
pub fn smooth(x: &[f32], w: usize) -> Vec<f32> {
    let h = w / 2;
    (0..x.len())
        .map(|i| {
            let lo = i.saturating_sub(h);
            let hi = (i + h + 1).min(x.len());
            mean(&x[lo..hi])
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn curves_and_json_round_trip() {
        let mut r = Report {
            seed: 3,
            ..Default::default()
        };
        r.push_trial(&TrialPoint {
            stage1_px: 3.0,
            stage2_px: 4.0,
            stage1_coarse_px: 9.0,
            stage1_fine_moves: 2,
            stage2_fine_moves: 1,
        });
        assert_eq!(r.combined_error_px, vec![5.0]);
        let s = serde_json::to_string(&r).unwrap();
        assert!(s.contains("\"stage1_error_px\":[3.0]"));
        let back: Report = serde_json::from_str(&s).unwrap();
        assert_eq!(back, r);
    }

    #[test]
    fn smoothing() {
        assert_eq!(smooth(&[0.0, 3.0, 6.0], 3), vec![1.5, 3.0, 4.5]);
        assert_eq!(mean(&[]), 0.0);
        assert_eq!(mean(&[1.0, f32::NAN, 3.0]), 2.0);
    }
}
