//! The run's figures from its log: training curves, the held-out evaluations (fixed move
//! budget, the controller's stop rule, the paper's protocol), snapshots, grasps, failures.

mod failure;

use super::records::{Phase, RunLog, TrialRecord};
use super::report::{
    mean, quantile, Deployment, EvalSummary, FailedTrial, GraspSummary, History, Report,
    SnapshotPoint, TrialPoint, VisitAndReturn,
};
use super::scoring::{self, combined, StageScore};
pub use failure::{failure, Failure};

fn last_px(s: Option<&StageScore>) -> f32 {
    s.map(StageScore::final_px).unwrap_or(f32::NAN)
}

/// One training trial pair as a point of the curves.
fn point(r1: &TrialRecord, r2: &TrialRecord) -> TrialPoint {
    let (s1, s2) = (scoring::stage1(r1), scoring::stage2(r2));
    let moves =
        |s: Option<&StageScore>| s.and_then(|s| s.report).map(|r| r.fine_moves).unwrap_or(0);
    TrialPoint {
        stage1_px: last_px(s1.as_ref()),
        stage2_px: last_px(s2.as_ref()),
        stage1_coarse_px: s1.as_ref().map(StageScore::coarse_px).unwrap_or(f32::NAN),
        stage1_fine_moves: moves(s1.as_ref()),
        stage2_fine_moves: moves(s2.as_ref()),
    }
}

/// Mean error after the coarse move and after each fine move over all trials; a trial that
/// stopped earlier keeps its last error (the arm stays where it is).
pub fn by_move_means(trials: &[Vec<f32>]) -> Vec<f32> {
    let longest = trials.iter().map(Vec::len).max().unwrap_or(0);
    (0..longest)
        .map(|i| {
            let col: Vec<f32> = trials
                .iter()
                .filter_map(|t| t.get(i).or(t.last()).copied())
                .collect();
            mean(&col)
        })
        .collect()
}

/// The training curve and the snapshots of `log` (what a checkpoint's `.sim` keeps of the
/// run so far).
pub fn history(log: &RunLog) -> History {
    let mut r = Report::default();
    for (r1, r2) in log.pairs(Phase::Training) {
        r.push_trial(&point(r1, r2));
    }
    r.learning_curve = snapshots(log);
    r.history()
}

/// Fills the figures of `report` from `log`.
pub fn fill(report: &mut Report, log: &RunLog, eval_targets: usize, grasps: usize) {
    for (r1, r2) in log.pairs(Phase::Training) {
        report.push_trial(&point(r1, r2));
    }
    report.correction_cap_hits = log.trials.iter().map(TrialRecord::cap_hits).sum();
    report.aborted_trials = log.trials.iter().filter(|r| r.aborted).count();
    report.failures = log
        .trials
        .iter()
        .filter_map(|r| {
            failure(r).map(|f| FailedTrial {
                trial: r.trial,
                phase: format!("{:?}", r.phase).to_lowercase(),
                reason: f.reason(),
                cause: f.cause,
            })
        })
        .collect();
    report.failed_trials = report.failures.len();
    report.evaluation_trials = log
        .trials
        .iter()
        .filter(|r| {
            matches!(
                r.phase,
                Phase::Deployment | Phase::Evaluation | Phase::Grasping
            )
        })
        .count();
    evaluation(report, log, eval_targets);
    report.deployment = deployment(log, Phase::Deployment, eval_targets);
    report.learning_curve = snapshots(log);
    report.visit_and_return = visit_and_return(log, eval_targets);
    grasping(report, log, grasps);
}

/// The pairs of a phase whose trials both succeeded.
fn ok_pairs(log: &RunLog, phase: Phase) -> (Vec<(StageScore, StageScore)>, usize) {
    let mut failed = 0;
    let mut ok = vec![];
    for (r1, r2) in log.pairs(phase) {
        failed += failure(r1).is_some() as usize + failure(r2).is_some() as usize;
        if let (None, None, Some(a), Some(b)) = (
            failure(r1),
            failure(r2),
            scoring::stage1(r1),
            scoring::stage2(r2),
        ) {
            ok.push((a, b));
        }
    }
    (ok, failed)
}

fn column(
    pairs: &[(StageScore, StageScore)],
    moves: usize,
    f: impl Fn(&StageScore, &StageScore, usize) -> f32,
) -> Vec<f32> {
    summary(pairs, moves, f, mean)
}

/// A statistic over the targets of a per-target figure, after each move.
fn summary(
    pairs: &[(StageScore, StageScore)],
    moves: usize,
    f: impl Fn(&StageScore, &StageScore, usize) -> f32,
    stat: impl Fn(&[f32]) -> f32,
) -> Vec<f32> {
    (0..moves)
        .map(|m| stat(&pairs.iter().map(|(a, b)| f(a, b, m)).collect::<Vec<_>>()))
        .collect()
}

fn at(v: &[f32], m: usize) -> f32 {
    v.get(m).copied().unwrap_or(f32::NAN)
}

/// Fine moves until the noise-free error is within 2 px; `None` if never.
fn moves_to_2px(s: &StageScore) -> Option<usize> {
    s.errors_true_px.iter().position(|&e| e <= 2.0)
}

/// The fixed-budget evaluation of one phase.
fn deployment(log: &RunLog, phase: Phase, targets: usize) -> Deployment {
    let (pairs, failed) = ok_pairs(log, phase);
    let fine_moves = log.phase(phase).map(|r| r.fine_moves).next().unwrap_or(0);
    let moves = fine_moves as usize + 1;
    let mut to2 = vec![];
    let mut not_reached = 0;
    for s in pairs.iter().flat_map(|(a, b)| [a, b]) {
        match moves_to_2px(s) {
            Some(n) => to2.push(n as f32),
            None => {
                not_reached += 1;
                to2.push(moves as f32);
            }
        }
    }
    let noise: Vec<f32> = pairs
        .iter()
        .map(|(a, b)| combined(a.noise_floor_px, b.noise_floor_px))
        .collect();
    let true_px = |a: &StageScore, b: &StageScore, m| {
        combined(at(&a.errors_true_px, m), at(&b.errors_true_px, m))
    };
    let measured_px =
        |a: &StageScore, b: &StageScore, m| combined(at(&a.errors_px, m), at(&b.errors_px, m));
    let tail = |f: &dyn Fn(&StageScore, &StageScore, usize) -> f32, q: f32| {
        summary(&pairs, moves, f, |x| quantile(x, q))
    };
    Deployment {
        combined_true_p50_px: tail(&true_px, 0.5),
        combined_true_p90_px: tail(&true_px, 0.9),
        combined_true_p95_px: tail(&true_px, 0.95),
        combined_true_max_px: tail(&true_px, 1.0),
        combined_measured_p50_px: tail(&measured_px, 0.5),
        combined_measured_p90_px: tail(&measured_px, 0.9),
        combined_measured_p95_px: tail(&measured_px, 0.95),
        combined_measured_max_px: tail(&measured_px, 1.0),
        targets,
        fine_moves,
        stage1_true_px: column(&pairs, moves, |a, _, m| at(&a.errors_true_px, m)),
        stage2_true_px: column(&pairs, moves, |_, b, m| at(&b.errors_true_px, m)),
        combined_true_px: column(&pairs, moves, |a, b, m| {
            combined(at(&a.errors_true_px, m), at(&b.errors_true_px, m))
        }),
        stage1_measured_px: column(&pairs, moves, |a, _, m| at(&a.errors_px, m)),
        stage2_measured_px: column(&pairs, moves, |_, b, m| at(&b.errors_px, m)),
        combined_measured_px: column(&pairs, moves, |a, b, m| {
            combined(at(&a.errors_px, m), at(&b.errors_px, m))
        }),
        noise_floor_px: mean(&noise),
        moves_to_2px_mean: mean(&to2),
        moves_to_2px_not_reached: not_reached,
        failed_trials: failed,
        combined_measured_by_target_px: pairs
            .iter()
            .map(|(a, b)| combined(at(&a.errors_px, moves - 1), at(&b.errors_px, moves - 1)))
            .collect(),
    }
}

fn snapshots(log: &RunLog) -> Vec<SnapshotPoint> {
    let mut seen = vec![];
    for r in &log.trials {
        if let Phase::Snapshot(n) = r.phase {
            if !seen.contains(&n) {
                seen.push(n);
            }
        }
    }
    seen.into_iter()
        .map(|n| {
            let d = deployment(log, Phase::Snapshot(n), 0);
            let asked = log.phase(Phase::SnapshotGrasp(n)).count();
            let g = grasp_summary(log, Phase::SnapshotGrasp(n), asked);
            // a grasp whose cylinder the twin arm, worn and drifted as the arm is now, can no
            // longer hold or see is no target: counted apart, not as the controller's failure
            let unreachable = log
                .phase(Phase::SnapshotGrasp(n))
                .filter(|r| !r.target_seen)
                .count();
            let scored = asked - unreachable;
            SnapshotPoint {
                trial: n,
                stage1_true_px: d.stage1_true_px,
                stage2_true_px: d.stage2_true_px,
                combined_true_px: d.combined_true_px,
                combined_measured_px: d.combined_measured_px,
                noise_floor_px: d.noise_floor_px,
                failed_trials: d.failed_trials,
                grasps: asked,
                grasps_unreachable: unreachable,
                grasp_success: if scored > 0 {
                    g.success_rate * asked as f32 / scored as f32
                } else {
                    f32::NAN
                },
                grasp_failures: g.failure_causes,
            }
        })
        .collect()
}

fn visit_and_return(log: &RunLog, targets: usize) -> VisitAndReturn {
    let (pairs, _) = ok_pairs(log, Phase::VisitAndReturn);
    let f = |g: &dyn Fn(&StageScore) -> f32| -> Vec<f32> {
        pairs.iter().map(|(a, b)| combined(g(a), g(b))).collect()
    };
    let moves: Vec<f32> = pairs
        .iter()
        .flat_map(|(a, b)| [a.fine_moves() as f32, b.fine_moves() as f32])
        .collect();
    VisitAndReturn {
        targets,
        combined_measured_px: mean(&f(&StageScore::final_px)),
        combined_true_px: mean(&f(&StageScore::final_true_px)),
        fine_moves: mean(&moves),
    }
}

/// The held-out evaluation with the controller's own stop rule (the report's main fields).
fn evaluation(report: &mut Report, log: &RunLog, targets: usize) {
    let mut eval = EvalSummary {
        targets,
        ..Default::default()
    };
    let (pairs, _) = ok_pairs(log, Phase::Evaluation);
    for (r1, r2) in log.pairs(Phase::Evaluation) {
        eval.cap_hits += r1.cap_hits() + r2.cap_hits();
    }
    let col = |f: &dyn Fn(&StageScore, &StageScore) -> f32| -> Vec<f32> {
        pairs.iter().map(|(a, b)| f(a, b)).collect()
    };
    let (e1, e2) = (col(&|a, _| a.final_px()), col(&|_, b| b.final_px()));
    let (t1, t2) = (
        col(&|a, _| a.final_true_px()),
        col(&|_, b| b.final_true_px()),
    );
    let (m1, m2) = (
        col(&|a, _| a.fine_moves() as f32),
        col(&|_, b| b.fine_moves() as f32),
    );
    eval.stage1_final_px = mean(&e1);
    eval.stage2_final_px = mean(&e2);
    eval.stage1_final_true_px = mean(&t1);
    eval.stage2_final_true_px = mean(&t2);
    eval.stage1_fine_moves = mean(&m1);
    eval.stage2_fine_moves = mean(&m2);
    eval.stage1_error_mm = mean(&col(&|a, _| a.pose_error_mm));
    eval.stage1_error_deg = mean(&col(&|a, _| a.pose_error_deg));
    let by1: Vec<Vec<f32>> = pairs.iter().map(|(a, _)| a.errors_px.clone()).collect();
    let by2: Vec<Vec<f32>> = pairs.iter().map(|(_, b)| b.errors_px.clone()).collect();
    eval.stage1_error_by_move_px = by_move_means(&by1);
    eval.stage2_error_by_move_px = by_move_means(&by2);
    report.final_error_px = mean(&col(&|a, b| combined(a.final_px(), b.final_px())));
    report.final_error_true_px = mean(&col(&|a, b| combined(a.final_true_px(), b.final_true_px())));
    report.noise_floor_px = mean(&col(&|a, b| combined(a.noise_floor_px, b.noise_floor_px)));
    report.fine_moves_mean = (mean(&m1) + mean(&m2)) / 2.0;
    report.sim_time_per_target_s = mean(&col(&|a, b| a.sim_time_s + b.sim_time_s));
    report.eval = eval;
}

/// Why a scored grasp failed.
fn grasp_cause(r: &TrialRecord, limit_deg: f64) -> &'static str {
    let (Some(a), Some(b), Some(g)) = (scoring::stage1(r), scoring::stage2(r), r.grasp) else {
        return "no grasp";
    };
    if a.final_true_px() > 3.0 {
        "stage-1 error"
    } else if b.final_true_px() > 2.0 {
        "stage-2 error"
    } else if g.perpendicular_error_deg > limit_deg {
        "orientation"
    } else {
        "placement"
    }
}

fn grasping(report: &mut Report, log: &RunLog, grasps: usize) {
    let g = grasp_summary(log, Phase::Grasping, grasps);
    report.grasp_success_rate = g.success_rate;
    report.error_mm = g.error_mm;
    report.error_deg = g.error_deg;
    report.grasp = g;
}

/// The grasps of `phase` (`grasps` of them asked for).
fn grasp_summary(log: &RunLog, phase: Phase, grasps: usize) -> GraspSummary {
    let mut g = GraspSummary {
        grasps,
        ..Default::default()
    };
    let (mut ok, mut gc, mut gct, mut gmm, mut gdeg, mut gmoves) =
        (0usize, vec![], vec![], vec![], vec![], vec![]);
    for r in log.phase(phase) {
        if let Some(f) = failure(r) {
            *g.failure_causes.entry(f.cause).or_default() += 1;
            continue;
        }
        if let (Some(a), Some(b)) = (scoring::stage1(r), scoring::stage2(r)) {
            gc.push(combined(a.final_px(), b.final_px()));
            gct.push(combined(a.final_true_px(), b.final_true_px()));
            gmoves.push((a.errors_px.len() + b.errors_px.len()).saturating_sub(2) as f32);
        }
        if let Some(score) = r.grasp {
            gmm.push(score.distance_mm as f32);
            gdeg.push(score.perpendicular_error_deg as f32);
            ok += score.success as usize;
            if !score.success {
                let cause = grasp_cause(r, 10.0);
                *g.failure_causes.entry(cause.to_string()).or_default() += 1;
            }
        } else {
            *g.failure_causes
                .entry("gripper never closed".into())
                .or_default() += 1;
        }
    }
    g.success_rate = if grasps > 0 {
        ok as f32 / grasps as f32
    } else {
        f32::NAN
    };
    g.combined_error_px = mean(&gc);
    g.combined_error_true_px = mean(&gct);
    g.error_mm = mean(&gmm);
    g.error_deg = mean(&gdeg);
    g.fine_moves = mean(&gmoves);
    g
}
