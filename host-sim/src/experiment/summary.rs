//! The summary table printed at the end of a run.

use super::report::{mean, Report};

/// Mean of the last `n` entries.
fn tail(x: &[f32], n: usize) -> f32 {
    mean(&x[x.len().saturating_sub(n)..])
}

/// First trial after which the centred 21-trial mean stays below `limit`, if any.
pub fn trials_to_reach(curve: &[f32], limit: f32) -> Option<usize> {
    let s = super::report::smooth(curve, 21);
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

/// Prints the summary of `r`; with `paper`, the chapter's figures beside the run's.
pub fn print(r: &Report, paper: bool) {
    let fmt_reach = |c: &[f32]| {
        trials_to_reach(c, 3.0)
            .map(|n| n.to_string())
            .unwrap_or_else(|| "not reached".into())
    };
    println!();
    println!(
        "TRN controller on the simulated SoftArm: {} ({} preset, seed {}, bus {})",
        r.command, r.preset, r.seed, r.bus
    );
    println!("{:-<96}", "");
    println!(
        "{:<58} {:>18} {:>18}",
        "",
        "this run",
        if paper { "paper (Sec. 8.4)" } else { "" }
    );
    let row = |name: &str, ours: String, theirs: &str| {
        println!(
            "{:<58} {:>18} {:>18}",
            name,
            ours,
            if paper { theirs } else { "" }
        );
    };
    if r.trials > 0 {
        row(
            "training trials per network",
            r.trials.to_string(),
            "300-1000",
        );
        row(
            "stage 1 below 3 px (position+orientation) after trial",
            fmt_reach(&r.stage1_error_px),
            "400",
        );
        row(
            "stage 2 below 3 px after trial",
            fmt_reach(&r.stage2_error_px),
            "400",
        );
        row(
            "combined error, last 50 training trials (px)",
            format!("{:.2}", tail(&r.combined_error_px, 50)),
            "1.35 @300",
        );
        let late: Vec<f32> = r.fine_moves.iter().map(|&m| m as f32).collect();
        row(
            "stage-1 fine moves per trial, last 50 training trials",
            format!("{:.2}", tail(&late, 50)),
            "~8 @200",
        );
    }
    if r.eval.targets > 0 {
        row(
            "held-out targets per network (no learning)",
            r.eval.targets.to_string(),
            "",
        );
        row(
            "stage 1 final error (px)",
            format!("{:.2}", r.eval.stage1_final_px),
            "a little < 1",
        );
        row(
            "stage 2 final error (px)",
            format!("{:.2}", r.eval.stage2_final_px),
            "a little < 1",
        );
        row(
            "combined final error, noisy target vs noisy reading (px)",
            format!("{:.2}", r.final_error_px),
            "1.35",
        );
        row(
            "combined final error, noise-free ground truth (px)",
            format!("{:.2}", r.final_error_true_px),
            "",
        );
        row(
            "camera-noise floor of the same measure (px)",
            format!("{:.2}", r.noise_floor_px),
            "",
        );
        row(
            "fine moves per network trial (mature)",
            format!("{:.2}", r.fine_moves_mean),
            "2-3",
        );
        let by = |v: &[f32]| {
            v.iter()
                .map(|x| format!("{x:.1}"))
                .collect::<Vec<_>>()
                .join(" ")
        };
        row(
            "stage 1 error after coarse, fine 1, 2, ... (px)",
            by(&r.eval.stage1_error_by_move_px),
            "",
        );
        row(
            "stage 2 error after coarse, fine 1, 2, ... (px)",
            by(&r.eval.stage2_error_by_move_px),
            "",
        );
        row(
            "stage 1 pose error (mm / deg)",
            format!(
                "{:.1} / {:.1}",
                r.eval.stage1_error_mm, r.eval.stage1_error_deg
            ),
            "",
        );
    }
    if r.grasp.grasps > 0 {
        row("grasps", r.grasp.grasps.to_string(), "");
        row(
            "grasp success rate",
            format!("{:.0} %", 100.0 * r.grasp_success_rate),
            "",
        );
        row(
            "grasp: gripper to cylinder centre (mm)",
            format!("{:.1}", r.error_mm),
            "",
        );
        row(
            "grasp: deviation from perpendicular (deg)",
            format!("{:.1}", r.error_deg),
            "",
        );
        row(
            "grasp combined error (px)",
            format!("{:.2}", r.grasp.combined_error_px),
            "",
        );
    }
    row(
        "trials ended at the fine-move cap",
        r.correction_cap_hits.to_string(),
        "",
    );
    row(
        "wall time (s)",
        format!("{:.1}", r.wall_s),
        "~30 s per trial",
    );
    println!("{:-<96}", "");
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
}
