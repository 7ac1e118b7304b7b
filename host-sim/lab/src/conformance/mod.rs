//! The conformance suite (`trn conformance`): drives whatever controller is on the bus (the
//! project's node in process, `controller-node` on SocketCAN, the firmware over SLCAN, an
//! external board) through the sequences of `protocol/SPEC.md` 3 and 3.2 (session
//! configuration, priming, training, evaluation, grasp, abort, repeats, refusals) against
//! the simulated rig, and checks from the controller's messages alone that it does what the
//! specification says. Nothing of the controller's code is used: only the bus.

pub mod journal;

use std::time::Duration;

use embedded_can::blocking::Can;
use rand_core::SeedableRng;
use rand_xoshiro::Xoshiro256PlusPlus;
use trn_node::codes;
use trn_protocol::bus::ReceiveTimeout;
use trn_protocol::{
    CanFrame, CaptureKind, Envelope, GraspRequest, Message, Mode, NodeId, PointStatus,
    SessionConfig, Stage1Target, Stage2Target, SupervisedPressure,
};

use super::runner::Runner;
use super::targets::{self, Target};
use crate::error::{LabError, Result};
use journal::{
    errors, gripper_commands, has_error, heartbeat_problems, missing_error, move_problems, moves,
    reports,
};

/// One check of the suite and its verdict.
#[derive(Debug, Clone, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Check {
    /// What the specification requires.
    pub name: String,
    /// Whether the controller did it.
    pub passed: bool,
    /// What was seen when it did not.
    pub detail: String,
}

/// How long to wait: for an answer that must come, and for quiet after an answer (to see
/// that nothing else follows).
#[derive(Debug, Clone, Copy)]
pub struct Patience {
    /// The longest a sequence may take.
    pub answer: Duration,
    /// How long nothing more may happen after a refusal or a repeat's answer.
    pub quiet: Duration,
}

struct Suite<'a, P> {
    runner: &'a mut Runner<P>,
    rng: Xoshiro256PlusPlus,
    patience: Patience,
    checks: Vec<Check>,
    trial: u32,
    /// Everything received, for the session-wide checks (heartbeats).
    all: Vec<Envelope>,
}

const STAGE1_JOINTS: [u8; 5] = [0, 1, 2, 3, 4];
const STAGE2_JOINTS: [u8; 3] = [0, 1, 2];

/// Runs the suite; `session` is the configuration it sends first.
pub fn run<P>(
    runner: &mut Runner<P>,
    session: SessionConfig,
    patience: Patience,
) -> Result<Vec<Check>>
where
    P: Can<Frame = CanFrame, Error = trn_protocol::Error> + ReceiveTimeout,
{
    runner.rig_mut().start_journal();
    let mut s = Suite {
        runner,
        rng: Xoshiro256PlusPlus::seed_from_u64(session.seed ^ 0xC0F0_12AA),
        patience,
        checks: Vec::new(),
        trial: 1000,
        all: Vec::new(),
    };
    s.session(session)?;
    s.priming()?;
    s.training()?;
    s.abort()?;
    s.mature(session)?;
    let problems = heartbeat_problems(&s.all);
    s.verdict("heartbeats: Operational, counter +1 each", problems);
    let idle = s.runner.mode(Mode::Idle);
    s.verdict(
        "ModeChange{Idle} is acknowledged (echo to Broadcast)",
        idle.err().map(|e| e.to_string()).into_iter().collect(),
    );
    Ok(s.checks)
}

impl<P> Suite<'_, P>
where
    P: Can<Frame = CanFrame, Error = trn_protocol::Error> + ReceiveTimeout,
{
    fn verdict(&mut self, name: &str, problems: Vec<String>) {
        self.checks.push(Check {
            name: name.to_string(),
            passed: problems.is_empty(),
            detail: problems.join("; "),
        });
    }

    /// Ends the suite when the controller has sent nothing but heartbeats for a whole
    /// sequence's patience since the suite began: a controller that answers nothing would
    /// otherwise cost every check its full patience.
    fn answered_nothing(&self) -> Result<()> {
        // the journal holds what the controller sent (the rig's own frames do not come back)
        let answers = |j: &[Envelope]| j.iter().any(|e| !matches!(e.msg, Message::Heartbeat(_)));
        if answers(&self.all) || answers(self.runner.rig().journal()) {
            return Ok(());
        }
        Err(LabError::Controller(format!(
            "sent only heartbeats for {:.1} s: it answered no request of the conformance suite",
            self.patience.answer.as_secs_f64()
        )))
    }

    fn next_trial(&mut self) -> u32 {
        self.trial += 1;
        self.trial
    }

    fn send(&mut self, msg: Message) -> Result<()> {
        self.runner.rig_mut().send(NodeId::Controller, msg)
    }

    /// Serves the bus until `done` holds for what came since the journal was last taken
    /// (or the patience ran out), then for `quiet` more; returns what came.
    fn collect(
        &mut self,
        done: impl Fn(&[Envelope]) -> bool,
        quiet: bool,
    ) -> Result<Vec<Envelope>> {
        let silence = self.runner.timing().silence;
        let deadline = self.runner.rig().now() + self.patience.answer;
        while !done(self.runner.rig().journal()) {
            let left = deadline.saturating_sub(self.runner.rig().now());
            if left.is_zero() {
                self.answered_nothing()?;
                break;
            }
            self.runner.rig_mut().next_event(left, silence)?;
        }
        if quiet {
            let until = self.runner.rig().now() + self.patience.quiet;
            loop {
                let left = until.saturating_sub(self.runner.rig().now());
                if left.is_zero() {
                    break;
                }
                self.runner.rig_mut().next_event(left, silence)?;
            }
        }
        let j = self.runner.rig_mut().take_journal();
        self.all.extend_from_slice(&j);
        Ok(j)
    }

    /// A target of the paper's kind (the arm visits random pressures), then the arm goes to
    /// a random start pose (all joints, or the first three for stage 2).
    fn target(&mut self, grasp: bool, joints: usize) -> Result<Target> {
        let mut plant = self.runner.rig_mut().plant_mut();
        let t = targets::visit_and_return(&mut plant, &mut self.rng, grasp)?;
        plant.move_to_random_joints(&mut self.rng, joints);
        plant.settle();
        Ok(t)
    }

    fn ended(trial: u32, stages: usize) -> impl Fn(&[Envelope]) -> bool {
        move |j: &[Envelope]| {
            reports(j).iter().filter(|r| r.trial == trial).count() >= stages
                || has_error(j, codes::TRIAL_ABORTED, trial)
        }
    }

    fn error_seen(code: u16) -> impl Fn(&[Envelope]) -> bool {
        move |j: &[Envelope]| errors(j).iter().any(|e| e.code == code)
    }

    fn session(&mut self, session: SessionConfig) -> Result<()> {
        let first = self.runner.configure(session);
        let repeat = self.runner.configure(session);
        self.collect(|_| true, false)?;
        self.verdict(
            "SessionConfig is acknowledged (echo to Broadcast), and so is its repeat",
            [first, repeat]
                .into_iter()
                .filter_map(|r| r.err().map(|e| e.to_string()))
                .collect(),
        );
        let mode = self.runner.mode(Mode::Priming);
        self.collect(|_| true, false)?;
        self.verdict(
            "ModeChange{Priming} is acknowledged (echo to Broadcast)",
            mode.err().map(|e| e.to_string()).into_iter().collect(),
        );
        Ok(())
    }

    /// A trial's problems: how it ended, its moves (joints, captures, `seq`), the number of
    /// fine moves and its report.
    fn trial_problems(
        j: &[Envelope],
        trial: u32,
        stage: u8,
        fine: u8,
        joints: &[u8],
        what: CaptureKind,
    ) -> Vec<String> {
        let m = moves(j);
        let mut p = move_problems(&m, joints, what);
        if m.len() != 1 + fine as usize {
            p.push(format!(
                "{} moves, expected the coarse move and {fine} fine",
                m.len()
            ));
        }
        match reports(j).as_slice() {
            [r] if r.trial == trial && r.stage == stage && r.fine_moves == fine => {}
            other => p.push(format!(
                "reports {other:?}, expected one TrialReport{{trial: {trial}, stage: {stage}, fine_moves: {fine}}}"
            )),
        }
        if !errors(j).is_empty() {
            p.push(format!("errors {:?}", errors(j)));
        }
        p
    }

    fn priming(&mut self) -> Result<()> {
        // a priming target without its supervised pressure starts nothing
        let t = self.target(false, 5)?;
        let trial = self.next_trial();
        self.send(stage1(trial, &t, 1, false).into())?;
        let j = self.collect(Self::error_seen(codes::MISSING_SUPERVISION), true)?;
        let mut p = nothing_moved(&j);
        p.extend(missing_error(
            &j,
            codes::MISSING_SUPERVISION,
            trial,
            "MISSING_SUPERVISION",
        ));
        self.verdict(
            "Priming: a Stage1Target without its SupervisedPressure starts nothing (MISSING_SUPERVISION)",
            p,
        );

        // a supervised priming trial: moves, reports stage 0
        let t = self.target(false, 5)?;
        let trial = self.next_trial();
        let sup = SupervisedPressure {
            trial,
            p: t.pressures,
        };
        self.send(sup.into())?;
        self.send(stage1(trial, &t, 1, false).into())?;
        let j = self.collect(Self::ended(trial, 1), false)?;
        let p = Self::trial_problems(&j, trial, 0, 1, &STAGE1_JOINTS, CaptureKind::GripperLights);
        self.verdict(
            "Priming trial: SupervisedPressure + Stage1Target{fine_moves: 1}: 2 moves of all five joints, TrialReport{stage: 0}",
            p,
        );
        let report = reports(&j).first().copied();

        // the same target again: the same report, no move
        self.send(sup.into())?;
        self.send(stage1(trial, &t, 1, false).into())?;
        let j = self.collect(Self::ended(trial, 1), true)?;
        let mut p = nothing_moved(&j);
        if reports(&j).first().copied() != report || report.is_none() {
            p.push(format!(
                "reports {:?}, expected {report:?} again",
                reports(&j)
            ));
        }
        self.verdict(
            "A repeated target of the trial that ended last is answered with the same report, without moving",
            p,
        );
        Ok(())
    }

    fn training(&mut self) -> Result<()> {
        let mode = self.runner.mode(Mode::Training);
        self.collect(|_| true, false)?;
        self.verdict(
            "ModeChange{Training} is acknowledged",
            mode.err().map(|e| e.to_string()).into_iter().collect(),
        );
        let t = self.target(false, 5)?;
        let trial = self.next_trial();
        self.send(stage1(trial, &t, 2, false).into())?;
        let j = self.collect(Self::ended(trial, 1), false)?;
        let p = Self::trial_problems(&j, trial, 1, 2, &STAGE1_JOINTS, CaptureKind::GripperLights);
        self.verdict(
            "Stage-1 trial with fine_moves: 2: exactly 3 moves of all five joints, one seq per move, TrialReport{stage: 1, fine_moves: 2}",
            p,
        );

        let t = self.target(false, 3)?;
        let trial = self.next_trial();
        self.send(stage2(trial, &t, 1, false).into())?;
        let j = self.collect(Self::ended(trial, 1), false)?;
        let p = Self::trial_problems(&j, trial, 2, 1, &STAGE2_JOINTS, CaptureKind::GripperCentre);
        self.verdict(
            "Stage-2 trial with fine_moves: 1: 2 moves of joints 0..=2 only (the wrist holds), centre captures, TrialReport{stage: 2}",
            p,
        );

        let t = self.target(false, 5)?;
        let trial = self.next_trial();
        self.send(stage1(trial, &t, trn_protocol::FINE_MOVES_POLICY, false).into())?;
        let j = self.collect(Self::ended(trial, 1), false)?;
        let m = moves(&j);
        let mut p = move_problems(&m, &STAGE1_JOINTS, CaptureKind::GripperLights);
        match reports(&j).as_slice() {
            [r] if r.trial == trial && r.stage == 1 && r.fine_moves as usize + 1 == m.len() => {}
            other => p.push(format!(
                "reports {other:?} after {} moves: fine_moves must count the moves after the coarse one",
                m.len()
            )),
        }
        self.verdict(
            "Stage-1 trial with the controller's own stop rule (fine_moves: 255): the report counts the moves made",
            p,
        );
        Ok(())
    }

    fn abort(&mut self) -> Result<()> {
        let t = self.target(false, 5)?;
        let trial = self.next_trial();
        self.runner
            .rig_mut()
            .camera_mut()
            .spoil_next(1, PointStatus::Occluded);
        let msg: Message = stage1(trial, &t, 2, false).into();
        self.send(msg)?;
        let j = self.collect(Self::ended(trial, 1), true)?;
        let mut p = Vec::new();
        let detail = (1 << 8) | PointStatus::Occluded as u32;
        p.extend(missing_error(
            &j,
            codes::INVALID_OBSERVATION,
            detail,
            "INVALID_OBSERVATION",
        ));
        p.extend(missing_error(
            &j,
            codes::TRIAL_ABORTED,
            trial,
            "TRIAL_ABORTED",
        ));
        if moves(&j).len() != 1 || !reports(&j).is_empty() {
            p.push(format!(
                "{} moves and reports {:?}: the trial ends at the invalid reading",
                moves(&j).len(),
                reports(&j)
            ));
        }
        self.verdict(
            "An invalid light (Occluded) aborts the trial: INVALID_OBSERVATION, TRIAL_ABORTED, no further move, no report",
            p,
        );

        self.send(msg)?;
        let j = self.collect(Self::ended(trial, 1), true)?;
        let mut p = nothing_moved(&j);
        p.extend(missing_error(
            &j,
            codes::TRIAL_ABORTED,
            trial,
            "TRIAL_ABORTED again",
        ));
        self.verdict(
            "A repeated target of an aborted trial is answered with the abort again, without moving",
            p,
        );

        let t = self.target(true, 5)?;
        let trial = self.next_trial();
        self.send(stage2(trial, &t, 1, true).into())?;
        let j = self.collect(Self::error_seen(codes::OUT_OF_ORDER), true)?;
        let mut p = nothing_moved(&j);
        p.extend(missing_error(
            &j,
            codes::OUT_OF_ORDER,
            trial,
            "OUT_OF_ORDER",
        ));
        self.verdict(
            "A grasp's Stage2Target without its GraspRequest and Stage1Target starts nothing (OUT_OF_ORDER)",
            p,
        );
        Ok(())
    }

    fn mature(&mut self, session: SessionConfig) -> Result<()> {
        let mode = self.runner.mode(Mode::Mature);
        self.collect(|_| true, false)?;
        self.verdict(
            "ModeChange{Mature} is acknowledged",
            mode.err().map(|e| e.to_string()).into_iter().collect(),
        );

        // a grasp: stage 1, stage 2 from where it ended, both reports, then the close
        let t = self.target(true, 5)?;
        let trial = self.next_trial();
        self.runner.rig_mut().gripper_mut().open();
        self.send(GraspRequest { trial }.into())?;
        self.send(stage1(trial, &t, 1, true).into())?;
        self.send(stage2(trial, &t, 1, true).into())?;
        let closed = |j: &[Envelope]| !gripper_commands(j).is_empty();
        let j = self.collect(closed, false)?;
        let m = moves(&j);
        let (lights, centre): (Vec<_>, Vec<_>) = m
            .iter()
            .cloned()
            .partition(|m| m.what == CaptureKind::GripperLights);
        let mut p = move_problems(&lights, &STAGE1_JOINTS, CaptureKind::GripperLights);
        p.extend(move_problems(
            &centre,
            &STAGE2_JOINTS,
            CaptureKind::GripperCentre,
        ));
        if m.iter().position(|m| m.what == CaptureKind::GripperCentre)
            < m.iter().rposition(|m| m.what == CaptureKind::GripperLights)
        {
            p.push("a stage-2 move before the end of stage 1".into());
        }
        if (lights.len(), centre.len()) != (2, 2) {
            p.push(format!(
                "{} stage-1 and {} stage-2 moves, expected 2 and 2 (both stages use the Stage2Target's fine_moves: 1)",
                lights.len(),
                centre.len()
            ));
        }
        let stages: Vec<u8> = reports(&j).iter().map(|r| r.stage).collect();
        if stages != [1, 2] || reports(&j).iter().any(|r| r.trial != trial) {
            p.push(format!(
                "reports {:?}, expected stage 1 then stage 2",
                reports(&j)
            ));
        }
        let last_report = j
            .iter()
            .rposition(|e| matches!(e.msg, Message::TrialReport(_)));
        match gripper_commands(&j).first() {
            Some(&(i, true)) if last_report.is_some_and(|r| r < i) => {}
            other => p.push(format!(
                "gripper command {other:?}: GripperCommand{{close: true}} after both reports"
            )),
        }
        self.verdict(
            "Grasp: GraspRequest, Stage1Target{grasp}, Stage2Target{grasp}: stage-1 moves, then stage-2 moves, TrialReport stage 1 and 2, then GripperCommand{close}",
            p,
        );

        // in Mature the tables are frozen: the same target from the same start pose gives the
        // same commands, whatever `learn` says (one move each: a fine move would depend on
        // the cameras' noise)
        let t = self.target(false, 5)?;
        let start = self.runner.rig().plant().random_pressures(&mut self.rng);
        let mut runs = Vec::new();
        for _ in 0..2 {
            {
                let mut plant = self.runner.rig_mut().plant_mut();
                plant.command(&start);
                plant.settle();
            }
            let trial = self.next_trial();
            let mut msg = stage1(trial, &t, 0, false);
            msg.learn = true;
            self.send(msg.into())?;
            let j = self.collect(Self::ended(trial, 1), false)?;
            runs.push(moves(&j).iter().map(Move::raws).collect::<Vec<_>>());
        }
        let mut p = Vec::new();
        if runs[0].is_empty() || runs[0] != runs[1] {
            p.push(format!("first run {:?}, second {:?}", runs[0], runs[1]));
        }
        self.verdict(
            "Mature: a target with learn: true learns nothing (the same target, fine_moves: 0, from the same start pose is commanded the same way twice)",
            p,
        );

        // a new configuration outside Idle is refused, nothing changes
        let other = SessionConfig {
            seed: session.seed.wrapping_add(1),
            ..session
        };
        self.send(other.into())?;
        let j = self.collect(Self::error_seen(codes::CONFIG_REJECTED), true)?;
        let mut p: Vec<String> = missing_error(
            &j,
            codes::CONFIG_REJECTED,
            codes::CONFIG_NOT_IDLE,
            "CONFIG_REJECTED (not idle)",
        )
        .into_iter()
        .collect();
        if j.iter().any(|e| matches!(e.msg, Message::SessionConfig(_))) {
            p.push("the new configuration was acknowledged".into());
        }
        self.verdict(
            "A SessionConfig outside Idle is refused (CONFIG_REJECTED, detail 1) and not acknowledged",
            p,
        );
        Ok(())
    }
}

use journal::Move;

/// Problems if the controller moved or reported.
fn nothing_moved(j: &[Envelope]) -> Vec<String> {
    let mut p = Vec::new();
    if !moves(j).is_empty()
        || j.iter().any(|e| {
            matches!(
                e.msg,
                Message::PressureCommand(_) | Message::CaptureRequest(_)
            )
        })
    {
        p.push("the controller moved".to_string());
    }
    p
}

fn stage1(trial: u32, t: &Target, fine_moves: u8, grasp: bool) -> Stage1Target {
    Stage1Target {
        trial,
        learn: !grasp,
        grasp,
        fine_moves,
        v: t.v,
    }
}

fn stage2(trial: u32, t: &Target, fine_moves: u8, grasp: bool) -> Stage2Target {
    Stage2Target {
        trial,
        learn: !grasp,
        grasp,
        fine_moves,
        c: t.c,
    }
}
