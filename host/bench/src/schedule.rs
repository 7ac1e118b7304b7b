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

use super::history::History;
use super::metrics;
use super::observe::Observer;
use super::records::{Phase, RunLog, TrialKind, TrialRecord};
use super::runner::{Runner, Source, TrialSpec};
use super::scoring::{self, combined};
use super::sim_state::SimState;
use crate::error::Result;
pub use crate::spec::Plan;
use trn_plant::targets::HeldOut;

/// The held-out sets of a run, drawn once from the run's seed.
struct HeldOutSets {
    targets: Vec<HeldOut>,
    grasps: Vec<HeldOut>,
}

/// Periodic checkpoints: every `every` training trials per network, `save` gets the runner
/// (whose port may hold the controller) and the simulator's state at that point.
pub struct Checkpoints<'a, P> {
    /// Training trials per network between two checkpoints.
    pub every: usize,
    /// Writes one.
    pub save: &'a mut dyn FnMut(&Runner<P>, SimState) -> Result<()>,
}

/// What a run's schedule needs besides the runner and the plan.
pub struct Context<'a, P> {
    /// The controller's configuration (its priming length paces the schedule).
    pub cfg: &'a Config,
    /// Draws the held-out targets (apart from the training targets).
    pub seed: u64,
    /// Watches the run and may interrupt it.
    pub observer: &'a mut dyn Observer,
    /// The simulation to continue (a simulator checkpoint, [`SimState`]).
    pub resume: Option<&'a SimState>,
    /// Periodic checkpoints, if asked.
    pub checkpoints: Option<Checkpoints<'a, P>>,
}

/// The runner and the log of a run, with its observer: each trial goes through here.
struct Session<'a, P> {
    runner: &'a mut Runner<P>,
    log: RunLog,
    observer: &'a mut dyn Observer,
    seed: u64,
    earlier: Option<&'a History>,
    checkpoints: Option<Checkpoints<'a, P>>,
}

impl<P> Session<'_, P>
where
    P: Can<Frame = CanFrame, Error = trn_protocol::Error> + ReceiveTimeout,
{
    /// True (and the log marked interrupted) when the observer asks the run to stop: at a
    /// trial boundary, before the next trial.
    fn stopping(&mut self) -> bool {
        if self.observer.stop_requested() {
            self.log.interrupted = true;
        }
        self.log.interrupted
    }

    fn keep(&mut self, rec: TrialRecord) {
        self.observer.trial(&rec);
        self.log.trials.push(rec);
    }

    fn run(&mut self, spec: &TrialSpec) -> Result<()> {
        let rec = self.runner.run(spec)?;
        self.keep(rec);
        Ok(())
    }

    /// The simulator's state now, after `done` training trials per network of `planned`,
    /// with the learning curve so far (the continued run's before it).
    fn state(&self, done: usize, planned: usize) -> SimState {
        let (runner_rng, runner_trial) = self.runner.sequence();
        let mut history = self.earlier.cloned().unwrap_or_default();
        let now = metrics::history(&self.log);
        history.stage1_error_px.extend(now.stage1_error_px);
        history.stage2_error_px.extend(now.stage2_error_px);
        history.fine_moves.extend(now.fine_moves);
        history.fine_moves_stage2.extend(now.fine_moves_stage2);
        history.learning_curve.extend(now.learning_curve);
        SimState {
            version: super::sim_state::VERSION,
            seed: self.seed,
            trials_done: done,
            trials_planned: planned,
            history,
            runner_rng,
            runner_trial,
            checkpoint_crc: 0,
            plant: self.runner.rig().plant().clone(),
        }
    }
}

/// Runs `plan`; the caller ends the session ([`Runner::finish`]: it may read the tables
/// out first). The held-out targets are drawn from the plant as it is
/// before `cx.resume` (a simulator checkpoint, [`SimState`]) replaces it: a continued run
/// keeps the held-out sets of the run it continues. The log keeps the simulator's state at
/// the end of training (or where an interrupt stopped it: a checkpoint of that state
/// continues the run with `--continue`).
pub fn run<'a, P>(runner: &'a mut Runner<P>, mut plan: Plan, cx: Context<'a, P>) -> Result<RunLog>
where
    P: Can<Frame = CanFrame, Error = trn_protocol::Error> + ReceiveTimeout,
{
    cx.observer.start(plan.total() as u64);
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(crate::seeds::Seeds::of(cx.seed).schedule);
    // an interrupt while the held-out sets are drawn ends the run before its first trial
    let (sets, interrupted) = {
        let plant = runner.rig().plant();
        let stop = || cx.observer.stop_requested();
        let targets = HeldOut::set_unless(&plant, &mut rng, plan.eval_targets, false, &stop)?;
        let grasps = match targets {
            Some(_) => HeldOut::set_unless(&plant, &mut rng, plan.grasps, true, &stop)?,
            None => None,
        };
        let interrupted = targets.is_none() || grasps.is_none();
        let sets = HeldOutSets {
            targets: targets.unwrap_or_default(),
            grasps: grasps.unwrap_or_default(),
        };
        (sets, interrupted)
    };
    if let Some(s) = cx.resume {
        *runner.rig_mut().plant_mut() = s.plant.clone();
        runner.continue_sequence((s.runner_rng.clone(), s.runner_trial));
        plan.first_trial = s.trials_done;
    }
    let mut s = Session {
        runner,
        log: RunLog {
            interrupted,
            ..RunLog::default()
        },
        observer: cx.observer,
        seed: cx.seed,
        earlier: cx.resume.map(|r| &r.history),
        checkpoints: cx.checkpoints,
    };
    train(&mut s, plan, cx.cfg, &sets)?;
    if !s.log.interrupted {
        evaluate(&mut s, plan, &sets)?;
    }
    s.observer.finish();
    Ok(s.log)
}

/// The training trials with their snapshots and periodic checkpoints; the simulator's
/// state where they ended.
fn train<P>(s: &mut Session<P>, plan: Plan, cfg: &Config, sets: &HeldOutSets) -> Result<()>
where
    P: Can<Frame = CanFrame, Error = trn_protocol::Error> + ReceiveTimeout,
{
    let first = plan.first_trial;
    let planned = first + plan.trials;
    if plan.trials > 0 {
        let primed = first as u32 >= cfg.supervised_steps;
        s.runner.mode(if primed {
            Mode::Training
        } else {
            Mode::Priming
        })?;
        s.observer.phase("training");
    }
    let mut recent = Vec::new();
    let learning = |i: usize| plan.learn_trials.is_none_or(|n| i < n);
    let mut done = first;
    for i in first..planned {
        if s.stopping() {
            break;
        }
        let learn = learning(i);
        let supervised = learn && (i as u32) < cfg.supervised_steps;
        if !learn && (i == first || learning(i - 1)) {
            // frozen from here on: the tables no longer change
            s.runner.mode(Mode::Mature)?;
        } else if learn && i as u32 == cfg.supervised_steps {
            s.runner.mode(Mode::Training)?;
        }
        let kind1 = TrialKind::Stage1 { supervised, learn };
        let r1 = s.runner.run_trial(kind1, Phase::Training)?;
        let r2 = s
            .runner
            .run_trial(TrialKind::Stage2 { learn }, Phase::Training)?;
        let last = |s: Option<scoring::StageScore>| s.map(|s| s.final_px()).unwrap_or(f32::NAN);
        recent.push(combined(
            last(scoring::stage1(&r1)),
            last(scoring::stage2(&r2)),
        ));
        s.keep(r1);
        s.keep(r2);
        done = i + 1;
        if i % 10 == 9 {
            let tail = &recent[recent.len().saturating_sub(20)..];
            let m = super::report::mean(tail);
            s.observer
                .message(&format!("combined error (last 20) {m:.2} px"));
        }
        if plan.snapshot_every > 0 && (i + 1) % plan.snapshot_every == 0 {
            s.observer.phase("snapshot");
            let resume = if !learning(i + 1) {
                Mode::Mature
            } else if (i as u32 + 1) < cfg.supervised_steps {
                Mode::Priming
            } else {
                Mode::Training
            };
            let n = plan.snapshot_targets.min(sets.targets.len());
            let g = plan.snapshot_grasps.min(sets.grasps.len());
            let held = (&sets.targets[..n], &sets.grasps[..g]);
            snapshot(s, held, plan, i + 1)?;
            s.runner.mode(resume)?;
            s.observer.phase("training");
        }
        let due = match &s.checkpoints {
            Some(c) => c.every > 0 && done.is_multiple_of(c.every) && done < planned,
            None => false,
        };
        if due {
            let state = s.state(done, planned);
            if let Some(c) = &mut s.checkpoints {
                (c.save)(s.runner, state)?;
            }
        }
    }
    s.log.end_of_training = Some(Box::new(s.state(done, planned)));
    Ok(())
}

/// The held-out evaluations (fixed budget, stop rule, the paper's protocol) and grasps.
fn evaluate<P>(s: &mut Session<P>, plan: Plan, sets: &HeldOutSets) -> Result<()>
where
    P: Can<Frame = CanFrame, Error = trn_protocol::Error> + ReceiveTimeout,
{
    s.runner.mode(Mode::Mature)?;
    s.observer.phase("eval");
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
        if s.stopping() {
            return Ok(());
        }
        s.run(&spec)?;
    }
    for _ in 0..plan.eval_targets {
        for kind in [
            TrialKind::Stage1 {
                supervised: false,
                learn: false,
            },
            TrialKind::Stage2 { learn: false },
        ] {
            if s.stopping() {
                return Ok(());
            }
            let rec = s.runner.run_trial(kind, Phase::VisitAndReturn)?;
            s.keep(rec);
        }
    }
    s.observer.phase("grasp");
    for h in &sets.grasps {
        if s.stopping() {
            return Ok(());
        }
        s.run(&TrialSpec {
            kind: TrialKind::Grasp { learn: false },
            phase: Phase::Grasping,
            source: Source::HeldOut(*h),
            fine_moves: FINE_MOVES_POLICY,
        })?;
    }
    Ok(())
}

/// A frozen evaluation after `trained` training trials per network: the held-out targets
/// with the fixed move budget and the held-out grasps with the stop rule, no learning, on a
/// copy of the plant (restored afterwards). An interrupt is kept for after it: a snapshot
/// is not cut short.
fn snapshot<P>(
    s: &mut Session<P>,
    (targets, grasps): (&[HeldOut], &[HeldOut]),
    plan: Plan,
    trained: usize,
) -> Result<()>
where
    P: Can<Frame = CanFrame, Error = trn_protocol::Error> + ReceiveTimeout,
{
    let saved = s.runner.rig().plant().clone();
    s.runner.mode(Mode::Mature)?;
    for h in targets {
        for kind in [
            TrialKind::Stage1 {
                supervised: false,
                learn: false,
            },
            TrialKind::Stage2 { learn: false },
        ] {
            s.run(&TrialSpec {
                kind,
                phase: Phase::Snapshot(trained),
                source: Source::HeldOut(*h),
                fine_moves: plan.fine_moves,
            })?;
        }
    }
    for h in grasps {
        s.run(&TrialSpec {
            kind: TrialKind::Grasp { learn: false },
            phase: Phase::SnapshotGrasp(trained),
            source: Source::HeldOut(*h),
            fine_moves: FINE_MOVES_POLICY,
        })?;
    }
    *s.runner.rig_mut().plant_mut() = saved;
    Ok(())
}
