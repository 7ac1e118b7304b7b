//! What a trial's record means: the error after each move (measured and noise-free), the
//! noise floor at the target, the pose error at the end of stage 1.

use trn_protocol::TrialReport;

use super::records::TrialRecord;
use trn_plant::nodes::Sight;
use trn_plant::targets::dist;

/// One stage of one trial, scored.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct StageScore {
    /// The controller's report (none if the trial was aborted first).
    pub report: Option<TrialReport>,
    /// Error after the coarse move and after each fine move: the measured target against
    /// the measured reading, as the paper measures (pixels).
    pub errors_px: Vec<f32>,
    /// The same from noise-free projections of target and arm (pixels).
    pub errors_true_px: Vec<f32>,
    /// What the camera noise alone gives at the target (pixels).
    pub noise_floor_px: f32,
    /// Position error of the final stage-1 pose against the target pose (mm); NaN when
    /// stage 1 did not end.
    pub pose_error_mm: f32,
    /// Orientation error of the same (degrees).
    pub pose_error_deg: f32,
    /// Simulated time of the trial's moves (s; [`TrialRecord::sim_time_s`], both stages' in
    /// a grasp).
    pub sim_time_s: f32,
}

impl StageScore {
    /// Error after the last move (NaN when there was none).
    pub fn final_px(&self) -> f32 {
        self.errors_px.last().copied().unwrap_or(f32::NAN)
    }

    /// Noise-free error after the last move.
    pub fn final_true_px(&self) -> f32 {
        self.errors_true_px.last().copied().unwrap_or(f32::NAN)
    }

    /// Error after the coarse move.
    pub fn coarse_px(&self) -> f32 {
        self.errors_px.first().copied().unwrap_or(f32::NAN)
    }

    /// Fine moves the runner saw.
    pub fn fine_moves(&self) -> usize {
        self.errors_px.len().saturating_sub(1)
    }
}

/// The measured and noise-free error of every capture `pick` accepts, in order. A capture
/// with an estimated point counts as the controller saw it (the estimate is its measured
/// reading; the noise-free error is the arm's): it is a move the controller made.
fn errors(rec: &TrialRecord, pick: impl Fn(&Sight) -> Option<(f32, f32)>) -> (Vec<f32>, Vec<f32>) {
    rec.captures.iter().filter_map(|c| pick(&c.sight)).unzip()
}

fn score(rec: &TrialRecord, stage: u8, noise_floor_px: f32) -> StageScore {
    StageScore {
        report: rec.report(stage).copied(),
        noise_floor_px,
        pose_error_mm: f32::NAN,
        pose_error_deg: f32::NAN,
        sim_time_s: rec.sim_time_s() as f32,
        ..Default::default()
    }
}

/// Stage 1 of a stage-1 trial or a grasp.
pub fn stage1(rec: &TrialRecord) -> Option<StageScore> {
    if !rec.kind.runs_stage1() {
        return None;
    }
    let t = &rec.target;
    let mut s = score(rec, 1, t.noise_v);
    (s.errors_px, s.errors_true_px) = errors(rec, |sight| match sight {
        Sight::Lights { noisy, truth } => match (noisy.reported_vector(), truth.to_vector()) {
            (Some(v), Some(vt)) => Some((dist(&v, &t.v), dist(&vt, &t.v_true))),
            _ => None,
        },
        _ => None,
    });
    let last_pose = rec
        .captures
        .iter()
        .rev()
        .find(|c| matches!(c.sight, Sight::Lights { .. }))
        .map(|c| c.pose);
    if let (Some(_), Some(pose)) = (s.report, last_pose) {
        (s.pose_error_mm, s.pose_error_deg) = pose.error_to(&t.pose);
    }
    Some(s)
}

/// Stage 2 of a stage-2 trial or a grasp.
pub fn stage2(rec: &TrialRecord) -> Option<StageScore> {
    if !rec.kind.runs_stage2() {
        return None;
    }
    let t = &rec.target;
    let mut s = score(rec, 2, t.noise_c);
    (s.errors_px, s.errors_true_px) = errors(rec, |sight| match sight {
        Sight::Centre { noisy, truth } => match (noisy.reported_vector(), truth.to_vector()) {
            (Some(x), Some(xt)) => Some((dist(&x, &t.c), dist(&xt, &t.c_true))),
            _ => None,
        },
        _ => None,
    });
    Some(s)
}

/// The combined error of both networks: the norm over the stacked 12 camera coordinates.
pub fn combined(stage1_px: f32, stage2_px: f32) -> f32 {
    (stage1_px * stage1_px + stage2_px * stage2_px).sqrt()
}
