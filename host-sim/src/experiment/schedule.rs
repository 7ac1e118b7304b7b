//! The schedule of a run: training (stage 1 and stage 2 alternate, supervised priming
//! first) with frozen snapshot evaluations, then the held-out evaluations and grasps.
//! Produces the run's [`RunLog`].
//!
//! Every held-out evaluation uses deployment-style targets ([`HeldOut`]), the same set
//! throughout a run. Snapshots and the final evaluations do not learn (`learn = false`,
//! mode `Mature`) and run on a copy of the plant that is thrown away afterwards, so a run
//! with snapshots trains exactly as one without.

use embedded_can::blocking::Can;
use rand_core::SeedableRng;
use rand_xoshiro::Xoshiro256PlusPlus;
use trn_controller::Config;
use trn_protocol::bus::ReceiveTimeout;
use trn_protocol::{CanFrame, Mode, FINE_MOVES_POLICY};

use super::records::{Phase, RunLog, TrialKind};
use super::runner::{Runner, Source, TrialSpec};
use super::scoring::{self, combined};
use super::targets::HeldOut;
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
    /// The fixed budget of fine moves of the held-out evaluation (after the coarse move).
    pub fine_moves: u8,
    /// A frozen snapshot evaluation every this many training trials (0: none).
    pub snapshot_every: usize,
    /// Held-out targets per network in a snapshot (the first of the held-out set).
    pub snapshot_targets: usize,
}

impl Plan {
    /// A plan with the default evaluation: 6 fine moves, a snapshot of 50 targets every 25
    /// training trials.
    pub const fn new(trials: usize, eval_targets: usize, grasps: usize) -> Plan {
        Plan {
            trials,
            eval_targets,
            grasps,
            fine_moves: 6,
            snapshot_every: 25,
            snapshot_targets: 50,
        }
    }

    /// Trials on the bus in all (for the progress bar).
    pub fn total(&self) -> usize {
        let snapshots = self.trials.checked_div(self.snapshot_every).unwrap_or(0);
        let per_snapshot = 2 * self.snapshot_targets.min(self.eval_targets);
        self.trials * 2 + snapshots * per_snapshot + self.eval_targets * 6 + self.grasps
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

/// The held-out sets of a run, drawn once from the run's seed.
struct HeldOutSets {
    targets: Vec<HeldOut>,
    grasps: Vec<HeldOut>,
}

/// Runs `plan` (the controller configured with `cfg`, for its priming length) and ends
/// the session. `seed` draws the held-out targets (apart from the training targets).
pub fn run<P>(
    runner: &mut Runner<P>,
    plan: Plan,
    cfg: &Config,
    seed: u64,
    quiet: bool,
) -> Result<RunLog>
where
    P: Can<Frame = CanFrame, Error = trn_protocol::Error> + ReceiveTimeout,
{
    let bar = progress(quiet, plan.total());
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed ^ 0x4E1D_0075_EED5);
    let plant = runner.rig().plant();
    let sets = HeldOutSets {
        targets: HeldOut::set(plant, &mut rng, plan.eval_targets, false)?,
        grasps: HeldOut::set(plant, &mut rng, plan.grasps, true)?,
    };
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
        if plan.snapshot_every > 0 && (i + 1) % plan.snapshot_every == 0 {
            bar.set_prefix("snapshot");
            let resume = if (i as u32 + 1) < cfg.supervised_steps {
                Mode::Priming
            } else {
                Mode::Training
            };
            let n = plan.snapshot_targets.min(sets.targets.len());
            snapshot(runner, &mut log, &sets.targets[..n], plan, i + 1, &bar)?;
            runner.mode(resume)?;
            bar.set_prefix("training");
        }
    }
    runner.mode(Mode::Mature)?;
    bar.set_prefix("eval");
    let pairs = |phase, fine_moves| {
        sets.targets
            .iter()
            .flat_map(move |h| {
                [
                    TrialKind::Stage1 {
                        supervised: false,
                        learn: false,
                    },
                    TrialKind::Stage2 { learn: false },
                ]
                .map(|kind| TrialSpec {
                    kind,
                    phase,
                    source: Source::HeldOut(*h),
                    fine_moves,
                })
            })
            .collect::<Vec<_>>()
    };
    for spec in pairs(Phase::Deployment, plan.fine_moves)
        .into_iter()
        .chain(pairs(Phase::Evaluation, FINE_MOVES_POLICY))
    {
        log.trials.push(runner.run(&spec)?);
        bar.inc(1);
    }
    for _ in 0..plan.eval_targets {
        for kind in [
            TrialKind::Stage1 {
                supervised: false,
                learn: false,
            },
            TrialKind::Stage2 { learn: false },
        ] {
            log.trials
                .push(runner.run_trial(kind, Phase::VisitAndReturn)?);
            bar.inc(1);
        }
    }
    bar.set_prefix("grasp");
    for h in &sets.grasps {
        let spec = TrialSpec {
            kind: TrialKind::Grasp { learn: false },
            phase: Phase::Grasping,
            source: Source::HeldOut(*h),
            fine_moves: FINE_MOVES_POLICY,
        };
        log.trials.push(runner.run(&spec)?);
        bar.inc(1);
    }
    bar.finish_and_clear();
    runner.finish()?;
    Ok(log)
}

/// A frozen evaluation after `trained` training trials per network: the held-out targets
/// with the fixed move budget, no learning, on a copy of the plant (restored afterwards).
fn snapshot<P>(
    runner: &mut Runner<P>,
    log: &mut RunLog,
    targets: &[HeldOut],
    plan: Plan,
    trained: usize,
    bar: &indicatif::ProgressBar,
) -> Result<()>
where
    P: Can<Frame = CanFrame, Error = trn_protocol::Error> + ReceiveTimeout,
{
    let saved = runner.rig().plant().clone();
    runner.mode(Mode::Mature)?;
    for h in targets {
        for kind in [
            TrialKind::Stage1 {
                supervised: false,
                learn: false,
            },
            TrialKind::Stage2 { learn: false },
        ] {
            let spec = TrialSpec {
                kind,
                phase: Phase::Snapshot(trained),
                source: Source::HeldOut(*h),
                fine_moves: plan.fine_moves,
            };
            log.trials.push(runner.run(&spec)?);
            bar.inc(1);
        }
    }
    *runner.rig_mut().plant_mut() = saved;
    Ok(())
}
