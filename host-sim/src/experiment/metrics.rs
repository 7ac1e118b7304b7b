//! The run's figures from its log: training curves, held-out evaluation, grasps.

use super::records::{Phase, RunLog, TrialRecord};
use super::report::{mean, EvalSummary, GraspSummary, Report, TrialPoint};
use super::scoring::{self, combined, StageScore};

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

/// Fills the figures of `report` from `log`.
pub fn fill(report: &mut Report, log: &RunLog, eval_targets: usize, grasps: usize) {
    for (r1, r2) in log.pairs(Phase::Training) {
        report.push_trial(&point(r1, r2));
    }
    report.correction_cap_hits = log.trials.iter().map(TrialRecord::cap_hits).sum();
    report.aborted_trials = log.trials.iter().filter(|r| r.aborted).count();
    evaluation(report, log, eval_targets);
    grasping(report, log, grasps);
}

fn evaluation(report: &mut Report, log: &RunLog, targets: usize) {
    let mut eval = EvalSummary {
        targets,
        ..Default::default()
    };
    let (mut e1, mut e2, mut t1, mut t2, mut m1, mut m2) =
        (vec![], vec![], vec![], vec![], vec![], vec![]);
    let (mut mm, mut deg, mut noise) = (vec![], vec![], vec![]);
    let (mut by_move1, mut by_move2) = (vec![], vec![]);
    for (r1, r2) in log.pairs(Phase::Evaluation) {
        eval.cap_hits += r1.cap_hits() + r2.cap_hits();
        let (Some(a), Some(b)) = (scoring::stage1(r1), scoring::stage2(r2)) else {
            continue;
        };
        e1.push(a.final_px());
        t1.push(a.final_true_px());
        e2.push(b.final_px());
        t2.push(b.final_true_px());
        m1.push(a.fine_moves() as f32);
        m2.push(b.fine_moves() as f32);
        mm.push(a.pose_error_mm);
        deg.push(a.pose_error_deg);
        noise.push(combined(a.noise_floor_px, b.noise_floor_px));
        by_move1.push(a.errors_px);
        by_move2.push(b.errors_px);
    }
    eval.stage1_final_px = mean(&e1);
    eval.stage2_final_px = mean(&e2);
    eval.stage1_final_true_px = mean(&t1);
    eval.stage2_final_true_px = mean(&t2);
    eval.stage1_fine_moves = mean(&m1);
    eval.stage2_fine_moves = mean(&m2);
    eval.stage1_error_mm = mean(&mm);
    eval.stage1_error_deg = mean(&deg);
    eval.stage1_error_by_move_px = by_move_means(&by_move1);
    eval.stage2_error_by_move_px = by_move_means(&by_move2);
    let combined_eval: Vec<f32> = e1.iter().zip(&e2).map(|(a, b)| combined(*a, *b)).collect();
    let combined_true: Vec<f32> = t1.iter().zip(&t2).map(|(a, b)| combined(*a, *b)).collect();
    report.final_error_px = mean(&combined_eval);
    report.final_error_true_px = mean(&combined_true);
    report.noise_floor_px = mean(&noise);
    report.fine_moves_mean = (mean(&m1) + mean(&m2)) / 2.0;
    report.eval = eval;
}

fn grasping(report: &mut Report, log: &RunLog, grasps: usize) {
    let mut g = GraspSummary {
        grasps,
        ..Default::default()
    };
    let (mut ok, mut gc, mut gct, mut gmm, mut gdeg, mut gmoves) =
        (0usize, vec![], vec![], vec![], vec![], vec![]);
    for r in log.phase(Phase::Grasping) {
        if let (Some(a), Some(b)) = (scoring::stage1(r), scoring::stage2(r)) {
            if let (Some(x), Some(y)) = (a.errors_px.last(), b.errors_px.last()) {
                gc.push(combined(*x, *y));
            }
            if let (Some(x), Some(y)) = (a.errors_true_px.last(), b.errors_true_px.last()) {
                gct.push(combined(*x, *y));
            }
            gmoves.push((a.errors_px.len() + b.errors_px.len()).saturating_sub(2) as f32);
        }
        if let Some(score) = r.grasp {
            gmm.push(score.distance_mm as f32);
            gdeg.push(score.perpendicular_error_deg as f32);
            ok += score.success as usize;
        }
    }
    g.success_rate = if grasps > 0 {
        ok as f32 / grasps as f32
    } else {
        0.0
    };
    g.combined_error_px = mean(&gc);
    g.combined_error_true_px = mean(&gct);
    g.error_mm = mean(&gmm);
    g.error_deg = mean(&gdeg);
    g.fine_moves = mean(&gmoves);
    report.grasp_success_rate = g.success_rate;
    report.error_mm = g.error_mm;
    report.error_deg = g.error_deg;
    report.grasp = g;
}
