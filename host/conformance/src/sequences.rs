//! The session's trial sequences (SPEC 3, 3.1, 3.2): the configuration and its repeat, a
//! supervised pressure that no target took dropped by the next session's configuration,
//! priming with and without supervision, training trials of both stages with a fixed
//! number of fine moves and with the controller's own rule, a late duplicate of an older
//! trial, a trial pre-empted by a newer one, an invalid reading's abort and its repeat, a
//! grasp target out of order.

use embedded_can::blocking::Can;
use trn_node::codes;
use trn_protocol::bus::ReceiveTimeout;
use trn_protocol::{
    CanFrame, CaptureKind, Envelope, Message, Mode, PointStatus, SessionConfig, Stage1Target,
    SupervisedPressure,
};

use super::{nothing_moved, refused_start, stage1, stage2, Suite, STAGE1_JOINTS, STAGE2_JOINTS};
use trn_bench::journal::{errors, missing_error, move_problems, moves, reports};
use trn_bench::Result;

/// A supervised pressure sent before another session began, which no target took.
struct Stale {
    trial: u32,
    /// Its stage-1 target (lights p and q in both cameras).
    v: [f32; 8],
    problems: Vec<String>,
}

impl<P> Suite<'_, P>
where
    P: Can<Frame = CanFrame, Error = trn_protocol::Error> + ReceiveTimeout,
{
    pub(super) fn session(&mut self, session: SessionConfig) -> Result<()> {
        let stale = self.stale_supervision(session)?;
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
        self.stale_supervision_dropped(stale)
    }

    /// Before the suite's session: a `SupervisedPressure` that no target takes, then another
    /// session's configuration accepted (the suite's seed + 1), which drops it (SPEC 3.1).
    /// The trial it was for, its target and the problems so far; `None` for a version-3
    /// controller.
    fn stale_supervision(&mut self, session: SessionConfig) -> Result<Option<Stale>> {
        if self.v3 {
            return Ok(None);
        }
        // pressures and a target that need not be reachable: the target must start nothing,
        // and the arm is not moved for it (the suite's later targets are drawn as before)
        let trial = self.next_trial();
        let sup = SupervisedPressure {
            trial,
            p: [0.25, -0.25, 0.1, -0.1, 0.0],
        };
        self.send(sup.into())?;
        let (w, h) = (session.image_width as f32, session.image_height as f32);
        let v = [
            0.45 * w,
            0.5 * h,
            0.4 * w,
            0.5 * h,
            0.55 * w,
            0.5 * h,
            0.5 * w,
            0.5 * h,
        ];
        let other = SessionConfig {
            seed: session.seed.wrapping_add(1),
            ..session
        };
        let p = match self.runner.configure(other) {
            Ok(()) => vec![],
            Err(e) => vec![format!("another session's configuration: {e}")],
        };
        self.collect(|_| true, false)?;
        Ok(Some(Stale {
            trial,
            v,
            problems: p,
        }))
    }

    /// In the suite's session, `Priming`: the target of the trial whose supervised pressure
    /// the configuration dropped starts nothing (`MISSING_SUPERVISION`).
    fn stale_supervision_dropped(&mut self, stale: Option<Stale>) -> Result<()> {
        const NAME: &str = "A SupervisedPressure no target took is dropped by the next session's SessionConfig: that session's Stage1Target of its trial starts nothing (MISSING_SUPERVISION)";
        let Some(Stale {
            trial,
            v,
            problems: mut p,
        }) = stale
        else {
            self.skip(NAME, super::V4_ONLY);
            return Ok(());
        };
        let target = Stage1Target {
            trial,
            learn: true,
            grasp: false,
            fine_moves: 1,
            v,
        };
        self.send(target.into())?;
        let j = self.collect(Self::error_seen(codes::MISSING_SUPERVISION), true)?;
        p.extend(refused_start(
            &j,
            codes::MISSING_SUPERVISION,
            trial,
            "MISSING_SUPERVISION",
        ));
        self.verdict(NAME, p);
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

        // a late duplicate of an older trial (not the one that ended last) starts nothing
        const LATE: &str = "A late target of an older trial of the session (not the last ended) starts nothing: no move, no report";
        if self.v4_only(LATE) {
            // pre-emption is v3's behaviour too
            return self.preemption();
        }
        let t = self.target(false, 5)?;
        let older = trial - 2;
        self.send(stage1(older, &t, 1, false).into())?;
        let j = self.collect(|_| true, true)?;
        let mut p = nothing_moved(&j);
        if !reports(&j).is_empty() {
            p.push(format!("reports {:?}", reports(&j)));
        }
        self.verdict(LATE, p);
        self.preemption()
    }

    /// A newer trial's target while a trial is in progress pre-empts it at once (SPEC 3.1):
    /// the trial in progress (20 fixed fine moves) gets no report and no abort, the newer one
    /// runs to its own report. The newer target is sent as soon as the first move was seen.
    fn preemption(&mut self) -> Result<()> {
        let t = self.target(false, 5)?;
        let first = self.next_trial();
        self.send(stage1(first, &t, 20, false).into())?;
        let begun = |j: &[Envelope]| !moves(j).is_empty() || !errors(j).is_empty();
        let mut j = self.collect(begun, false)?;
        let mut p = Vec::new();
        if moves(&j).is_empty() {
            p.push(format!(
                "trial {first} made no move: errors {:?}",
                errors(&j)
            ));
        }
        let second = self.next_trial();
        self.send(stage1(second, &t, 1, false).into())?;
        j.extend(self.collect(Self::ended(second, 1), true)?);
        if reports(&j).iter().any(|r| r.trial == first) {
            p.push(format!(
                "trial {first} reported ({:?}): it ended before trial {second} came, or was not pre-empted",
                reports(&j)
            ));
        }
        match reports(&j).iter().filter(|r| r.trial == second).count() {
            1 => {}
            n => p.push(format!("{n} reports of trial {second}, expected one")),
        }
        if !errors(&j).is_empty() {
            p.push(format!("errors {:?}", errors(&j)));
        }
        self.verdict(
            "A newer trial's target mid-trial pre-empts the trial in progress: no report and no abort for it, the newer trial runs to its report",
            p,
        );
        Ok(())
    }

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
}
