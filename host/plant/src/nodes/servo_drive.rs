//! One joint's servo drive unit as a sans-IO node: pressure commands in, `ServoStatus` out,
//! heartbeat supervision of the controller with a safe state (protocol/SPEC.md, section 6).

use trn_protocol::heartbeat::{HeartbeatConfig, HeartbeatEvent, HeartbeatMonitor, VENT_RAW};
use trn_protocol::{Envelope, Joint, Message, NodeId, SafeState, SafeStateAction, ServoStatus};

use super::Outbox;
use crate::Plant;
use crate::PlantError as SimError;

/// The servo drive of one joint.
#[derive(Debug, Clone)]
pub struct ServoDrive {
    joint: Joint,
    monitor: HeartbeatMonitor,
    /// The raw command applied last (held in the safe state).
    last_raw: u16,
    /// The sequence number of the command applied last, and its status.
    last: Option<(u16, ServoStatus)>,
}

/// True when `seq` is older than `last` (wrapping: within the half of the counter behind).
fn older(seq: u16, last: u16) -> bool {
    let behind = last.wrapping_sub(seq);
    behind != 0 && behind < 0x8000
}

impl ServoDrive {
    /// The drive of `joint`, supervising the controller's heartbeat from `now_ms` on.
    pub fn new(joint: Joint, supervision: HeartbeatConfig, now_ms: u32) -> Self {
        ServoDrive {
            joint,
            monitor: HeartbeatMonitor::new(supervision, now_ms),
            last_raw: 2048,
            last: None,
        }
    }

    /// The joint it drives.
    pub fn joint(&self) -> Joint {
        self.joint
    }

    /// True while in the safe state (the controller's heartbeat was lost).
    pub fn is_safe(&self) -> bool {
        self.monitor.is_safe()
    }

    /// The safe-state status as reported in `ServoStatus`.
    pub fn safe_state(&self) -> SafeState {
        match (self.monitor.is_safe(), self.monitor.config().action) {
            (false, _) => SafeState::Normal,
            (true, SafeStateAction::HoldLast) => SafeState::HoldLast,
            (true, SafeStateAction::Vent) => SafeState::Vented,
        }
    }

    fn node(&self) -> NodeId {
        NodeId::Servo(self.joint)
    }

    /// Timers: enters the safe state when the controller's heartbeat was lost (venting the
    /// tubes if so configured) and announces it once with `SafeStateEntered`. The drive
    /// forgets the `seq` of its last command then (SPEC 3.6, 8): a controller that restarted
    /// counts from 1 again and must be heard, not taken for a late sender.
    pub fn poll(
        &mut self,
        plant: &mut Plant,
        now_ms: u32,
        out: &mut Outbox,
    ) -> Result<(), SimError> {
        if let Some(HeartbeatEvent::EnteredSafeState(action)) = self.monitor.poll(now_ms) {
            let j = self.joint.index() as usize;
            if action == SafeStateAction::Vent {
                plant.servo_command_raw(j, VENT_RAW)?;
            }
            let msg = self.monitor.safe_state_message(self.last_raw);
            self.last_raw = self.monitor.held_raw(self.last_raw);
            self.last = None;
            out.push(Envelope::new(self.node(), msg));
        }
        Ok(())
    }

    /// A received message: heartbeats feed the supervision; a `PressureCommand` to this
    /// drive is applied (ignored in the safe state, which holds or vents) and answered
    /// with `ServoStatus`. A repeat of the command applied last (same `seq`: its status was
    /// lost) is answered again without applying it twice; an older command (late, reordered)
    /// is ignored. Returns true when it answered.
    pub fn on_message(
        &mut self,
        plant: &mut Plant,
        env: &Envelope,
        now_ms: u32,
        out: &mut Outbox,
    ) -> Result<bool, SimError> {
        self.monitor.observe(env, NodeId::Controller, now_ms);
        let Message::PressureCommand(c) = env.msg else {
            return Ok(false);
        };
        if env.node != self.node() {
            return Ok(false);
        }
        match self.last {
            Some((seq, status)) if seq == c.seq && status.applied == c.raw => {
                out.push(Envelope::new(self.node(), status.into()));
                return Ok(true);
            }
            Some((seq, _)) if older(c.seq, seq) => return Ok(false),
            _ => {}
        }
        let safe_state = self.safe_state();
        let raw = if safe_state == SafeState::Normal {
            c.raw
        } else {
            self.last_raw
        };
        self.last_raw = raw;
        let fb = plant.servo_command_raw(self.joint.index() as usize, raw)?;
        let status = ServoStatus {
            seq: c.seq,
            raw: fb.raw_pressure,
            applied: raw,
            saturated: fb.saturated,
            safe_state,
        };
        self.last = Some((c.seq, status));
        out.push(Envelope::new(self.node(), status.into()));
        Ok(true)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::SimConfig;
    use trn_protocol::{Heartbeat, NodeState, PressureCommand, SafeStateEntered};

    fn heartbeat() -> Envelope {
        Envelope::new(
            NodeId::Controller,
            Heartbeat {
                counter: 0,
                state: NodeState::Operational,
            }
            .into(),
        )
    }

    fn command(joint: u8, seq: u16, raw: u16) -> Envelope {
        Envelope::new(
            NodeId::Servo(Joint::new(joint).unwrap()),
            PressureCommand { seq, raw }.into(),
        )
    }

    #[test]
    fn applies_its_own_commands_only_and_answers_with_the_seq() {
        let mut plant = Plant::new(&SimConfig::default(), 1).unwrap();
        let mut d = ServoDrive::new(Joint::new(2).unwrap(), HeartbeatConfig::default(), 0);
        let mut out = Outbox::new();
        d.on_message(&mut plant, &command(1, 7, 3000), 10, &mut out)
            .unwrap();
        assert!(out.is_empty(), "a command to joint 1 is not for drive 2");
        d.on_message(&mut plant, &command(2, 8, 3000), 10, &mut out)
            .unwrap();
        let [Envelope {
            node,
            msg: Message::ServoStatus(s),
        }] = out.as_slice()
        else {
            panic!("{out:?}")
        };
        assert_eq!(*node, NodeId::Servo(Joint::new(2).unwrap()));
        assert_eq!((s.seq, s.safe_state), (8, SafeState::Normal));
        // the command reached the joint: the tubes follow it
        plant.advance(1.0);
        assert!(
            (plant.joints()[2].pressure() - trn_protocol::raw_to_pressure(3000) as f64).abs()
                < 0.01
        );
    }

    /// A repeated command (its status was lost) is answered again but applied once; a late
    /// older command does not move the arm back. Fails if a duplicate frame could apply a
    /// stale pressure.
    #[test]
    fn repeats_are_answered_once_applied_and_old_commands_ignored() {
        let mut plant = Plant::new(&SimConfig::default(), 1).unwrap();
        let mut d = ServoDrive::new(Joint::new(0).unwrap(), HeartbeatConfig::default(), 0);
        let mut out = Outbox::new();
        assert!(d
            .on_message(&mut plant, &command(0, 10, 3000), 0, &mut out)
            .unwrap());
        assert!(d
            .on_message(&mut plant, &command(0, 10, 3000), 0, &mut out)
            .unwrap());
        assert_eq!(out.len(), 2);
        assert_eq!(out[0], out[1], "the same status again");
        assert!(!d
            .on_message(&mut plant, &command(0, 9, 100), 0, &mut out)
            .unwrap());
        plant.advance(1.0);
        assert!(
            plant.joints()[0].pressure() > 0.4,
            "the late command 9 was not applied"
        );
        // after a wrap of the counter a new command is new
        assert!(d
            .on_message(&mut plant, &command(0, 11, 1000), 0, &mut out)
            .unwrap());
    }

    #[test]
    fn heartbeat_loss_holds_the_last_command_and_is_announced_once() {
        let mut plant = Plant::new(&SimConfig::default(), 1).unwrap();
        let mut d = ServoDrive::new(Joint::new(0).unwrap(), HeartbeatConfig::default(), 0);
        let mut out = Outbox::new();
        d.on_message(&mut plant, &heartbeat(), 100, &mut out)
            .unwrap();
        d.on_message(&mut plant, &command(0, 1, 3000), 100, &mut out)
            .unwrap();
        out.clear();
        d.poll(&mut plant, 600, &mut out).unwrap();
        assert!(out.is_empty() && !d.is_safe(), "500 ms allowed");
        d.poll(&mut plant, 601, &mut out).unwrap();
        assert!(d.is_safe());
        assert_eq!(
            out[0].msg,
            Message::SafeStateEntered(SafeStateEntered {
                reason: trn_protocol::SafeStateReason::HeartbeatLost,
                action: SafeStateAction::HoldLast,
                held_raw: 3000
            })
        );
        d.poll(&mut plant, 900, &mut out).unwrap();
        assert_eq!(out.len(), 1, "announced once");
        // in the safe state a new command is not applied: the status says so
        out.clear();
        d.on_message(&mut plant, &command(0, 2, 100), 950, &mut out)
            .unwrap();
        let Message::ServoStatus(s) = out[0].msg else {
            panic!()
        };
        assert_eq!(s.safe_state, SafeState::HoldLast);
        plant.advance(1.0);
        assert!(plant.joints()[0].pressure() > 0.4, "still holding raw 3000");
        // heartbeats resume: back to normal
        d.on_message(&mut plant, &heartbeat(), 1000, &mut out)
            .unwrap();
        assert!(!d.is_safe());
    }

    /// A controller that restarts counts its `seq` from 1 again: after its heartbeat was
    /// lost the drive forgets the last `seq` and applies the new controller's first command.
    /// Fails if the drive still takes seq 1 for a command older than the old controller's
    /// last (it would never move again: 1 is behind 40,000 by less than 2^15 after a wrap).
    #[test]
    fn a_restarted_controller_is_heard_after_its_heartbeat_was_lost() {
        let mut plant = Plant::new(&SimConfig::default(), 1).unwrap();
        let mut d = ServoDrive::new(Joint::new(0).unwrap(), HeartbeatConfig::default(), 0);
        let mut out = Outbox::new();
        d.on_message(&mut plant, &heartbeat(), 0, &mut out).unwrap();
        // the old controller's last command: seq 20,000
        d.on_message(&mut plant, &command(0, 20_000, 3000), 0, &mut out)
            .unwrap();
        // while its heartbeat is heard, seq 1 is a late command (behind by less than 2^15)
        assert!(!d
            .on_message(&mut plant, &command(0, 1, 1000), 10, &mut out)
            .unwrap());
        // it stops; the drive goes to its safe state and forgets the seq
        d.poll(&mut plant, 600, &mut out).unwrap();
        assert!(d.is_safe());
        // the restarted controller beats again and sends its first move, seq 1
        d.on_message(&mut plant, &heartbeat(), 700, &mut out)
            .unwrap();
        assert!(!d.is_safe());
        out.clear();
        assert!(d
            .on_message(&mut plant, &command(0, 1, 1000), 710, &mut out)
            .unwrap());
        let Message::ServoStatus(s) = out[0].msg else {
            panic!("{out:?}")
        };
        assert_eq!(
            (s.seq, s.applied, s.safe_state),
            (1, 1000, SafeState::Normal)
        );
        plant.advance(1.0);
        assert!(plant.joints()[0].pressure() < -0.4, "raw 1000 was applied");
    }

    #[test]
    fn vent_goes_to_zero_difference() {
        let mut plant = Plant::new(&SimConfig::default(), 1).unwrap();
        let hb = HeartbeatConfig {
            action: SafeStateAction::Vent,
            ..HeartbeatConfig::default()
        };
        let mut d = ServoDrive::new(Joint::new(1).unwrap(), hb, 0);
        let mut out = Outbox::new();
        d.on_message(&mut plant, &command(1, 1, 4000), 0, &mut out)
            .unwrap();
        d.poll(&mut plant, 501, &mut out).unwrap();
        assert_eq!(d.safe_state(), SafeState::Vented);
        plant.advance(2.0);
        assert!(plant.joints()[1].pressure().abs() < 0.01);
    }
}
