//! The JSON report of a run: learning curves and summaries.

use serde::{Deserialize, Serialize};

pub use crate::history::{History, SnapshotPoint};
use crate::scoring::combined;

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
    /// Every failed grasp by cause: the reason of a failed trial (a lost light, ...), or for
    /// a grasp that closed off the mark, the first of: stage-1 error (above 3 px), stage-2
    /// error (above 2 px), orientation (beyond the angle limit), placement (both networks on
    /// target in the images but the gripper off the cylinder).
    pub failure_causes: std::collections::BTreeMap<String, usize>,
}

/// The held-out evaluation with the fixed move budget: deployment-style targets, the coarse
/// move plus exactly `fine_moves` fine moves, no early stop. Entry `m` of each list is the
/// mean error after move `m` (0 = coarse). Means over no valid trial are `null`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Deployment {
    /// Held-out targets per network.
    pub targets: usize,
    /// Fine moves after the coarse move.
    pub fine_moves: u8,
    /// Mean noise-free error of stage 1 after each move (pixels).
    pub stage1_true_px: Vec<f32>,
    /// The same for stage 2.
    pub stage2_true_px: Vec<f32>,
    /// Mean of sqrt(e1^2 + e2^2) per target, noise-free.
    pub combined_true_px: Vec<f32>,
    /// Mean measured error of stage 1 after each move (noisy target vs noisy reading).
    pub stage1_measured_px: Vec<f32>,
    /// The same for stage 2.
    pub stage2_measured_px: Vec<f32>,
    /// The same combined.
    pub combined_measured_px: Vec<f32>,
    /// The tails of the combined noise-free error after each move, over the targets: the
    /// median, the 90th and 95th percentiles and the largest (nearest rank).
    #[serde(default)]
    pub combined_true_p50_px: Vec<f32>,
    /// 90th percentile.
    #[serde(default)]
    pub combined_true_p90_px: Vec<f32>,
    /// 95th percentile.
    #[serde(default)]
    pub combined_true_p95_px: Vec<f32>,
    /// The largest.
    #[serde(default)]
    pub combined_true_max_px: Vec<f32>,
    /// The same tails of the combined measured error.
    #[serde(default)]
    pub combined_measured_p50_px: Vec<f32>,
    /// 90th percentile.
    #[serde(default)]
    pub combined_measured_p90_px: Vec<f32>,
    /// 95th percentile.
    #[serde(default)]
    pub combined_measured_p95_px: Vec<f32>,
    /// The largest.
    #[serde(default)]
    pub combined_measured_max_px: Vec<f32>,
    /// The floor of the combined measured error: what the camera noise alone gives at the
    /// target (a second reading against the first).
    pub noise_floor_px: f32,
    /// Mean fine moves until the noise-free error is within 2 px (0: the coarse move), over
    /// the trials of both networks; a trial that never gets there counts as `fine_moves + 1`.
    pub moves_to_2px_mean: f32,
    /// Trials that never got within 2 px within the budget.
    pub moves_to_2px_not_reached: usize,
    /// Trials of this evaluation that failed (aborted, target not seen, fewer moves).
    pub failed_trials: usize,
    /// The combined measured error after the last move of the budget, per held-out target
    /// whose trials both succeeded, in the held-out set's order: the distribution behind
    /// the mean (its tail: percentiles over targets and seeds in `trn compare`).
    #[serde(default)]
    pub combined_measured_by_target_px: Vec<f32>,
}

/// A trial that failed, and why.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct FailedTrial {
    /// Trial number on the bus.
    pub trial: u32,
    /// The part of the run.
    pub phase: String,
    /// Why, with what is particular to this trial.
    pub reason: String,
    /// The kind of failure (what counts together in tables).
    #[serde(default)]
    pub cause: String,
}

/// The paper's visit-then-return protocol, kept as a secondary evaluation.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct VisitAndReturn {
    /// Targets per network.
    pub targets: usize,
    /// Mean combined final error, measured.
    pub combined_measured_px: f32,
    /// Mean combined final error, noise-free.
    pub combined_true_px: f32,
    /// Mean fine moves per network trial.
    pub fine_moves: f32,
}

/// What the bus and both sides did about faults: the injector's counts (in-process bus with
/// `--faults`), the runner's repeats and give-ups, the controller node's repeats.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct BusReport {
    /// The `--faults` argument, if any.
    pub faults: Option<String>,
    /// Frames sent, delivered, dropped, duplicated, corrupted, truncated, delayed.
    pub injected: Option<std::collections::BTreeMap<String, u64>>,
    /// The runner: trial starts and mode changes sent again, trials given up.
    pub runner: RunnerStats,
    /// The controller node (in-process only): requests repeated, commands corrected after a
    /// drive confirmed another value, repeated targets, stale answers, dropped frames,
    /// aborted trials.
    pub controller: Option<std::collections::BTreeMap<String, u32>>,
}

/// Counters of the runner ([`crate::runner::Runner::stats`]).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct RunnerStats {
    /// Trial starts sent again after no answer.
    pub target_repeats: u32,
    /// Mode changes and session configurations sent again after no acknowledgement.
    pub mode_repeats: u32,
    /// Trials given up after every repeat.
    pub given_up: u32,
    /// Requests about the tables (their status, a nonce, a chunk) sent again after no
    /// answer.
    #[serde(default)]
    pub table_repeats: u32,
}

/// One check of the conformance suite (`trn-conformance`, run through [`crate::suite`]) and its verdict.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Check {
    /// What the specification requires.
    pub name: String,
    /// Whether the controller did it (a check not applicable counts as passed).
    pub passed: bool,
    /// What was seen when it did not; why it was not applicable.
    pub detail: String,
    /// Not applicable to this controller: a choice the specification leaves it made the
    /// check impossible (it ended its loop at `Idle`; its tables never learn).
    #[serde(default)]
    pub skipped: bool,
}

/// The report of `trn train` / `trn eval` / `trn grasp` (`--report FILE.json`).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
pub struct Report {
    /// Command that produced it.
    pub command: String,
    /// The controller's preset (`project`, `paper`, `lifelong`), whatever the law.
    pub preset: String,
    /// The ablation (`none`, ...).
    #[serde(default)]
    pub ablation: String,
    /// The control law (`trn`, `broyden`, `model`).
    #[serde(default)]
    pub law: String,
    /// The run stopped early at an interrupt: what is here is what it did.
    #[serde(default)]
    pub interrupted: bool,
    /// Training trials per network the networks have learned in all (a continued run
    /// counts the trials of the runs before it).
    pub trials: usize,
    /// Training trials per network of this run alone.
    #[serde(default)]
    pub trials_this_run: usize,
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
    /// Mean simulated time per held-out target in the same evaluation: both networks'
    /// trials, every move's pressure ramp, settle and capture (s).
    pub sim_time_per_target_s: f32,
    /// Trials (training and evaluation) that ended at the cap on fine moves.
    pub correction_cap_hits: usize,
    /// Trials the controller aborted (a light out of view or hidden, a rejected input); their
    /// errors are NaN in the curves, left out of the means and listed in `failures`.
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
    /// The held-out evaluation with the fixed move budget.
    pub deployment: Deployment,
    /// Frozen snapshots during training (the fixed move budget on the held-out targets).
    pub learning_curve: Vec<SnapshotPoint>,
    /// The paper's protocol, secondary.
    pub visit_and_return: VisitAndReturn,
    /// Trials that failed in the whole run.
    pub failed_trials: usize,
    /// Each failed trial with its reason.
    pub failures: Vec<FailedTrial>,
    /// Trials of the held-out evaluations and grasps (for the share that failed).
    pub evaluation_trials: usize,
    /// Retries, timeouts and give-ups on both sides, and the injected faults.
    pub bus_stats: BusReport,
    /// What produced the report: the version, the git commit (and whether the sources
    /// differed from it), the command line.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub provenance: Option<crate::provenance::Provenance>,
    /// The whole specification of the run, the plant's full configuration included.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub spec: Option<crate::spec::RunSpec>,
    /// The conformance suite's checks (`trn conformance`).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub conformance: Vec<Check>,
    /// The protocol version the controller speaks (3 or 4, SPEC.md "Versions"): a version-3
    /// controller's tables are neither read, saved nor checked. None when no session was
    /// opened over the bus (a tuning configuration given to the controller directly).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub controller_protocol: Option<u8>,
}

impl Report {
    /// An empty report of a run of `spec`.
    pub fn of(spec: &crate::spec::RunSpec) -> Report {
        Report {
            command: spec.command.name().to_string(),
            preset: spec.profile.preset.name().to_string(),
            ablation: spec.profile.ablation.name().to_string(),
            law: spec.profile.law.name().to_string(),
            trials: spec.plan.trials,
            trials_this_run: spec.plan.trials,
            seed: spec.seed,
            bus: spec.bus.spec.to_string(),
            provenance: Some(crate::provenance::Provenance::current()),
            spec: Some(spec.clone()),
            ..Default::default()
        }
    }

    /// The label of the run's controller in tables: the law when it is not the TRN, else
    /// the preset and the ablation.
    pub fn label(&self) -> String {
        match (self.law.as_str(), self.ablation.as_str()) {
            ("trn" | "", "none" | "") => self.preset.clone(),
            ("trn" | "", a) => format!("{}+{}", self.preset, a.replace('-', "")),
            (law, _) => law.to_string(),
        }
    }

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

impl Report {
    /// Its training curve and snapshots.
    pub fn history(&self) -> History {
        History {
            stage1_error_px: self.stage1_error_px.clone(),
            stage2_error_px: self.stage2_error_px.clone(),
            fine_moves: self.fine_moves.clone(),
            fine_moves_stage2: self.fine_moves_stage2.clone(),
            learning_curve: self.learning_curve.clone(),
        }
    }

    /// Puts `earlier` (the run this one continues) before this run's curve and snapshots.
    pub fn continue_from(&mut self, earlier: &History) {
        fn before<T: Clone>(earlier: &[T], now: &mut Vec<T>) {
            let mut all = earlier.to_vec();
            all.append(now);
            *now = all;
        }
        before(&earlier.stage1_error_px, &mut self.stage1_error_px);
        before(&earlier.stage2_error_px, &mut self.stage2_error_px);
        before(&earlier.fine_moves, &mut self.fine_moves);
        before(&earlier.fine_moves_stage2, &mut self.fine_moves_stage2);
        before(&earlier.learning_curve, &mut self.learning_curve);
        self.combined_error_px = self
            .stage1_error_px
            .iter()
            .zip(&self.stage2_error_px)
            .map(|(a, b)| combined(*a, *b))
            .collect();
    }
}

/// Mean of the finite values of a slice; NaN (`null` in the JSON report, `n/a` in the
/// table) when there are none. Failed trials are NaN in the curves and counted in
/// [`Report::failures`], never averaged.
pub fn mean(x: &[f32]) -> f32 {
    let (sum, n) = x
        .iter()
        .filter(|v| v.is_finite())
        .fold((0.0, 0usize), |(s, n), v| (s + v, n + 1));
    if n == 0 {
        f32::NAN
    } else {
        sum / n as f32
    }
}

/// The `q`-quantile (0..=1) of the finite values by nearest rank: the smallest value with
/// at least a fraction `q` of the values at or below it; NaN when there are none.
pub fn quantile(x: &[f32], q: f32) -> f32 {
    let mut v: Vec<f32> = x.iter().copied().filter(|v| v.is_finite()).collect();
    if v.is_empty() {
        return f32::NAN;
    }
    v.sort_by(f32::total_cmp);
    let rank = (q * v.len() as f32).ceil() as usize;
    v[rank.clamp(1, v.len()) - 1]
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

/// First trial after which the centred 21-trial mean stays below `limit`, if any.
pub fn trials_to_reach(curve: &[f32], limit: f32) -> Option<usize> {
    let s = smooth(curve, 21);
    let mut first = None;
    for (i, &e) in s.iter().enumerate() {
        if e < limit {
            first.get_or_insert(i + 1);
        } else {
            first = None;
        }
    }
    first
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn reach_is_the_first_trial_after_which_the_mean_stays_below() {
        let mut c = vec![10.0f32; 50];
        c.extend(vec![1.0f32; 100]);
        let n = trials_to_reach(&c, 3.0).unwrap();
        assert!(n > 45 && n < 60, "{n}");
        assert_eq!(trials_to_reach(&[5.0; 30], 3.0), None);
    }

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
    fn quantiles_by_nearest_rank() {
        let x: Vec<f32> = (1..=20).map(|i| i as f32).collect();
        assert_eq!(quantile(&x, 0.5), 10.0);
        assert_eq!(quantile(&x, 0.9), 18.0);
        assert_eq!(quantile(&x, 0.95), 19.0);
        assert_eq!(quantile(&x, 1.0), 20.0);
        assert_eq!(quantile(&[3.0, f32::NAN, 1.0], 1.0), 3.0);
        assert!(quantile(&[], 0.5).is_nan());
    }

    #[test]
    fn smoothing() {
        assert_eq!(smooth(&[0.0, 3.0, 6.0], 3), vec![1.5, 3.0, 4.5]);
        assert!(
            mean(&[]).is_nan(),
            "a mean of nothing is no number, never 0"
        );
        assert_eq!(mean(&[1.0, f32::NAN, 3.0]), 2.0);
    }
}
