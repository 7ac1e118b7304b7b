//! The experiment runner: what to ask the controller next, in which order. It sets up each
//! trial on the plant (target, start pose), sends the target over the bus and collects the
//! trial's record from the rig's events until the controller reports or aborts.

use std::time::Duration;

use embedded_can::blocking::Can;
use rand_xoshiro::Xoshiro256PlusPlus;
use trn_node::codes;
use trn_protocol::bus::ReceiveTimeout;
use trn_protocol::{
    CanFrame, GraspRequest, Message, Mode, ModeChange, NodeId, SessionConfig, Stage1Target,
    Stage2Target, SupervisedPressure, FINE_MOVES_POLICY,
};

use super::records::{Phase, TrialKind, TrialRecord};
use super::rig::{Event, Rig};
use crate::error::{LabError as Error, Result};
use crate::patience::Patience;
pub use crate::report::RunnerStats;
use trn_plant::targets::{self, HeldOut, Target};

/// Where a trial's target comes from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Source {
    /// The paper's protocol: the arm visits random pressures, then moves away.
    VisitAndReturn,
    /// A deployment-style held-out target (realised on a twin of the plant).
    HeldOut(HeldOut),
}

/// One trial to run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrialSpec {
    /// What is asked.
    pub kind: TrialKind,
    /// The part of the run.
    pub phase: Phase,
    /// The target.
    pub source: Source,
    /// Fine moves: a fixed budget, or `FINE_MOVES_POLICY` (the controller's rule).
    pub fine_moves: u8,
}

/// The runner and the rig it drives.
pub struct Runner<P> {
    rig: Rig<P>,
    rng: Xoshiro256PlusPlus,
    trial: u32,
    timing: Timing,
    patience: Patience,
    stats: RunnerStats,
}

/// The runner's patience: how long it waits for a sign of the trial (or an acknowledgement)
/// before repeating its request, how often it repeats, and after how long without any frame
/// from the controller (heartbeats included) it declares the controller gone.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Timing {
    /// Wait for an answer before repeating.
    pub reply: Duration,
    /// Repeats before a trial is given up (recorded as failed).
    pub retries: u32,
    /// Silence of the controller that ends the run (`BusSilent`).
    pub silence: Duration,
    /// A controller heard within this is alive (its heartbeats come every 100 ms): a trial
    /// that gets no answer from a live controller is given up; from a silent one, the run
    /// waits for `silence` to end it.
    pub alive: Duration,
    /// The reply timeout is learned from the bus's round trips, `reply` its ceiling
    /// ([`Patience`]: a wall-clock bus); else it is `reply` (a simulated clock).
    pub adaptive: bool,
}

impl Timing {
    /// Timing with the given silence, repeats every `reply` up to 12 times, and the
    /// heartbeat supervision's 500 ms for "alive", `reply` fixed.
    pub const fn new(reply: Duration, silence: Duration) -> Timing {
        Timing {
            reply,
            retries: 12,
            silence,
            alive: Duration::from_millis(500),
            adaptive: false,
        }
    }
}

/// Why the controller did not acknowledge a mode or a session configuration.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Refused {
    /// `CONFIG_REJECTED` with its detail (SPEC 3.2).
    Config(u32),
    /// `GUARD_REFUSED` of a re-seed with its detail (`op << 8 | reason`, SPEC 3.4).
    Guard(u32),
    /// No acknowledgement after this many tries.
    Unanswered(u32),
}

impl Refused {
    /// What happened to `what`, in words a user can act on.
    pub fn describe(&self, what: &str) -> String {
        match *self {
            Refused::Config(d) => format!(
                "refused {what}: {}",
                match d {
                    codes::CONFIG_NOT_IDLE => "not idle (a session or a trial is in progress)",
                    codes::CONFIG_MISMATCH => {
                        "its tables were learned under another configuration (keep them with that configuration, or pass --reset-tables to erase them)"
                    }
                    codes::CONFIG_UNSUPPORTED => {
                        "it does not run this control law (choose another with --controller)"
                    }
                    _ => "invalid configuration",
                }
            ),
            Refused::Guard(d) => format!("refused {what}: {}", guard_refusal(d)),
            Refused::Unanswered(n) => format!("did not acknowledge {what} after {n} tries"),
        }
    }
}

/// A `GUARD_REFUSED` detail in words.
pub fn guard_refusal(detail: u32) -> String {
    let op = match detail >> 8 {
        1 => "re-seeding its tables",
        2 => "writing tables in",
        3 => "erasing its stored tables",
        _ => "an operation",
    };
    let why = match detail & 0xFF {
        1 => "it holds learned tables, and that needs a nonce it announced (pass --reset-tables to erase them, or keep them)",
        2 => "the nonce came after its window",
        3 => "the nonce was used before (a replay)",
        4 => "the nonce is not the one it issued (a repeat crossed it)",
        5 => "it cannot issue nonces (its generator was never seeded), so its learned tables cannot be replaced over the bus",
        _ => "for a reason this runner does not know",
    };
    format!("{op} was refused by its guard: {why}")
}

impl<P> Runner<P>
where
    P: Can<Frame = CanFrame, Error = trn_protocol::Error> + ReceiveTimeout,
{
    /// A runner on `rig`; the run's `seed` drives the targets and start poses (its
    /// [`crate::seeds::Seeds::runner`]).
    pub fn new(mut rig: Rig<P>, seed: u64, timing: Timing) -> Self {
        rig.heard_now();
        use rand_core::SeedableRng;
        Runner {
            rig,
            rng: Xoshiro256PlusPlus::seed_from_u64(crate::seeds::Seeds::of(seed).runner),
            trial: 0,
            timing,
            patience: if timing.adaptive {
                Patience::adaptive(timing.reply)
            } else {
                Patience::fixed(timing.reply)
            },
            stats: RunnerStats::default(),
        }
    }

    /// The runner's patience.
    pub fn timing(&self) -> Timing {
        self.timing
    }

    /// The reply timeout as learned so far (the tables' transfers wait by it too).
    pub fn patience(&self) -> &Patience {
        &self.patience
    }

    /// Ends the runner: its rig.
    pub fn into_rig(self) -> Rig<P> {
        self.rig
    }

    /// The rig.
    pub fn rig(&self) -> &Rig<P> {
        &self.rig
    }

    /// The rig, to copy and restore the plant around a frozen snapshot evaluation.
    pub fn rig_mut(&mut self) -> &mut Rig<P> {
        &mut self.rig
    }

    /// What the runner carries from trial to trial: the generator of the training targets
    /// and start poses, and the next trial number (for a simulator checkpoint).
    pub fn sequence(&self) -> (Xoshiro256PlusPlus, u32) {
        (self.rng.clone(), self.trial)
    }

    /// Continues the sequence of [`Runner::sequence`].
    pub fn continue_sequence(&mut self, (rng, trial): (Xoshiro256PlusPlus, u32)) {
        self.rng = rng;
        self.trial = trial;
    }

    /// Announces a mode (`Priming`, `Training`, `Mature`, `Idle`) and waits for the
    /// controller's acknowledgement (the echo to every node), repeating it when none comes.
    pub fn mode(&mut self, mode: Mode) -> Result<()> {
        let msg: Message = ModeChange { mode }.into();
        self.acknowledge(msg, msg)?
            .map_err(|r| Error::Controller(r.describe(&format!("mode {mode:?}"))))
    }

    /// Sends the session's run parameters (seed, preset, ablation, image size, bus mode;
    /// SPEC.md 3.2) and waits for the controller's acknowledgement. A controller that refuses
    /// them (`CONFIG_REJECTED`, `GUARD_REFUSED`) ends the run with its reason.
    pub fn configure(&mut self, session: SessionConfig) -> Result<()> {
        self.acknowledge(session.into(), session.into())?
            .map_err(|r| Error::Controller(r.describe("the session configuration")))
    }

    /// Sends `msg` to the controller until it echoes `echo` to `Broadcast` (a mode, a
    /// session configuration; for a `ConfirmedSessionConfig` the configuration it confirms),
    /// repeating it after each reply timeout. `Ok(Err(_))`: the controller refused it
    /// (`CONFIG_REJECTED`, `GUARD_REFUSED`, both for a session configuration only) or never
    /// answered; `Err`: the bus failed or went silent.
    pub fn acknowledge(
        &mut self,
        msg: Message,
        echo: Message,
    ) -> Result<std::result::Result<(), Refused>> {
        let config = matches!(
            msg,
            Message::SessionConfig(_) | Message::ConfirmedSessionConfig(_)
        );
        let first = self.rig.now();
        let mut repeats = 0;
        loop {
            self.rig.send(NodeId::Controller, msg)?;
            let since = self.rig.now();
            loop {
                let wait = self
                    .patience
                    .wait(repeats)
                    .saturating_sub(self.rig.now() - since);
                match self.rig.next_event(wait, self.timing.silence)? {
                    None => break,
                    Some(Event::Controller(m)) if m == echo => {
                        if repeats == 0 {
                            self.patience.answered(self.rig.now() - since);
                        }
                        return Ok(Ok(()));
                    }
                    Some(Event::Controller(Message::ErrorReport(e))) if config => match e.code {
                        codes::CONFIG_REJECTED => return Ok(Err(Refused::Config(e.detail))),
                        codes::GUARD_REFUSED if e.detail >> 8 == 1 => {
                            return Ok(Err(Refused::Guard(e.detail)))
                        }
                        _ => {}
                    },
                    Some(_) => {}
                }
            }
            // counted after every try that went unanswered, the last one too
            self.stats.mode_repeats += 1;
            let stalled = self.rig.now() - first;
            if self
                .patience
                .exhausted(repeats + 1, stalled, self.timing.retries + 1)
            {
                break;
            }
            repeats += 1;
        }
        Ok(Err(Refused::Unanswered(repeats + 1)))
    }

    /// Tells the controller the session is over (`ModeChange{Idle}`). A node that ended its
    /// loop at the first `Idle` cannot acknowledge a repeat when its echo was lost, so a
    /// missing acknowledgement is not an error here: the caller stops the controller's side
    /// anyway (the thread's stop flag, the process's exit or kill).
    pub fn finish(&mut self) -> Result<()> {
        match self.mode(Mode::Idle) {
            Err(Error::Controller(_)) => Ok(()),
            other => other,
        }
    }

    /// Runs one training trial (the paper's visit-then-return targets, the controller's
    /// rule for fine moves) to its end over the bus.
    pub fn run_trial(&mut self, kind: TrialKind, phase: Phase) -> Result<TrialRecord> {
        self.run(&TrialSpec {
            kind,
            phase,
            source: Source::VisitAndReturn,
            fine_moves: FINE_MOVES_POLICY,
        })
    }

    /// Sets up the plant for a trial: its target, the arm's start pose, the cylinder. `None`
    /// when a held-out target cannot be seen on this plant.
    fn set_up(&mut self, spec: &TrialSpec) -> Result<Option<Target>> {
        let kind = spec.kind;
        let stage2 = matches!(kind, TrialKind::Stage2 { .. });
        match &spec.source {
            Source::VisitAndReturn => {
                let grasp = kind.is_grasp();
                let mut plant = self.rig.plant_mut();
                let target = targets::visit_and_return(&mut plant, &mut self.rng, grasp)?;
                // "the robot arm went to a particular arbitrarily chosen position from where
                // it tried to reach the target" (Sec. 8.4.1); stage 2 keeps the wrist of the
                // target.
                let joints = if stage2 { 3 } else { 5 };
                plant.move_to_random_joints(&mut self.rng, joints);
                plant.settle();
                publish_start(&plant);
                Ok(Some(target))
            }
            Source::HeldOut(h) => {
                let realised = h.realise(&self.rig.plant(), kind.is_grasp());
                let Ok(target) = realised else {
                    return Ok(None);
                };
                // the arm starts from a pose of its own; a stage-2 trial needs the target's
                // wrist (stage 2 moves joints 0..=2), which the arm reaches along its own
                // history
                let mut start = h.start;
                if stage2 {
                    start[3..].copy_from_slice(&h.pressures[3..]);
                }
                let mut plant = self.rig.plant_mut();
                plant.set_cylinder(target.cylinder);
                plant.command(&start);
                plant.settle();
                publish_start(&plant);
                Ok(Some(target))
            }
        }
    }

    /// Runs one trial to its end over the bus.
    pub fn run(&mut self, spec: &TrialSpec) -> Result<TrialRecord> {
        self.trial += 1;
        let trial = self.trial;
        let (kind, phase, fine_moves) = (spec.kind, spec.phase, spec.fine_moves);
        let set_up = self.set_up(spec)?;
        self.rig.gripper_mut().open();
        let mut rec = TrialRecord {
            trial,
            kind,
            phase,
            fine_moves,
            target: set_up.unwrap_or(Target::NONE),
            target_seen: set_up.is_some(),
            captures: vec![],
            reports: vec![],
            errors: vec![],
            aborted: false,
            gave_up: false,
            grasp: None,
            started_s: self.rig.plant().time_s(),
        };
        let Some(target) = set_up else {
            return Ok(rec);
        };
        let start = start_messages(trial, spec, &target);
        self.send_all(&start)?;
        let expect_reports = if kind.is_grasp() { 2 } else { 1 };
        let mut closed = false;
        let mut since = self.rig.now();
        // the last sign of the trial, and the repeats since it
        let mut sign = since;
        let mut stalled = 0;
        let mut tries = 0;
        loop {
            let wait = self.patience.wait(stalled);
            let wait = wait.saturating_sub(self.rig.now() - since);
            let event = self.rig.next_event(wait, self.timing.silence)?;
            let Some(event) = event else {
                // no sign of the trial within the reply timeout: the target (or its final
                // report) was lost; the controller answers a repeat of the same trial
                let quiet = self.rig.now() - sign;
                if self.patience.exhausted(tries, quiet, self.timing.retries) {
                    if self.rig.since_heard() > self.timing.alive {
                        // not lost frames: the controller itself is silent; wait for it
                        // until the bus timeout ends the run (`BusSilent`)
                        since = self.rig.now();
                        continue;
                    }
                    rec.gave_up = true;
                    self.stats.given_up += 1;
                    return Ok(rec);
                }
                tries += 1;
                stalled += 1;
                self.stats.target_repeats += 1;
                self.send_all(&start)?;
                since = self.rig.now();
                continue;
            };
            match event {
                Event::Controller(Message::Heartbeat(_)) => continue, // alive, not an answer
                Event::Captured(c) => rec.captures.push(*c),
                Event::Gripper(close) => {
                    // A grasp is scored at the first close after the controller reported
                    // both halves of this trial (it sends the close right after them). A
                    // close before that belongs to an earlier grasp: the controller repeats
                    // a close until the gripper confirms it, and answers every repeat of a
                    // finished trial's start with its final messages again, so copies of
                    // that close can arrive after this trial began, at another pose. A
                    // close of this trial that overtook a lost report comes again with the
                    // report, when the start is repeated.
                    if close && !closed && rec.reports.len() >= expect_reports {
                        if let Some(cyl) = rec.target.cylinder.as_ref() {
                            rec.grasp = Some(self.rig.plant().grasp_score(cyl));
                        }
                        closed = true;
                    }
                }
                Event::Controller(Message::TrialReport(r)) if r.trial == trial => {
                    if !rec.reports.iter().any(|x| x.stage == r.stage) {
                        rec.reports.push(r);
                    }
                }
                Event::Controller(Message::ErrorReport(e)) => {
                    rec.errors.push((e.code, e.detail));
                    if e.code == codes::TRIAL_ABORTED && e.detail == trial {
                        rec.aborted = true;
                        let reason = rec.errors.iter().any(|(c, _)| codes::aborts_trial(*c));
                        if reason || tries >= self.timing.retries {
                            return Ok(rec);
                        }
                        // the reason (sent right before the abort) was lost: a repeat of the
                        // start is answered with both again
                        tries += 1;
                        stalled += 1;
                        self.stats.target_repeats += 1;
                        self.send_all(&start)?;
                        since = self.rig.now();
                        continue;
                    }
                    if e.code == codes::SESSION_REQUIRED && e.detail == trial {
                        // not a lost frame: the controller holds learned tables and no
                        // session is in force (it restarted, or another runner ended the
                        // session); repeating the trial cannot help
                        return Err(Error::Controller(format!(
                            "refuses trial {trial} (SESSION_REQUIRED): it holds learned tables and no session is in force (did it restart, or did another runner end the session?)"
                        )));
                    }
                    // a refusal (a lost half of the trial's start) is no progress: the
                    // start is repeated at the timeout
                    continue;
                }
                Event::Controller(_) => continue,
                Event::Progress => {}
            }
            let now = self.rig.now();
            if stalled == 0 {
                // a gap with no repeat in it: the bus's round trip and the controller's turn
                self.patience.answered(now - since);
            }
            (since, sign, stalled) = (now, now, 0);
            // a grasp ends when the gripper has closed after both reports
            if rec.reports.len() >= expect_reports && (closed || !kind.is_grasp()) {
                return Ok(rec);
            }
        }
    }

    fn send_all(&mut self, msgs: &[(NodeId, Message)]) -> Result<()> {
        msgs.iter().try_for_each(|(n, m)| self.rig.send(*n, *m))
    }

    /// Counters of repeats and give-ups.
    pub fn stats(&self) -> RunnerStats {
        self.stats
    }

    /// The counters, for the tables' requests ([`crate::tables`]).
    pub(crate) fn stats_mut(&mut self) -> &mut RunnerStats {
        &mut self.stats
    }
}

/// The messages that start a trial (sent again, the same, when no answer comes).
fn start_messages(trial: u32, spec: &TrialSpec, target: &Target) -> Vec<(NodeId, Message)> {
    let ctrl = NodeId::Controller;
    let fine_moves = spec.fine_moves;
    match spec.kind {
        TrialKind::Stage1 { supervised, learn } => {
            let mut m = vec![];
            if supervised {
                let p = target.pressures;
                m.push((ctrl, SupervisedPressure { trial, p }.into()));
            }
            let t = Stage1Target {
                trial,
                learn,
                grasp: false,
                fine_moves,
                v: target.v,
            };
            m.push((ctrl, t.into()));
            m
        }
        TrialKind::Stage2 { learn } => {
            let t = Stage2Target {
                trial,
                learn,
                grasp: false,
                fine_moves,
                c: target.c,
            };
            vec![(ctrl, t.into())]
        }
        TrialKind::Grasp { learn } => {
            let t1 = Stage1Target {
                trial,
                learn,
                grasp: true,
                fine_moves,
                v: target.v,
            };
            let t2 = Stage2Target {
                trial,
                learn,
                grasp: true,
                fine_moves,
                c: target.c,
            };
            vec![
                (ctrl, GraspRequest { trial }.into()),
                (ctrl, t1.into()),
                (ctrl, t2.into()),
            ]
        }
    }
}

/// Experiment (`StageConfig::loop_from_drives`): the pressures the drives hold now, for a
/// controller in this process that reads them ([`trn_controller::EXP_START`]).
fn publish_start(plant: &trn_plant::Plant) {
    for (slot, j) in trn_controller::EXP_START.iter().zip(plant.joints()) {
        slot.store(
            (j.commanded() as f32).to_bits(),
            std::sync::atomic::Ordering::Relaxed,
        );
    }
}
