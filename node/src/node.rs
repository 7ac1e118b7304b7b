//! The controller node's state machine: protocol messages in, controller calls, protocol
//! messages out.

use trn_controller::{
    Command, Controller, Error as CtrlError, FineMoves, ObserveKind, Outcome, Task,
};
use trn_protocol as proto;
use trn_protocol::{
    CanFrame, CaptureKind, CaptureRequest, Encoder, Envelope, ErrorReport, GripperCommand,
    Heartbeat, Joint, Message, Mode, NodeId, NodeState, PointStatus, PressureCommand, Reassembler,
    TrialReport,
};

use crate::codes;
use crate::config::NodeConfig;
use crate::outbox::{push, send, FrameError, Outbox};

/// Counters of what the node saw.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct NodeStats {
    /// Trials started.
    pub trials: u32,
    /// Trials aborted (invalid observations, timeouts, rejected inputs).
    pub aborted: u32,
    /// Observations ignored because their sequence number was not the awaited one (late,
    /// duplicated or foreign).
    pub stale_observations: u32,
    /// Capture requests repeated after a timeout.
    pub capture_retries: u32,
    /// Messages not meant for the controller, ignored.
    pub ignored: u32,
    /// Frames dropped by the reassembler (malformed, lost or corrupt segments).
    pub frame_errors: u32,
}

#[derive(Debug, Clone, Copy, PartialEq)]
struct Awaiting {
    seq: u16,
    what: CaptureKind,
    since_ms: u32,
    retries: u8,
}

#[derive(Debug, Clone, Copy, PartialEq)]
struct PendingGrasp {
    trial: u32,
    learn: bool,
    v: Option<[f32; 8]>,
}

/// The controller as a CAN node. It does not own the [`Controller`] (firmware keeps that in
/// a `static`); every call borrows it.
#[derive(Debug, Clone)]
pub struct ControllerNode {
    cfg: NodeConfig,
    seq: u16,
    trial: Option<u32>,
    awaiting: Option<Awaiting>,
    supervised: Option<(u32, [f32; 5])>,
    grasp: Option<PendingGrasp>,
    mode: Mode,
    heartbeat_due_ms: Option<u32>,
    heartbeat_counter: u8,
    idle_requested: bool,
    stats: NodeStats,
}

/// The controller's fine-move rule for a target's `fine_moves` field.
fn fine_moves(n: u8) -> FineMoves {
    if n == proto::FINE_MOVES_POLICY {
        FineMoves::Policy
    } else {
        FineMoves::Exactly(n)
    }
}

fn out_of_order(out: &mut Outbox, trial: u32) {
    let report = ErrorReport {
        code: codes::OUT_OF_ORDER,
        detail: trial,
    };
    push(out, NodeId::Controller, report.into());
}

impl ControllerNode {
    /// A node in mode `Idle`.
    pub const fn new(cfg: NodeConfig) -> Self {
        ControllerNode {
            cfg,
            seq: 0,
            trial: None,
            awaiting: None,
            supervised: None,
            grasp: None,
            mode: Mode::Idle,
            heartbeat_due_ms: None,
            heartbeat_counter: 0,
            idle_requested: false,
            stats: NodeStats {
                trials: 0,
                aborted: 0,
                stale_observations: 0,
                capture_retries: 0,
                ignored: 0,
                frame_errors: 0,
            },
        }
    }

    /// Counters.
    pub fn stats(&self) -> &NodeStats {
        &self.stats
    }

    pub(crate) fn count_frame_error(&mut self) {
        self.stats.frame_errors = self.stats.frame_errors.saturating_add(1);
    }

    /// The trial in progress, if any.
    pub fn trial(&self) -> Option<u32> {
        self.trial
    }

    /// Timers: heartbeats and the observation timeout.
    pub fn poll(&mut self, ctrl: &mut Controller, now_ms: u32, out: &mut Outbox) {
        let due = *self.heartbeat_due_ms.get_or_insert(now_ms);
        if now_ms.wrapping_sub(due) < u32::MAX / 2 {
            let state = NodeState::Operational;
            push(
                out,
                NodeId::Controller,
                Heartbeat {
                    counter: self.heartbeat_counter,
                    state,
                }
                .into(),
            );
            self.heartbeat_counter = self.heartbeat_counter.wrapping_add(1);
            self.heartbeat_due_ms = Some(now_ms.wrapping_add(self.cfg.heartbeat_period_ms));
        }
        if let Some(a) = self.awaiting {
            if now_ms.wrapping_sub(a.since_ms) >= self.cfg.observation_timeout_ms {
                if a.retries < self.cfg.capture_retries {
                    self.stats.capture_retries += 1;
                    self.awaiting = Some(Awaiting {
                        since_ms: now_ms,
                        retries: a.retries + 1,
                        ..a
                    });
                    push(
                        out,
                        NodeId::CameraProcessor,
                        CaptureRequest {
                            seq: a.seq,
                            what: a.what,
                        }
                        .into(),
                    );
                } else {
                    let report = ErrorReport {
                        code: codes::OBSERVATION_TIMEOUT,
                        detail: a.seq as u32,
                    };
                    push(out, NodeId::Controller, report.into());
                    self.abort(ctrl, out);
                }
            }
        }
    }

    /// Feeds one received frame through `rx`; a completed message is handled and every
    /// frame to send is passed to `tx`, encoded by `enc`. Frame errors (malformed, lost,
    /// corrupt segments) are returned after the frame is dropped.
    pub fn on_frame<const SLOTS: usize>(
        &mut self,
        ctrl: &mut Controller,
        rx: &mut Reassembler<SLOTS>,
        enc: &mut Encoder,
        frame: &CanFrame,
        now_ms: u32,
        tx: &mut impl FnMut(&CanFrame),
    ) -> Result<(), FrameError> {
        let env = rx.push(frame, now_ms)?;
        if let Some(env) = env {
            let mut out = Outbox::new();
            self.on_message(ctrl, &env, now_ms, &mut out);
            send(enc, &out, tx)?;
        }
        Ok(())
    }

    /// [`ControllerNode::poll`] with the output encoded and passed to `tx`.
    pub fn poll_frames(
        &mut self,
        ctrl: &mut Controller,
        enc: &mut Encoder,
        now_ms: u32,
        tx: &mut impl FnMut(&CanFrame),
    ) -> Result<(), FrameError> {
        let mut out = Outbox::new();
        self.poll(ctrl, now_ms, &mut out);
        send(enc, &out, tx)
    }

    /// Handles one received message.
    pub fn on_message(
        &mut self,
        ctrl: &mut Controller,
        env: &Envelope,
        now_ms: u32,
        out: &mut Outbox,
    ) {
        match (env.node, &env.msg) {
            (NodeId::CameraProcessor, Message::Observation(o)) => {
                self.on_observation(ctrl, o, now_ms, out)
            }
            (NodeId::Controller, Message::SupervisedPressure(s)) => {
                // supervised pressures belong to priming: ignored once training began
                if matches!(self.mode, Mode::Idle | Mode::Priming) {
                    self.supervised = Some((s.trial, s.p))
                } else {
                    self.stats.ignored += 1;
                }
            }
            (NodeId::Controller, Message::GraspRequest(g)) => {
                self.grasp = Some(PendingGrasp {
                    trial: g.trial,
                    learn: false,
                    v: None,
                })
            }
            (NodeId::Controller, Message::Stage1Target(t)) => {
                if t.grasp {
                    match self.grasp {
                        Some(g) if g.trial == t.trial => {
                            self.grasp = Some(PendingGrasp {
                                v: Some(t.v),
                                learn: self.learns(t.learn),
                                ..g
                            })
                        }
                        _ => out_of_order(out, t.trial),
                    }
                    return;
                }
                let supervised = match self.supervised.take() {
                    Some((trial, p)) if trial == t.trial => Some(p),
                    _ => None,
                };
                self.start(
                    ctrl,
                    t.trial,
                    Task::Stage1 {
                        v: t.v,
                        supervised,
                        learn: self.learns(t.learn),
                    },
                    fine_moves(t.fine_moves),
                    now_ms,
                    out,
                );
            }
            (NodeId::Controller, Message::Stage2Target(t)) => {
                if t.grasp {
                    match self.grasp.take() {
                        Some(PendingGrasp {
                            trial,
                            learn,
                            v: Some(v),
                        }) if trial == t.trial => {
                            let task = Task::Grasp { v, c: t.c, learn };
                            self.start(ctrl, trial, task, fine_moves(t.fine_moves), now_ms, out)
                        }
                        _ => out_of_order(out, t.trial),
                    }
                    return;
                }
                self.start(
                    ctrl,
                    t.trial,
                    Task::Stage2 {
                        c: t.c,
                        learn: self.learns(t.learn),
                    },
                    fine_moves(t.fine_moves),
                    now_ms,
                    out,
                );
            }
            (NodeId::Controller, Message::ModeChange(m)) => {
                self.mode = m.mode;
                self.idle_requested = m.mode == Mode::Idle;
            }
            (_, Message::Emergency(_)) => {
                if self.trial.is_some() {
                    self.abort(ctrl, out);
                }
            }
            _ => self.stats.ignored += 1,
        }
    }

    /// True after a `ModeChange{Idle}`: the runner has ended the session (a host process
    /// may save its checkpoint and exit).
    pub fn idle_requested(&self) -> bool {
        self.idle_requested
    }

    /// Whether a target that asks to `learn` may: never in `Mature` mode, where the tables
    /// are frozen whatever a target says.
    fn learns(&self, learn: bool) -> bool {
        learn && self.mode != Mode::Mature
    }

    /// The operating mode last set by a `ModeChange`.
    pub fn mode(&self) -> Mode {
        self.mode
    }

    fn start(
        &mut self,
        ctrl: &mut Controller,
        trial: u32,
        task: Task,
        fine: FineMoves,
        now_ms: u32,
        out: &mut Outbox,
    ) {
        if ctrl.busy() {
            // a new target pre-empts a trial that is still running (its runner gave up)
            ctrl.abort();
            self.stats.aborted += 1;
        }
        self.trial = Some(trial);
        self.awaiting = None;
        self.stats.trials += 1;
        match ctrl.begin_with(task, fine) {
            Ok(cmd) => self.execute(ctrl, cmd, now_ms, out),
            Err(e) => self.reject(ctrl, e, out),
        }
    }

    fn on_observation(
        &mut self,
        ctrl: &mut Controller,
        o: &proto::Observation,
        now_ms: u32,
        out: &mut Outbox,
    ) {
        let Some(a) = self.awaiting else {
            self.stats.stale_observations += 1;
            return;
        };
        if o.seq != a.seq || o.what != a.what {
            self.stats.stale_observations += 1;
            return;
        }
        let used = match a.what {
            CaptureKind::GripperLights => 4,
            CaptureKind::GripperCentre => 2,
        };
        for (i, p) in o.points[..used].iter().enumerate() {
            if p.status != PointStatus::Valid {
                let detail = ((i as u32) << 8) | p.status as u32;
                push(
                    out,
                    NodeId::Controller,
                    ErrorReport {
                        code: codes::INVALID_OBSERVATION,
                        detail,
                    }
                    .into(),
                );
                self.abort(ctrl, out);
                return;
            }
        }
        self.awaiting = None;
        let obs = match a.what {
            CaptureKind::GripperLights => {
                let mut v = [0.0; 8];
                for (i, p) in o.points.iter().enumerate() {
                    v[2 * i] = p.x;
                    v[2 * i + 1] = p.y;
                }
                trn_controller::Observation::Lights(v)
            }
            CaptureKind::GripperCentre => trn_controller::Observation::Centre([
                o.points[0].x,
                o.points[0].y,
                o.points[1].x,
                o.points[1].y,
            ]),
        };
        match ctrl.observe(obs) {
            Ok(cmd) => self.execute(ctrl, cmd, now_ms, out),
            Err(e) => self.reject(ctrl, e, out),
        }
    }

    fn execute(&mut self, _ctrl: &mut Controller, cmd: Command, now_ms: u32, out: &mut Outbox) {
        match cmd {
            Command::Move {
                pressures,
                joints,
                observe,
            } => {
                self.seq = self.seq.wrapping_add(1);
                for (j, joint) in Joint::ALL.iter().enumerate().take(joints as usize) {
                    // the controller clamps its pressures to [-1, 1] and never emits NaN
                    let raw = trn_protocol::pressure_to_raw(pressures[j]).unwrap_or(2048);
                    push(
                        out,
                        NodeId::Servo(*joint),
                        PressureCommand { seq: self.seq, raw }.into(),
                    );
                }
                let what = match observe {
                    ObserveKind::Lights => CaptureKind::GripperLights,
                    ObserveKind::Centre => CaptureKind::GripperCentre,
                };
                push(
                    out,
                    NodeId::CameraProcessor,
                    CaptureRequest {
                        seq: self.seq,
                        what,
                    }
                    .into(),
                );
                self.awaiting = Some(Awaiting {
                    seq: self.seq,
                    what,
                    since_ms: now_ms,
                    retries: 0,
                });
            }
            Command::Done(outcome) => self.finish(outcome, out),
        }
    }

    fn finish(&mut self, o: Outcome, out: &mut Outbox) {
        let trial = self.trial.take().unwrap_or(0);
        self.awaiting = None;
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
            push(out, NodeId::Gripper, GripperCommand { close: true }.into());
        }
    }

    fn reject(&mut self, ctrl: &mut Controller, e: CtrlError, out: &mut Outbox) {
        let detail = codes::controller_error_code(&e);
        push(
            out,
            NodeId::Controller,
            ErrorReport {
                code: codes::CONTROLLER_ERROR,
                detail,
            }
            .into(),
        );
        self.abort(ctrl, out);
    }

    /// Ends the trial in progress without a result: the runner sees `TRIAL_ABORTED` with
    /// the trial number, after the report of the reason.
    fn abort(&mut self, ctrl: &mut Controller, out: &mut Outbox) {
        ctrl.abort();
        let trial = self.trial.take().unwrap_or(0);
        push(
            out,
            NodeId::Controller,
            ErrorReport {
                code: codes::TRIAL_ABORTED,
                detail: trial,
            }
            .into(),
        );
        self.awaiting = None;
        self.stats.aborted += 1;
    }
}
