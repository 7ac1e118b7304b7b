//! The schedule of a run: training (stage 1 and stage 2 alternate, supervised priming
//! first), held-out evaluation, grasps. Produces the run's [`RunLog`].

use embedded_can::blocking::Can;
use trn_controller::Config;
use trn_protocol::bus::ReceiveTimeout;
use trn_protocol::{CanFrame, Mode};

use super::records::{Phase, RunLog, TrialKind};
use super::runner::Runner;
use super::scoring::{self, combined};
use crate::error::Result;

/// How many trials of each kind a run has.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Plan {
    /// Training trials per network (0: no training).
    pub trials: usize,
    /// Held-out targets per network.
    pub eval_targets: usize,
    /// Grasps.
    pub grasps: usize,
}

impl Plan {
    /// Trials on the bus in all.
    pub fn total(&self) -> usize {
        self.trials * 2 + self.eval_targets * 2 + self.grasps
    }
}

fn progress(quiet: bool, total: usize) -> indicatif::ProgressBar {
    if quiet {
        return indicatif::ProgressBar::hidden();
    }
    let b = indicatif::ProgressBar::new(total as u64);
    b.set_style(
        indicatif::ProgressStyle::with_template("{prefix:>9} [{bar:40}] {pos}/{len} trials {msg}")
            .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
    );
    b
}

/// Runs `plan` (the controller configured with `cfg`, for its priming length) and ends
/// the session.
pub fn run<P>(runner: &mut Runner<P>, plan: Plan, cfg: &Config, quiet: bool) -> Result<RunLog>
where
    P: Can<Frame = CanFrame, Error = trn_protocol::Error> + ReceiveTimeout,
{
    let bar = progress(quiet, plan.total());
    let mut log = RunLog::default();
    if plan.trials > 0 {
        runner.mode(Mode::Priming)?;
        bar.set_prefix("training");
    }
    let mut recent = Vec::new();
    for i in 0..plan.trials {
        let supervised = (i as u32) < cfg.supervised_steps;
        if i as u32 == cfg.supervised_steps {
            runner.mode(Mode::Training)?;
        }
        let kind1 = TrialKind::Stage1 {
            supervised,
            learn: true,
        };
        let r1 = runner.run_trial(kind1, Phase::Training)?;
        let r2 = runner.run_trial(TrialKind::Stage2 { learn: true }, Phase::Training)?;
        let last = |s: Option<scoring::StageScore>| s.map(|s| s.final_px()).unwrap_or(f32::NAN);
        recent.push(combined(
            last(scoring::stage1(&r1)),
            last(scoring::stage2(&r2)),
        ));
        log.trials.extend([r1, r2]);
        bar.inc(2);
        if i % 10 == 9 {
            let tail = &recent[recent.len().saturating_sub(20)..];
            let m = super::report::mean(tail);
            bar.set_message(format!("combined error (last 20) {m:.2} px"));
        }
    }
    runner.mode(Mode::Mature)?;
    bar.set_prefix("eval");
    for _ in 0..plan.eval_targets {
        let kind1 = TrialKind::Stage1 {
            supervised: false,
            learn: false,
        };
        let r1 = runner.run_trial(kind1, Phase::Evaluation)?;
        let r2 = runner.run_trial(TrialKind::Stage2 { learn: false }, Phase::Evaluation)?;
        log.trials.extend([r1, r2]);
        bar.inc(2);
    }
    bar.set_prefix("grasp");
    for _ in 0..plan.grasps {
        log.trials
            .push(runner.run_trial(TrialKind::Grasp { learn: false }, Phase::Grasping)?);
        bar.inc(1);
    }
    bar.finish_and_clear();
    runner.finish()?;
    Ok(log)
}
