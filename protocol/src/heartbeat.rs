//! Heartbeat generation and supervision (no_std; the caller passes `now_ms`).
//!
//! Every node sends a [`Heartbeat`] every [`DEFAULT_PERIOD_MS`]. A servo drive supervises
//! the controller's heartbeat with a [`HeartbeatMonitor`]: when none was seen for
//! [`DEFAULT_TIMEOUT_MS`] it enters its safe state (hold the last pressure or vent) and
//! announces it with [`HeartbeatMonitor::safe_state_message`].
//!
//! ```
//! use trn_protocol::{HeartbeatConfig, HeartbeatEvent, HeartbeatMonitor, SafeStateAction};
//! let mut m = HeartbeatMonitor::new(HeartbeatConfig::default(), 0);
//! m.heartbeat(100);
//! assert_eq!(m.poll(600), None);
//! assert_eq!(m.poll(601), Some(HeartbeatEvent::EnteredSafeState(SafeStateAction::HoldLast)));
//! assert_eq!(m.poll(700), None); // reported once
//! ```

use crate::envelope::Envelope;
use crate::message::{
    Heartbeat, Message, NodeState, SafeStateAction, SafeStateEntered, SafeStateReason,
};
use crate::node::NodeId;

/// Default heartbeat period, ms.
pub const DEFAULT_PERIOD_MS: u32 = 100;
/// Default supervision timeout, ms (five missed heartbeats).
pub const DEFAULT_TIMEOUT_MS: u32 = 500;
/// The raw command of zero pressure difference, used when venting.
pub const VENT_RAW: u16 = 2048;

/// Supervision configuration.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct HeartbeatConfig {
    /// Heartbeat loss is declared when none was seen for more than this, ms.
    pub timeout_ms: u32,
    /// What the node does in its safe state.
    pub action: SafeStateAction,
    /// Leave the safe state automatically when heartbeats resume.
    pub auto_recover: bool,
}

impl Default for HeartbeatConfig {
    fn default() -> Self {
        HeartbeatConfig {
            timeout_ms: DEFAULT_TIMEOUT_MS,
            action: SafeStateAction::HoldLast,
            auto_recover: true,
        }
    }
}

/// A supervision transition, reported once.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum HeartbeatEvent {
    /// The heartbeat was lost: apply the action and announce it.
    EnteredSafeState(SafeStateAction),
    /// Heartbeats resumed (with `auto_recover`): back to normal operation.
    Recovered,
}

/// Supervises one node's heartbeat.
#[derive(Debug, Clone)]
pub struct HeartbeatMonitor {
    cfg: HeartbeatConfig,
    last_seen_ms: u32,
    safe: bool,
}

impl HeartbeatMonitor {
    /// Starts supervising at `now_ms`; the first heartbeat is due within the timeout.
    pub const fn new(cfg: HeartbeatConfig, now_ms: u32) -> Self {
        HeartbeatMonitor {
            cfg,
            last_seen_ms: now_ms,
            safe: false,
        }
    }

    /// The configuration.
    pub const fn config(&self) -> HeartbeatConfig {
        self.cfg
    }

    /// True while in the safe state.
    pub const fn is_safe(&self) -> bool {
        self.safe
    }

    /// Records a heartbeat at `now_ms`.
    pub fn heartbeat(&mut self, now_ms: u32) -> Option<HeartbeatEvent> {
        self.last_seen_ms = now_ms;
        if self.safe && self.cfg.auto_recover {
            self.safe = false;
            return Some(HeartbeatEvent::Recovered);
        }
        None
    }

    /// Feeds a received envelope: a [`Heartbeat`] from `supervised` counts as a heartbeat
    /// unless its state is `SafeState` or `Fault`.
    pub fn observe(
        &mut self,
        env: &Envelope,
        supervised: NodeId,
        now_ms: u32,
    ) -> Option<HeartbeatEvent> {
        match env.msg {
            Message::Heartbeat(Heartbeat { state, .. })
                if env.node == supervised
                    && matches!(state, NodeState::Booting | NodeState::Operational) =>
            {
                self.heartbeat(now_ms)
            }
            _ => None,
        }
    }

    /// Checks the timeout at `now_ms`; reports entering the safe state once.
    pub fn poll(&mut self, now_ms: u32) -> Option<HeartbeatEvent> {
        if !self.safe && now_ms.wrapping_sub(self.last_seen_ms) > self.cfg.timeout_ms {
            self.safe = true;
            return Some(HeartbeatEvent::EnteredSafeState(self.cfg.action));
        }
        None
    }

    /// Leaves the safe state explicitly (when `auto_recover` is off), restarting the
    /// timeout at `now_ms`.
    pub fn reset(&mut self, now_ms: u32) {
        self.safe = false;
        self.last_seen_ms = now_ms;
    }

    /// The raw pressure a servo drive holds in the safe state: the last command for
    /// `HoldLast`, [`VENT_RAW`] for `Vent`.
    pub const fn held_raw(&self, last_raw: u16) -> u16 {
        match self.cfg.action {
            SafeStateAction::HoldLast => last_raw,
            SafeStateAction::Vent => VENT_RAW,
        }
    }

    /// The announcement to send (node = the sender itself) after entering the safe state.
    pub const fn safe_state_message(&self, last_raw: u16) -> Message {
        Message::SafeStateEntered(SafeStateEntered {
            reason: SafeStateReason::HeartbeatLost,
            action: self.cfg.action,
            held_raw: self.held_raw(last_raw),
        })
    }
}

/// Produces this node's heartbeats every `period_ms`.
#[derive(Debug, Clone)]
pub struct HeartbeatSender {
    period_ms: u32,
    next_due_ms: u32,
    counter: u8,
}

impl HeartbeatSender {
    /// First heartbeat due at `now_ms`.
    pub const fn new(period_ms: u32, now_ms: u32) -> Self {
        HeartbeatSender {
            period_ms,
            next_due_ms: now_ms,
            counter: 0,
        }
    }

    /// When the next heartbeat is due (ms, the clock of `now_ms`).
    pub const fn next_due_ms(&self) -> u32 {
        self.next_due_ms
    }

    /// A heartbeat if one is due at `now_ms` (at most one per call).
    pub fn poll(&mut self, now_ms: u32, state: NodeState) -> Option<Message> {
        // Due when now is at or past next_due (wrapping comparison).
        if (now_ms.wrapping_sub(self.next_due_ms) as i32) < 0 {
            return None;
        }
        let hb = Heartbeat {
            counter: self.counter,
            state,
        };
        self.counter = self.counter.wrapping_add(1);
        self.next_due_ms = now_ms.wrapping_add(self.period_ms);
        Some(Message::Heartbeat(hb))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn vent() -> HeartbeatConfig {
        HeartbeatConfig {
            timeout_ms: 500,
            action: SafeStateAction::Vent,
            auto_recover: false,
        }
    }

    #[test]
    fn no_first_heartbeat_also_times_out() {
        let mut m = HeartbeatMonitor::new(HeartbeatConfig::default(), 1000);
        assert_eq!(m.poll(1500), None);
        assert!(m.poll(1501).is_some());
        assert!(m.is_safe());
    }

    #[test]
    fn regular_heartbeats_keep_it_normal() {
        let mut m = HeartbeatMonitor::new(HeartbeatConfig::default(), 0);
        for t in (0..10_000).step_by(100) {
            assert_eq!(m.heartbeat(t), None);
            assert_eq!(m.poll(t + 99), None);
        }
        assert!(!m.is_safe());
    }

    #[test]
    fn auto_recover_and_announcement() {
        let mut m = HeartbeatMonitor::new(HeartbeatConfig::default(), 0);
        assert!(m.poll(501).is_some());
        assert_eq!(
            m.safe_state_message(1234),
            Message::SafeStateEntered(SafeStateEntered {
                reason: SafeStateReason::HeartbeatLost,
                action: SafeStateAction::HoldLast,
                held_raw: 1234
            })
        );
        assert_eq!(m.heartbeat(600), Some(HeartbeatEvent::Recovered));
        assert!(!m.is_safe());
    }

    #[test]
    fn vent_without_auto_recover_needs_reset() {
        let mut m = HeartbeatMonitor::new(vent(), 0);
        assert_eq!(
            m.poll(600),
            Some(HeartbeatEvent::EnteredSafeState(SafeStateAction::Vent))
        );
        assert_eq!(m.held_raw(100), VENT_RAW);
        assert_eq!(m.heartbeat(700), None);
        assert!(m.is_safe());
        m.reset(700);
        assert!(!m.is_safe());
        assert_eq!(m.poll(1200), None);
        assert!(m.poll(1201).is_some());
    }

    #[test]
    fn observe_only_counts_the_supervised_nodes_healthy_heartbeat() {
        let mut m = HeartbeatMonitor::new(vent(), 0);
        let hb =
            |node, state| Envelope::new(node, Message::Heartbeat(Heartbeat { counter: 0, state }));
        m.observe(
            &hb(NodeId::Gripper, NodeState::Operational),
            NodeId::Controller,
            400,
        );
        m.observe(
            &hb(NodeId::Controller, NodeState::Fault),
            NodeId::Controller,
            400,
        );
        assert!(m.poll(501).is_some());
        let mut m = HeartbeatMonitor::new(vent(), 0);
        m.observe(
            &hb(NodeId::Controller, NodeState::Operational),
            NodeId::Controller,
            400,
        );
        assert!(m.poll(501).is_none());
    }

    #[test]
    fn sender_period_and_counter() {
        let mut s = HeartbeatSender::new(100, u32::MAX - 50);
        let mut sent = 0;
        let mut t = u32::MAX - 50;
        for _ in 0..1000 {
            if let Some(Message::Heartbeat(h)) = s.poll(t, NodeState::Operational) {
                assert_eq!(h.counter, sent as u8);
                sent += 1;
            }
            t = t.wrapping_add(1);
        }
        assert_eq!(sent, 10);
    }
}
