//! A trial from its start to its end: repeats of a trial recognised, trials refused while a
//! session is required, the controller begun and fed observations, its commands sent, the
//! final messages kept to answer a repeat, and aborts.

use trn_controller::{Command, Control, Error as CtrlError, FineMoves, ObserveKind, Outcome, Task};
use trn_protocol as proto;
use trn_protocol::{CaptureKind, Mode, NodeId, PointStatus, TrialReport};

use super::tables::learned;
use super::{error, ControllerNode, FINAL};
use crate::codes;
use crate::exchange::Pending;
use crate::outbox::{push, Outbox};

impl ControllerNode {
    /// True (and handled) when `trial` is the trial in progress (ignored: it is being
    /// served), the trial that ended last (its final messages are sent again, once per repeat
    /// of its start: `completes` is true for the message that completes a start, a grasp's
    /// `Stage2Target` or another trial's target), or older than the newest trial of the
    /// session (a late duplicate: ignored).
    pub(super) fn repeated(&mut self, trial: u32, completes: bool, out: &mut Outbox) -> bool {
        if self.trial == Some(trial) {
            self.stats.repeated_targets += 1;
            return true;
        }
        if self.last_trial == Some(trial) {
            self.stats.repeated_targets += 1;
            if completes || !self.last_grasp {
                for env in &self.last_final {
                    push(out, env.node, env.msg);
                }
            }
            return true;
        }
        // the newest trial started is the one in progress, or else the one that ended last
        if let Some(newest) = self.trial.or(self.last_trial) {
            if newest.wrapping_sub(trial) < 1 << 31 {
                self.stats.ignored += 1;
                return true;
            }
        }
        false
    }

    /// A session begins or ends: no trial of it is remembered (a new session numbers its
    /// trials afresh), and a supervised pressure no target took is dropped (it belongs to
    /// the old session's trial of its number, not to the new session's).
    pub(super) fn forget_trials(&mut self) {
        self.supervised = None;
        if self.trial.is_none() {
            self.last_trial = None;
            self.last_final.clear();
        }
    }

    /// True (and reported with `out`) when trials are refused: the tables learned and no
    /// session is in force.
    pub(super) fn refuses_trial<C: Control + ?Sized>(
        &mut self,
        ctrl: &mut C,
        trial: u32,
        out: Option<&mut Outbox>,
    ) -> bool {
        if !(self.session_required && learned(ctrl)) || self.cfg.v3() {
            return false;
        }
        match out {
            Some(out) => error(out, codes::SESSION_REQUIRED, trial),
            None => self.stats.ignored += 1,
        }
        true
    }

    /// Whether a target that asks to `learn` may: never in `Mature` mode, where the tables
    /// are frozen whatever a target says.
    pub(super) fn learns(&self, learn: bool) -> bool {
        learn && self.mode != Mode::Mature
    }

    pub(super) fn start<C: Control + ?Sized>(
        &mut self,
        ctrl: &mut C,
        trial: u32,
        task: Task,
        fine: FineMoves,
        now_ms: u32,
        out: &mut Outbox,
    ) {
        if self.trial.is_none() && self.defers(trial, task, fine, now_ms) {
            return;
        }
        if ctrl.busy() {
            // a new target pre-empts a trial that is still running (its runner gave up)
            ctrl.abort();
            self.stats.aborted += 1;
        }
        let learns = match task {
            Task::Stage1 {
                learn, supervised, ..
            } => learn || supervised.is_some(),
            Task::Stage2 { learn, .. } | Task::Grasp { learn, .. } => learn,
        };
        if learns {
            // the tables change: a save in progress starts again after the trial
            self.tables_changed(ctrl, true);
        }
        self.trial = Some(trial);
        self.trial_learns = learns;
        self.last_grasp = matches!(task, Task::Grasp { .. });
        self.pending = Pending::None;
        self.stats.trials += 1;
        match ctrl.begin_with(task, fine) {
            Ok(cmd) => self.execute(cmd, now_ms, out),
            Err(e) => self.reject(ctrl, e, out),
        }
    }

    pub(super) fn on_observation<C: Control + ?Sized>(
        &mut self,
        ctrl: &mut C,
        o: &proto::Observation,
        now_ms: u32,
        out: &mut Outbox,
    ) {
        if !self.pending.takes_observation(o.seq, o.what) {
            self.stats.stale_answers += 1;
            return;
        }
        let used = match o.what {
            CaptureKind::GripperLights => 4,
            CaptureKind::GripperCentre => 2,
        };
        // an estimate (a light hidden from one camera, placed by the camera processor from
        // what it sees and the markers' last position) is good enough to move on with, not
        // to learn from: the tables would take its error for the arm's
        let usable = |s: PointStatus| {
            s == PointStatus::Valid || (s == PointStatus::Estimated && !self.trial_learns)
        };
        for (i, p) in o.points[..used].iter().enumerate() {
            if !usable(p.status) {
                let detail = ((i as u32) << 8) | p.status as u32;
                error(out, codes::INVALID_OBSERVATION, detail);
                self.abort(ctrl, out);
                return;
            }
        }
        if o.points[..used]
            .iter()
            .any(|p| p.status == PointStatus::Estimated)
        {
            self.stats.estimated = self.stats.estimated.saturating_add(1);
        }
        self.pending = Pending::None;
        match ctrl.observe(crate::exchange::reading(o)) {
            Ok(cmd) => self.execute(cmd, now_ms, out),
            Err(e) => self.reject(ctrl, e, out),
        }
    }

    fn execute(&mut self, cmd: Command, now_ms: u32, out: &mut Outbox) {
        match cmd {
            Command::Move {
                pressures,
                joints,
                observe,
            } => {
                self.seq = self.seq.wrapping_add(1);
                // the controller clamps its pressures to [-1, 1] and never emits NaN
                let raw = pressures.map(|p| proto::pressure_to_raw(p).unwrap_or(2048));
                let what = match observe {
                    ObserveKind::Lights => CaptureKind::GripperLights,
                    ObserveKind::Centre => CaptureKind::GripperCentre,
                };
                self.pending = Pending::start_move(out, self.seq, raw, joints, what, now_ms);
            }
            Command::Done(outcome) => self.finish(outcome, now_ms, out),
        }
    }

    /// Remembers the messages that end `trial`, to send them again if the runner repeats it.
    fn end_trial(&mut self, out: &Outbox, from: usize) {
        self.last_trial = self.trial.take();
        self.last_final.clear();
        for env in out.iter().skip(from).take(FINAL) {
            let _ = self.last_final.push(*env);
        }
    }

    fn finish(&mut self, o: Outcome, now_ms: u32, out: &mut Outbox) {
        let trial = self.trial.unwrap_or(0);
        let from = out.len();
        self.pending = Pending::None;
        for (stage, s) in [(1u8, o.stage1), (2u8, o.stage2)] {
            if let Some(s) = s {
                let stage = if stage == 1 && s.supervised { 0 } else { stage };
                let report = TrialReport {
                    trial,
                    stage,
                    coarse_error_px: s.coarse_error,
                    final_error_px: s.final_error,
                    fine_moves: s.fine_moves,
                    cap_hit: s.cap_hit,
                };
                push(out, NodeId::Controller, report.into());
            }
        }
        if o.close_gripper {
            self.pending = Pending::start_close(out, now_ms);
        }
        self.end_trial(out, from);
    }

    fn reject<C: Control + ?Sized>(&mut self, ctrl: &mut C, e: CtrlError, out: &mut Outbox) {
        error(
            out,
            codes::CONTROLLER_ERROR,
            codes::controller_error_code(&e),
        );
        self.abort(ctrl, out);
    }

    /// Ends the trial in progress without a result: the runner sees `TRIAL_ABORTED` with
    /// the trial number, after the report of the reason.
    pub(super) fn abort<C: Control + ?Sized>(&mut self, ctrl: &mut C, out: &mut Outbox) {
        ctrl.abort();
        let from = out.len().saturating_sub(1);
        let trial = self.trial.unwrap_or(0);
        error(out, codes::TRIAL_ABORTED, trial);
        self.pending = Pending::None;
        self.stats.aborted += 1;
        self.end_trial(out, from);
    }
}
