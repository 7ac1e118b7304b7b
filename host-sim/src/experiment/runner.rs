//! The experiment runner: what to ask the controller next, in which order. It sets up each
//! trial on the plant (target, start pose), sends the target over the bus and collects the
//! trial's record from the rig's events until the controller reports or aborts.

use std::time::Duration;

use embedded_can::blocking::Can;
use rand_xoshiro::Xoshiro256PlusPlus;
use trn_node::codes;
use trn_protocol::bus::ReceiveTimeout;
use trn_protocol::{
    CanFrame, GraspRequest, Message, Mode, ModeChange, NodeId, Stage1Target, Stage2Target,
    SupervisedPressure, FINE_MOVES_POLICY,
};

use super::records::{Phase, TrialKind, TrialRecord};
use super::rig::{Event, Rig};
use super::targets::{self, HeldOut, Target};
use crate::error::Result;

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
    silence: Duration,
}

impl<P> Runner<P>
where
    P: Can<Frame = CanFrame, Error = trn_protocol::Error> + ReceiveTimeout,
{
    /// A runner on `rig`; `seed` drives the targets and start poses; a run fails when the
    /// controller sends nothing for `silence`.
    pub fn new(rig: Rig<P>, seed: u64, silence: Duration) -> Self {
        use rand_core::SeedableRng;
        Runner {
            rig,
            rng: Xoshiro256PlusPlus::seed_from_u64(seed ^ 0x5EED_7A26_E75E_55ED),
            trial: 0,
            silence,
        }
    }

    /// The rig.
    pub fn rig(&self) -> &Rig<P> {
        &self.rig
    }

    /// The rig, to copy and restore the plant around a frozen snapshot evaluation.
    pub fn rig_mut(&mut self) -> &mut Rig<P> {
        &mut self.rig
    }

    /// Announces a mode (`Priming`, `Training`, `Mature`).
    pub fn mode(&mut self, mode: Mode) -> Result<()> {
        self.rig
            .send(NodeId::Controller, ModeChange { mode }.into())
    }

    /// Tells the controller the session is over (`ModeChange{Idle}`).
    pub fn finish(&mut self) -> Result<()> {
        self.mode(Mode::Idle)
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
                let plant = self.rig.plant_mut();
                let target = targets::visit_and_return(plant, &mut self.rng, grasp)?;
                // "the robot arm went to a particular arbitrarily chosen position from where
                // it tried to reach the target" (Sec. 8.4.1); stage 2 keeps the wrist of the
                // target.
                let joints = if stage2 { 3 } else { 5 };
                plant.move_to_random_joints(&mut self.rng, joints);
                plant.settle();
                Ok(Some(target))
            }
            Source::HeldOut(h) => {
                let Ok(target) = h.realise(self.rig.plant(), kind.is_grasp()) else {
                    return Ok(None);
                };
                // the arm starts from a pose of its own; a stage-2 trial needs the target's
                // wrist (stage 2 moves joints 0..=2), which the arm reaches along its own
                // history
                let mut start = h.start;
                if stage2 {
                    start[3..].copy_from_slice(&h.pressures[3..]);
                }
                let plant = self.rig.plant_mut();
                plant.set_cylinder(target.cylinder);
                plant.command(&start);
                plant.settle();
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
            grasp: None,
        };
        let Some(target) = set_up else {
            return Ok(rec);
        };
        let ctrl = NodeId::Controller;
        let expect_reports = if kind.is_grasp() { 2 } else { 1 };
        match kind {
            TrialKind::Stage1 { supervised, learn } => {
                if supervised {
                    let p = target.pressures;
                    self.rig
                        .send(ctrl, SupervisedPressure { trial, p }.into())?;
                }
                let (grasp, v) = (false, target.v);
                self.rig.send(
                    ctrl,
                    Stage1Target {
                        trial,
                        learn,
                        grasp,
                        fine_moves,
                        v,
                    }
                    .into(),
                )?;
            }
            TrialKind::Stage2 { learn } => {
                let (grasp, c) = (false, target.c);
                self.rig.send(
                    ctrl,
                    Stage2Target {
                        trial,
                        learn,
                        grasp,
                        fine_moves,
                        c,
                    }
                    .into(),
                )?;
            }
            TrialKind::Grasp { learn } => {
                self.rig.send(ctrl, GraspRequest { trial }.into())?;
                let (grasp, v, c) = (true, target.v, target.c);
                self.rig.send(
                    ctrl,
                    Stage1Target {
                        trial,
                        learn,
                        grasp,
                        fine_moves,
                        v,
                    }
                    .into(),
                )?;
                self.rig.send(
                    ctrl,
                    Stage2Target {
                        trial,
                        learn,
                        grasp,
                        fine_moves,
                        c,
                    }
                    .into(),
                )?;
            }
        }
        let mut closed = false;
        loop {
            match self.rig.next_event(self.silence)? {
                Event::Captured(c) => rec.captures.push(*c),
                Event::Gripper(close) => {
                    closed = close;
                    if let (true, Some(cyl)) = (close, rec.target.cylinder.as_ref()) {
                        rec.grasp = Some(self.rig.plant().grasp_score(cyl));
                    }
                }
                Event::Controller(Message::TrialReport(r)) if r.trial == trial => {
                    rec.reports.push(r);
                }
                Event::Controller(Message::ErrorReport(e)) => {
                    rec.errors.push((e.code, e.detail));
                    if e.code == codes::TRIAL_ABORTED && e.detail == trial {
                        rec.aborted = true;
                        return Ok(rec);
                    }
                }
                Event::Controller(_) => {}
            }
            // a grasp ends when the gripper has closed after both reports
            if rec.reports.len() >= expect_reports && (closed || !kind.is_grasp()) {
                return Ok(rec);
            }
        }
    }
}
