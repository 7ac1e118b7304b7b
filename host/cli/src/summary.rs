//! The summary `trn` prints at the end of a run: the deployment-style evaluation with the fixed
//! move budget first (what measures the networks), then the controller's stop rule, the
//! training curve (which depends on the tolerance schedule tol(t)), grasps and failures.

use trn_bench::format::{protocol_line, px};
use trn_bench::report::{mean, trials_to_reach, Report};
use trn_bench::{LabError as Error, Result};

/// Mean of the last `n` entries.
fn tail(x: &[f32], n: usize) -> f32 {
    mean(&x[x.len().saturating_sub(n)..])
}

/// Prints the conformance suite's checks; fails when any failed.
pub fn conformance(r: &Report) -> Result<()> {
    println!(
        "conformance suite on {} (seed {}, {})",
        r.bus, r.seed, r.preset
    );
    if let Some(line) = protocol_line(r) {
        println!("{line}; the checks of what v4 added are not applicable");
    }
    for c in &r.conformance {
        let verdict = match (c.passed, c.skipped) {
            (_, true) => "n/a ",
            (true, _) => "pass",
            (false, _) => "FAIL",
        };
        println!("  {verdict}  {}", c.name);
        if !c.passed || c.skipped {
            println!("        {}", c.detail);
        }
    }
    let failed = r.conformance.iter().filter(|c| !c.passed).count();
    let skipped = r.conformance.iter().filter(|c| c.skipped).count();
    let run = r.conformance.len() - skipped;
    let not_applicable = match skipped {
        0 => String::new(),
        n => format!(" ({n} more not applicable to this controller)"),
    };
    println!("{} of {run} checks passed{not_applicable}", run - failed);
    if failed > 0 || r.conformance.is_empty() {
        return Err(Error::NotConformant {
            failed,
            checks: r.conformance.len(),
        });
    }
    Ok(())
}

/// What the summary's title calls the controller of a report whose law is `law`.
fn controller_title(law: &str) -> String {
    match law {
        "trn" | "" => "TRN controller".into(),
        "broyden" => "Broyden servo".into(),
        "model" => "Calibrated model".into(),
        "oracle" => "Oracle".into(),
        other => format!("Controller `{other}`"),
    }
}

/// Prints the summary of `r`; with `paper`, the chapter's figures beside the run's. Fails
/// (after printing) when more than 10 % of the evaluation's trials failed.
pub fn print(r: &Report, paper: bool) -> Result<()> {
    let w = 100;
    println!();
    println!(
        "{} on the simulated SoftArm: {} ({} preset, seed {}, bus {})",
        controller_title(&r.law),
        r.command,
        r.preset,
        r.seed,
        r.bus
    );
    if let Some(line) = protocol_line(r) {
        println!("{line}");
    }
    println!("{:=<w$}", "");
    let d = &r.deployment;
    if d.targets > 0 {
        println!(
            "held-out, deployment-style targets, fixed budget: coarse move + {} fine moves, {} targets per network",
            d.fine_moves, d.targets
        );
        println!(
            "{:<38} {}",
            "error after move (px)",
            (0..=d.fine_moves)
                .map(|m| if m == 0 {
                    format!(" {:>6}", "coarse")
                } else {
                    format!(" {m:>6}")
                })
                .collect::<Vec<_>>()
                .join("")
        );
        let row = |name: &str, v: &[f32]| {
            println!(
                "{:<38} {}",
                name,
                v.iter()
                    .map(|x| format!(" {:>6}", px(*x)))
                    .collect::<Vec<_>>()
                    .join("")
            );
        };
        row("stage 1, noise-free", &d.stage1_true_px);
        row("stage 2, noise-free", &d.stage2_true_px);
        row("combined, noise-free", &d.combined_true_px);
        row("  median over the targets", &d.combined_true_p50_px);
        row("  95th percentile", &d.combined_true_p95_px);
        row("  worst target", &d.combined_true_max_px);
        row("combined, measured", &d.combined_measured_px);
        row("  95th percentile", &d.combined_measured_p95_px);
        println!(
            "{:<38} {}",
            "camera-noise floor of the measured (px)",
            px(d.noise_floor_px)
        );
        println!(
            "{:<38} {} (not within the budget: {} trials)",
            "fine moves to 2 px (noise-free)",
            px(d.moves_to_2px_mean),
            d.moves_to_2px_not_reached
        );
        println!("{:-<w$}", "");
    }
    if let (Some(first), Some(last)) = (r.learning_curve.first(), r.learning_curve.last()) {
        println!(
            "frozen snapshots: combined noise-free error after coarse / 2 fine moves: {} / {} px after {} trials, {} / {} px after {}",
            px(first.combined_true_px.first().copied().unwrap_or(f32::NAN)),
            px(first.combined_true_px.get(2).copied().unwrap_or(f32::NAN)),
            first.trial,
            px(last.combined_true_px.first().copied().unwrap_or(f32::NAN)),
            px(last.combined_true_px.get(2).copied().unwrap_or(f32::NAN)),
            last.trial,
        );
        println!("{:-<w$}", "");
    }
    println!(
        "{:<62} {:>16} {:>18}",
        "",
        "this run",
        if paper { "paper (Sec. 8.4)" } else { "" }
    );
    let row = |name: &str, ours: String, theirs: &str| {
        println!(
            "{:<62} {:>16} {:>18}",
            name,
            ours,
            if paper { theirs } else { "" }
        );
    };
    if r.eval.targets > 0 {
        row(
            "held-out, controller's stop rule: combined final error (px)",
            px(r.final_error_px),
            "1.35",
        );
        row("  the same, noise-free", px(r.final_error_true_px), "");
        row(
            "  camera-noise floor of that measure",
            px(r.noise_floor_px),
            "",
        );
        row(
            "  fine moves per network trial",
            px(r.fine_moves_mean),
            "2-3",
        );
        row(
            "  simulated time per target, both networks (s)",
            px(r.sim_time_per_target_s),
            "",
        );
        let pair = |a: f32, b: f32| format!("{} / {}", px(a), px(b));
        row(
            "  stage 1 / stage 2 final error (px)",
            pair(r.eval.stage1_final_px, r.eval.stage2_final_px),
            "a little < 1",
        );
        row(
            "  stage 1 pose error (mm / deg)",
            pair(r.eval.stage1_error_mm, r.eval.stage1_error_deg),
            "",
        );
        let v = &r.visit_and_return;
        row(
            "paper's visit-then-return targets: combined final error",
            format!(
                "{} px, {} moves",
                px(v.combined_measured_px),
                px(v.fine_moves)
            ),
            "",
        );
    }
    if r.trials > 0 {
        let reach = |c: &[f32]| {
            trials_to_reach(c, 3.0)
                .map(|n| n.to_string())
                .unwrap_or_else(|| "not reached".into())
        };
        row(
            "training trials per network",
            r.trials.to_string(),
            "300-1000",
        );
        row(
            "training curve below 3 px after trial (depends on tol(t))",
            format!(
                "{}, {}",
                reach(&r.stage1_error_px),
                reach(&r.stage2_error_px)
            ),
            "400",
        );
        row(
            "  combined end-of-trial error, last 50 trials (tol(t))",
            px(tail(&r.combined_error_px, 50)),
            "1.35 @300",
        );
    }
    if r.grasp.grasps > 0 {
        row(
            "grasps: success, distance (mm), tilt (deg)",
            format!(
                "{} %, {}, {}",
                px(100.0 * r.grasp_success_rate),
                px(r.error_mm),
                px(r.error_deg)
            ),
            "",
        );
        for (cause, n) in &r.grasp.failure_causes {
            row(&format!("  failed grasps: {cause}"), n.to_string(), "");
        }
    }
    row("trials that failed", r.failed_trials.to_string(), "");
    row(
        "wall time (s)",
        format!("{:.1}", r.wall_s),
        "~30 s per trial",
    );
    println!("{:=<w$}", "");
    check_failures(r)
}

/// What an interrupted run did (on stderr: its figures are partial and not printed as
/// results).
pub fn interrupted(r: &Report) {
    eprintln!(
        "{}: interrupted after {} training trials per network ({} in this run), {} evaluation trials; the report (if asked) is marked \"interrupted\"; a checkpoint (if asked) continues it with --continue",
        r.command,
        r.trials,
        r.stage1_error_px.len(),
        r.evaluation_trials
    );
}

/// `TooManyFailures` when more than 10 % of the evaluation's trials failed.
pub fn check_failures(r: &Report) -> Result<()> {
    let failed: Vec<_> = r
        .failures
        .iter()
        .filter(|f| matches!(f.phase.as_str(), "deployment" | "evaluation" | "grasping"))
        .collect();
    if r.evaluation_trials == 0 || failed.len() * 10 <= r.evaluation_trials {
        return Ok(());
    }
    let mut reasons = std::collections::BTreeMap::<String, usize>::new();
    for f in &failed {
        // the same cause with other details (trial, seq) counts together
        let cause = if f.cause.is_empty() {
            &f.reason
        } else {
            &f.cause
        };
        *reasons.entry(cause.clone()).or_default() += 1;
    }
    Err(Error::TooManyFailures {
        failed: failed.len(),
        trials: r.evaluation_trials,
        reasons: reasons
            .iter()
            .map(|(k, n)| format!("{n} x {k}"))
            .collect::<Vec<_>>()
            .join("; "),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use trn_bench::report::FailedTrial;

    #[test]
    fn more_than_a_tenth_of_failed_evaluation_trials_is_an_error() {
        let fail = |phase: &str| FailedTrial {
            trial: 1,
            phase: phase.into(),
            reason: "lost light".into(),
            cause: "lost light".into(),
        };
        let mut r = Report {
            evaluation_trials: 20,
            failures: vec![fail("evaluation"), fail("grasping")],
            ..Default::default()
        };
        assert!(check_failures(&r).is_ok(), "2 of 20 is 10 %");
        r.failures.push(fail("deployment"));
        let e = check_failures(&r).unwrap_err().to_string();
        assert!(e.contains("3 of 20") && e.contains("lost light"), "{e}");
        // training failures do not count against the evaluation
        r.failures = vec![fail("training"); 10];
        assert!(check_failures(&r).is_ok());
    }

    /// The title names the controller that ran (a Broyden run was titled "TRN controller").
    #[test]
    fn the_title_names_the_controller_that_ran() {
        let names: Vec<String> = ["trn", "", "broyden", "model", "oracle", "x"]
            .iter()
            .map(|l| controller_title(l))
            .collect();
        assert_eq!(
            names,
            [
                "TRN controller",
                "TRN controller",
                "Broyden servo",
                "Calibrated model",
                "Oracle",
                "Controller `x`"
            ]
        );
    }
}
