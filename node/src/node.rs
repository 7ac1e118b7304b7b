//! The controller node's state machine: protocol messages in, controller calls, protocol
//! messages out. Every request it makes is repeated until answered ([`crate::exchange`]);
//! every target may arrive more than once (the runner repeats it when no answer came), and a
//! repeat of the trial in progress is ignored, a repeat of the trial just ended is answered
//! with the same final messages again.
//!
//! Its parts are `impl ControllerNode` blocks in the modules below it: a session's
//! configuration (`session.rs`), a trial (`trial.rs`), the tables over the bus and in their
//! store (`tables.rs`, which also keeps the state of their saves and transfers).

use trn_controller::{Control, FineMoves, Task};
use trn_protocol as proto;
use trn_protocol::{
    BusMode, CanFrame, Encoder, Envelope, ErrorReport, GuardNonce, Heartbeat, Message, Mode,
    ModeChange, NodeId, NodeState, Reassembler, SessionConfig,
};

use crate::codes;
use crate::config::NodeConfig;
use crate::exchange::{GaveUp, Pending, ServoAnswer};
use crate::guard::{op_code, Guard};
use crate::health::{BusAction, BusCounters, BusHealth, BusReading};
use crate::outbox::{push, send, FrameError, Outbox};
pub use crate::stats::NodeStats;

mod session;
mod tables;
mod trial;

use tables::{learned, TableState};

#[derive(Debug, Clone, Copy, PartialEq)]
struct PendingGrasp {
    trial: u32,
    learn: bool,
    v: Option<[f32; 8]>,
}

/// A trial's start that waits for a save to end (`NodeConfig::save_hold_ms`).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Deferred {
    trial: u32,
    task: Task,
    fine: FineMoves,
    since_ms: u32,
}

/// Capacity of the cache of a trial's final messages (two reports, a gripper command, or an
/// error and the abort).
const FINAL: usize = 4;

/// The controller as a CAN node. It does not own the controller (any [`Control`]; firmware
/// keeps the project's `trn_controller::Controller` in
/// a `static`); every call borrows it.
#[derive(Debug, Clone)]
pub struct ControllerNode {
    pub(crate) cfg: NodeConfig,
    seq: u16,
    pub(crate) trial: Option<u32>,
    /// Whether the trial in progress updates the tables (it may not use estimated points).
    pub(crate) trial_learns: bool,
    pending: Pending,
    supervised: Option<(u32, [f32; 5])>,
    grasp: Option<PendingGrasp>,
    pub(crate) mode: Mode,
    heartbeat_due_ms: Option<u32>,
    heartbeat_counter: u8,
    /// The reset cause to announce at the next poll, before the first heartbeat.
    reset_report: Option<ErrorReport>,
    idle_requested: bool,
    /// The session configuration in force (the last one accepted; none after `Idle`).
    pub(crate) session: Option<SessionConfig>,
    /// Trials are refused (`SESSION_REQUIRED`) while the tables learned and no session is in
    /// force: at boot with restored tables, after `Idle`, after a refused `SessionConfig`.
    pub(crate) session_required: bool,
    /// A bus mode the encoder must switch to before the next frame is sent.
    bus_mode: Option<BusMode>,
    /// The last trial that ended, whether it was a grasp, and the messages that ended it.
    last_trial: Option<u32>,
    last_grasp: bool,
    last_final: heapless::Vec<Envelope, FINAL>,
    /// The guard of destructive operations.
    pub(crate) guard: Guard,
    /// The tables' provenance, store and transfers.
    pub(crate) tables: TableState,
    /// A trial's start waiting for the save in progress.
    deferred: Option<Deferred>,
    pub(crate) stats: NodeStats,
}

/// The controller's fine-move rule for a target's `fine_moves` field.
fn fine_moves(n: u8) -> FineMoves {
    if n == proto::FINE_MOVES_POLICY {
        FineMoves::Policy
    } else {
        FineMoves::Exactly(n)
    }
}

pub(crate) fn error(out: &mut Outbox, code: u16, detail: u32) {
    push(out, NodeId::Controller, ErrorReport { code, detail }.into());
}

impl ControllerNode {
    /// A node in mode `Idle`.
    pub const fn new(cfg: NodeConfig) -> Self {
        ControllerNode {
            cfg,
            seq: 0,
            trial: None,
            trial_learns: false,
            pending: Pending::None,
            supervised: None,
            grasp: None,
            mode: Mode::Idle,
            heartbeat_due_ms: None,
            heartbeat_counter: 0,
            reset_report: None,
            idle_requested: false,
            session: None,
            session_required: false,
            bus_mode: None,
            last_trial: None,
            last_grasp: false,
            last_final: heapless::Vec::new(),
            guard: Guard::new(),
            tables: TableState::new(),
            deferred: None,
            stats: NodeStats {
                trials: 0,
                aborted: 0,
                stale_answers: 0,
                retries: 0,
                corrected_commands: 0,
                repeated_targets: 0,
                ignored: 0,
                frame_errors: 0,
                estimated: 0,
                bus: BusCounters::ZERO,
            },
        }
    }

    /// Seeds the generator of the guard's nonces, at boot, from a source the bus cannot
    /// predict (the MCU's RNG; on a host, OS entropy or a seeded generator). Until then the
    /// node issues no nonce: destructive operations on tables that learned are refused
    /// (`GUARD_REFUSED`, reason 5), whatever a replay carries.
    pub fn seed_guard(&mut self, seed: [u8; 16]) {
        self.guard.seed(seed);
    }

    /// True while trials are refused until a session is configured (`SESSION_REQUIRED`).
    pub fn session_required(&self) -> bool {
        self.session_required
    }

    /// Counters.
    pub fn stats(&self) -> &NodeStats {
        &self.stats
    }

    /// Takes a board's reading of its CAN controller (a turn's, before
    /// [`ControllerNode::service`]) into the policy's state `health` (the board's, one for
    /// the node's life): the counters of [`NodeStats::bus`] updated, the health
    /// reports pushed into `out` when due (`BUS_STATE` and `BUS_COUNTS`, protocol/SPEC.md
    /// section 7), and what the board must do: [`BusAction::Restart`] once a bus-off's
    /// hold-off has passed (`health.rs` has the policy). While the reading says bus-off, the
    /// board drops what the node sends.
    pub fn bus_health(
        &mut self,
        health: &mut BusHealth,
        reading: &BusReading,
        now_ms: u32,
        out: &mut Outbox,
    ) -> BusAction {
        let action = health.update(&mut self.stats.bus, reading, now_ms);
        health.report(&mut self.stats.bus, now_ms, out);
        action
    }

    /// [`ControllerNode::bus_health`] with the reports encoded and passed to `tx` (a board's
    /// loop calls this; its outbox lives only in this call's frame).
    #[inline(never)]
    pub fn bus_health_frames(
        &mut self,
        health: &mut BusHealth,
        reading: &BusReading,
        enc: &mut Encoder,
        now_ms: u32,
        tx: &mut impl FnMut(&CanFrame),
    ) -> Result<BusAction, FrameError> {
        let mut out = Outbox::new();
        let action = self.bus_health(health, reading, now_ms, &mut out);
        send(enc, &out, tx)?;
        Ok(action)
    }

    pub(crate) fn count_frame_error(&mut self) {
        self.stats.frame_errors = self.stats.frame_errors.saturating_add(1);
    }

    /// The cause of the part's last reset and its detail (`crate::reset`), announced with
    /// `ErrorReport{RESET_CAUSE}` at the next poll, before the first heartbeat (protocol/SPEC.md
    /// section 7): a board calls this at boot. The report goes out through the node's own
    /// turn, so a board needs no frames of its own for it.
    pub fn announce_reset(&mut self, cause: crate::reset::ResetCause, detail: u32) {
        self.reset_report = Some(crate::reset::reset_report(cause, detail));
    }

    /// The trial in progress, if any.
    pub fn trial(&self) -> Option<u32> {
        self.trial
    }

    /// Timers: heartbeats, and the repeats and give-ups of unanswered requests.
    pub fn poll<C: Control + ?Sized>(&mut self, ctrl: &mut C, now_ms: u32, out: &mut Outbox) {
        if let Some(r) = self.reset_report.take() {
            push(out, NodeId::Controller, r.into());
        }
        let due = *self.heartbeat_due_ms.get_or_insert(now_ms);
        if now_ms.wrapping_sub(due) < u32::MAX / 2 {
            let hb = Heartbeat {
                counter: self.heartbeat_counter,
                state: NodeState::Operational,
            };
            push(out, NodeId::Controller, hb.into());
            self.heartbeat_counter = self.heartbeat_counter.wrapping_add(1);
            self.heartbeat_due_ms = Some(now_ms.wrapping_add(self.cfg.heartbeat_period_ms));
        }
        match self
            .pending
            .poll(now_ms, self.cfg.reply_timeout_ms, self.cfg.retries, out)
        {
            Ok(true) => self.stats.retries += 1,
            Ok(false) => {}
            Err(GaveUp::Servo(detail)) => {
                error(out, codes::SERVO_TIMEOUT, detail);
                self.abort(ctrl, out);
            }
            Err(GaveUp::Observation(seq)) => {
                error(out, codes::OBSERVATION_TIMEOUT, seq as u32);
                self.abort(ctrl, out);
            }
            Err(GaveUp::Gripper) => {
                error(out, codes::GRIPPER_TIMEOUT, self.last_trial.unwrap_or(0));
            }
        }
        self.poll_tables(ctrl, out);
        if let Some(d) = self.deferred {
            let held = now_ms.wrapping_sub(d.since_ms) < self.cfg.save_hold_ms;
            if !self.tables_saving() || !held {
                // the start finds the save over or its hold past, and begins
                self.start(ctrl, d.trial, d.task, d.fine, now_ms, out);
            }
        }
        self.speak_own_version(out);
    }

    /// True (and kept) when the start of `trial` must wait for the save in progress: a save
    /// writes the tables only between trials. A repeat of the start waiting keeps the first
    /// (its supervision, its time).
    pub(crate) fn defers(&mut self, trial: u32, task: Task, fine: FineMoves, now_ms: u32) -> bool {
        if !self.tables_saving() {
            self.deferred = None;
            return false;
        }
        match self.deferred {
            Some(d) if d.trial == trial => {}
            _ => {
                self.deferred = Some(Deferred {
                    trial,
                    task,
                    fine,
                    since_ms: now_ms,
                })
            }
        }
        let d = self.deferred.expect("kept above");
        if now_ms.wrapping_sub(d.since_ms) >= self.cfg.save_hold_ms {
            self.deferred = None;
            return false;
        }
        true
    }

    /// True while a trial's start waits for a save.
    pub fn trial_deferred(&self) -> bool {
        self.deferred.is_some()
    }

    /// The `now_ms` at which the node next needs a turn if no frame arrives: the earlier of
    /// its next heartbeat and the repeat or give-up of the request it waits on (what
    /// [`ControllerNode::poll`] would act on first). A loop may sleep until then or until a
    /// frame comes (times wrap like `now_ms`: compare with `wrapping_sub`).
    ///
    /// `None` until the timers first ran (the first `poll`, which every `service` makes):
    /// the first heartbeat is due at once, so a loop gives the node a turn before waiting.
    ///
    /// While a save of the tables runs (one small step a turn) or a status waits to be
    /// announced, the answer is the last heartbeat's time, already past: the next turn is due
    /// at once.
    pub fn poll_timeout(&self) -> Option<u32> {
        let heartbeat = self.heartbeat_due_ms?;
        if self.tables_want_a_turn() {
            return Some(heartbeat.wrapping_sub(self.cfg.heartbeat_period_ms));
        }
        Some(match self.pending.deadline(self.cfg.reply_timeout_ms) {
            // the request's deadline comes first (wrapping comparison)
            Some(request) if (request.wrapping_sub(heartbeat) as i32) < 0 => request,
            _ => heartbeat,
        })
    }

    /// Feeds one received frame through `rx`; a completed message is handled and every
    /// frame to send is passed to `tx`, encoded by `enc`. Frame errors (malformed, lost,
    /// corrupt segments) are returned after the frame is dropped.
    #[inline(never)]
    pub fn on_frame<const SLOTS: usize, C: Control + ?Sized>(
        &mut self,
        ctrl: &mut C,
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
            if let Some(mode) = self.bus_mode.take() {
                enc.set_mode(mode);
            }
            send(enc, &out, tx)?;
        }
        Ok(())
    }

    /// [`ControllerNode::poll`] with the output encoded and passed to `tx`.
    #[inline(never)]
    pub fn poll_frames<C: Control + ?Sized>(
        &mut self,
        ctrl: &mut C,
        enc: &mut Encoder,
        now_ms: u32,
        tx: &mut impl FnMut(&CanFrame),
    ) -> Result<(), FrameError> {
        let mut out = Outbox::new();
        self.poll(ctrl, now_ms, &mut out);
        send(enc, &out, tx)
    }

    /// Handles one received message.
    pub fn on_message<C: Control + ?Sized>(
        &mut self,
        ctrl: &mut C,
        env: &Envelope,
        now_ms: u32,
        out: &mut Outbox,
    ) {
        if !self.cfg.protocol.understands(&env.msg) {
            // a version-3 node's decoder rejects what version 4 added (an unknown kind, an
            // unknown point status): nothing is answered
            return self.count_frame_error();
        }
        self.handle(ctrl, env, now_ms, out);
        self.speak_own_version(out);
    }

    /// Drops from `out` what the node's protocol version does not have (a version-3 node
    /// never sends what version 4 added).
    fn speak_own_version(&self, out: &mut Outbox) {
        if self.cfg.v3() {
            out.retain(|e| trn_protocol::ProtocolVersion::V3.understands(&e.msg));
        }
    }

    fn handle<C: Control + ?Sized>(
        &mut self,
        ctrl: &mut C,
        env: &Envelope,
        now_ms: u32,
        out: &mut Outbox,
    ) {
        match (env.node, &env.msg) {
            (NodeId::CameraProcessor, Message::Observation(o)) => {
                self.on_observation(ctrl, o, now_ms, out)
            }
            (NodeId::Servo(j), Message::ServoStatus(s)) => {
                match self.pending.on_servo(j.index() as usize, s, now_ms, out) {
                    ServoAnswer::Stale => self.stats.stale_answers += 1,
                    ServoAnswer::Repeated => self.stats.corrected_commands += 1,
                    ServoAnswer::Confirmed(_) => {}
                    ServoAnswer::NotNormal(detail) => {
                        error(out, codes::SERVO_NOT_NORMAL, detail);
                        self.abort(ctrl, out);
                    }
                }
            }
            (NodeId::Gripper, Message::GripperStatus(g)) => self.pending.on_gripper(g.closed),
            (NodeId::Controller, Message::SupervisedPressure(s)) => {
                // supervised pressures belong to priming: ignored once training began
                if matches!(self.mode, Mode::Idle | Mode::Priming) {
                    self.supervised = Some((s.trial, s.p))
                } else {
                    self.stats.ignored += 1;
                }
            }
            (NodeId::Controller, Message::GraspRequest(g)) => {
                // one of a grasp's three start messages: a repeat of a finished grasp is
                // answered once, at its Stage2Target
                if self.repeated(g.trial, false, out) || self.refuses_trial(ctrl, g.trial, None) {
                    return;
                }
                if self.grasp.map(|p| p.trial) != Some(g.trial) {
                    self.grasp = Some(PendingGrasp {
                        trial: g.trial,
                        learn: false,
                        v: None,
                    });
                }
            }
            (NodeId::Controller, Message::Stage1Target(t)) => {
                if self.repeated(t.trial, !t.grasp, out)
                    || self.refuses_trial(ctrl, t.trial, Some(out))
                {
                    return;
                }
                if t.grasp {
                    match self.grasp {
                        Some(g) if g.trial == t.trial => {
                            self.grasp = Some(PendingGrasp {
                                v: Some(t.v),
                                learn: self.learns(t.learn),
                                ..g
                            })
                        }
                        _ => error(out, codes::OUT_OF_ORDER, t.trial),
                    }
                    return;
                }
                let supervised = match self.supervised.take() {
                    Some((trial, p)) if trial == t.trial => Some(p),
                    _ => None,
                };
                if self.mode == Mode::Priming && supervised.is_none() {
                    // every priming trial is supervised: its pressure was lost or is late
                    error(out, codes::MISSING_SUPERVISION, t.trial);
                    return;
                }
                let task = Task::Stage1 {
                    v: t.v,
                    supervised,
                    learn: self.learns(t.learn),
                };
                self.start(ctrl, t.trial, task, fine_moves(t.fine_moves), now_ms, out);
            }
            (NodeId::Controller, Message::Stage2Target(t)) => {
                if self.repeated(t.trial, true, out) || self.refuses_trial(ctrl, t.trial, Some(out))
                {
                    return;
                }
                if t.grasp {
                    match self.grasp {
                        Some(PendingGrasp {
                            trial,
                            learn,
                            v: Some(v),
                        }) if trial == t.trial => {
                            self.grasp = None;
                            let task = Task::Grasp { v, c: t.c, learn };
                            self.start(ctrl, trial, task, fine_moves(t.fine_moves), now_ms, out)
                        }
                        _ => error(out, codes::OUT_OF_ORDER, t.trial),
                    }
                    return;
                }
                let task = Task::Stage2 {
                    c: t.c,
                    learn: self.learns(t.learn),
                };
                self.start(ctrl, t.trial, task, fine_moves(t.fine_moves), now_ms, out);
            }
            (NodeId::Controller, Message::ModeChange(m)) => {
                // a start waiting for a save belongs to the mode it came in
                self.deferred = None;
                self.entering_mode(m.mode);
                self.mode = m.mode;
                self.idle_requested = m.mode == Mode::Idle;
                if m.mode == Mode::Idle {
                    // the session is over: the next one starts with its configuration, and
                    // its trial numbers afresh
                    self.session = None;
                    self.forget_trials();
                    self.session_required |= learned(ctrl);
                }
                // the acknowledgement: the mode now in force, to every node
                let echo = ModeChange { mode: self.mode };
                push(out, NodeId::Broadcast, echo.into());
            }
            (NodeId::Controller, Message::SessionConfig(c)) => {
                self.on_session_config(ctrl, c, 0, now_ms, out)
            }
            (NodeId::Controller, Message::ConfirmedSessionConfig(c)) => {
                self.on_session_config(ctrl, &c.config, c.nonce, now_ms, out)
            }
            (NodeId::Controller, Message::GuardRequest(r)) => {
                match self.guard.issue(r.op, now_ms) {
                    Ok(nonce) => {
                        let window_ms = self.cfg.nonce_window_ms;
                        let n = GuardNonce {
                            op: r.op,
                            nonce,
                            window_ms,
                        };
                        push(out, NodeId::Controller, n.into());
                    }
                    Err(refusal) => {
                        let detail = op_code(r.op) << 8 | refusal as u32;
                        error(out, codes::GUARD_REFUSED, detail)
                    }
                }
            }
            (NodeId::Controller, Message::StoreCommand(c)) => {
                self.on_store_command(ctrl, c, now_ms, out)
            }
            (NodeId::Controller, Message::TableReadRequest(r)) => {
                self.on_read_request(ctrl, r, out)
            }
            (NodeId::Controller, Message::TableWriteBegin(b)) => {
                self.on_write_begin(ctrl, b, now_ms, out)
            }
            (NodeId::Controller, Message::TableWriteChunk(c)) => self.on_write_chunk(ctrl, c, out),
            (NodeId::Controller, Message::TableWriteEnd(e)) => self.on_write_end(ctrl, e, out),
            (_, Message::Emergency(_)) => {
                if self.trial.is_some() {
                    self.abort(ctrl, out);
                }
            }
            _ => self.stats.ignored += 1,
        }
    }

    /// The session configuration in force, if the runner sent one.
    pub fn session(&self) -> Option<&SessionConfig> {
        self.session.as_ref()
    }

    /// True after a `ModeChange{Idle}`: the runner has ended the session (a host process
    /// may save its checkpoint and exit).
    pub fn idle_requested(&self) -> bool {
        self.idle_requested
    }

    /// The operating mode last set by a `ModeChange`.
    pub fn mode(&self) -> Mode {
        self.mode
    }
}
