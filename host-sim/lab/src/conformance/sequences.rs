//! The suite's sequences of `protocol/SPEC.md` 3 and 3.2, in the order the suite sends them:
//! the session's start, priming, training, aborts and refusals, and the mature mode (grasp,
//! frozen tables, a configuration refused). Each sends its messages through the [`Suite`]
//! and records one verdict per requirement.

use embedded_can::blocking::Can;
use trn_node::codes;
use trn_protocol::bus::ReceiveTimeout;
use trn_protocol::{
    CanFrame, CaptureKind, Envelope, GraspRequest, Message, Mode, PointStatus, SessionConfig,
    Stage1Target, Stage2Target, SupervisedPressure,
};

use super::journal::{gripper_commands, missing_error, move_problems, moves, reports, Move};
use super::{Suite, STAGE1_JOINTS, STAGE2_JOINTS};
use crate::error::Result;
use crate::targets::Target;

impl<P> Suite<'_, P>
where
    P: Can<Frame = CanFrame, Error = trn_protocol::Error> + ReceiveTimeout,
{
    /// The session's start: `SessionConfig` and its repeat acknowledged, then
    /// `ModeChange{Priming}`.
    pub(super) fn session(&mut self, session: SessionConfig) -> Result<()> {
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

    /// Priming: a target without its supervised pressure refused, a supervised trial, and
    /// the same target again answered with the same report.
    pub(super) fn priming(&mut self) -> Result<()> {
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

    /// Training: stage-1 and stage-2 trials with a fixed number of fine moves, and a stage-1
    /// trial with the controller's own stop rule.
    pub(super) fn training(&mut self) -> Result<()> {
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

    /// Aborts and refusals: an invalid light aborts the trial, its repeat is answered with
    /// the abort again, and a grasp's stage 2 alone is out of order.
    pub(super) fn abort(&mut self) -> Result<()> {
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

    /// Mature: a grasp (both stages, then the close), frozen tables, and a new configuration
    /// refused outside Idle.
    pub(super) fn mature(&mut self, session: SessionConfig) -> Result<()> {
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
