//! The requests the node waits on, each with a timeout and a bounded number of repeats:
//! a move's pressure commands (confirmed by every drive's `ServoStatus`, which echoes what it
//! applied), the capture that follows (confirmed by the `Observation` of the same `seq`),
//! and the gripper's close (confirmed by `GripperStatus`). A repeat carries the same `seq`,
//! so drives and camera treat it as the same request.

use trn_protocol::{
    CaptureKind, CaptureRequest, GripperCommand, Joint, NodeId, PressureCommand, SafeState,
    ServoStatus,
};

use crate::outbox::{push, Outbox};

/// What the node waits for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Pending {
    /// Nothing.
    None,
    /// Every commanded drive to confirm the move `seq`.
    Servos {
        seq: u16,
        raw: [u16; 5],
        joints: u8,
        confirmed: u8,
        what: CaptureKind,
        since_ms: u32,
        retries: u8,
    },
    /// The observation of capture `seq`.
    Observation {
        seq: u16,
        what: CaptureKind,
        since_ms: u32,
        retries: u8,
    },
    /// The gripper to confirm its close.
    Gripper { since_ms: u32, retries: u8 },
}

/// What a drive's status means for the move in progress.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum ServoAnswer {
    /// Not for the move in progress (late, repeated, foreign): ignored.
    Stale,
    /// The drive is not in its normal state: the move cannot be trusted.
    NotNormal(u32),
    /// The drive applied something else than commanded (a corrupted command): repeated.
    Repeated,
    /// Confirmed; `true` when every drive has confirmed and the capture was requested.
    Confirmed(bool),
}

/// A timeout that has run out of repeats.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum GaveUp {
    /// A drive: `joint << 16 | seq`.
    Servo(u32),
    /// The camera: the capture's `seq`.
    Observation(u16),
    /// The gripper.
    Gripper,
}

fn command(out: &mut Outbox, j: usize, seq: u16, raw: u16) {
    push(
        out,
        NodeId::Servo(Joint::ALL[j]),
        PressureCommand { seq, raw }.into(),
    );
}

fn capture(out: &mut Outbox, seq: u16, what: CaptureKind) {
    push(
        out,
        NodeId::CameraProcessor,
        CaptureRequest { seq, what }.into(),
    );
}

fn close(out: &mut Outbox) {
    push(out, NodeId::Gripper, GripperCommand { close: true }.into());
}

impl Pending {
    /// Sends a move's commands and waits for the drives.
    pub(crate) fn start_move(
        out: &mut Outbox,
        seq: u16,
        raw: [u16; 5],
        joints: u8,
        what: CaptureKind,
        now_ms: u32,
    ) -> Pending {
        for (j, &r) in raw.iter().enumerate().take(joints as usize) {
            command(out, j, seq, r);
        }
        Pending::Servos {
            seq,
            raw,
            joints,
            confirmed: 0,
            what,
            since_ms: now_ms,
            retries: 0,
        }
    }

    /// Sends the gripper's close and waits for it.
    pub(crate) fn start_close(out: &mut Outbox, now_ms: u32) -> Pending {
        close(out);
        Pending::Gripper {
            since_ms: now_ms,
            retries: 0,
        }
    }

    /// A drive's status.
    pub(crate) fn on_servo(
        &mut self,
        joint: usize,
        st: &ServoStatus,
        now_ms: u32,
        out: &mut Outbox,
    ) -> ServoAnswer {
        let Pending::Servos {
            seq,
            raw,
            joints,
            confirmed,
            what,
            ..
        } = self
        else {
            return ServoAnswer::Stale;
        };
        if st.seq != *seq || joint >= *joints as usize {
            return ServoAnswer::Stale;
        }
        if st.safe_state != SafeState::Normal {
            return ServoAnswer::NotNormal(((joint as u32) << 8) | st.safe_state as u32);
        }
        if st.applied != raw[joint] {
            command(out, joint, *seq, raw[joint]);
            return ServoAnswer::Repeated;
        }
        *confirmed |= 1 << joint;
        if *confirmed != (1u8 << *joints) - 1 {
            return ServoAnswer::Confirmed(false);
        }
        let (seq, what) = (*seq, *what);
        capture(out, seq, what);
        *self = Pending::Observation {
            seq,
            what,
            since_ms: now_ms,
            retries: 0,
        };
        ServoAnswer::Confirmed(true)
    }

    /// The awaited capture, if an observation of `seq` and `what` is it.
    pub(crate) fn takes_observation(&self, seq: u16, what: CaptureKind) -> bool {
        matches!(*self, Pending::Observation { seq: s, what: w, .. } if s == seq && w == what)
    }

    /// The gripper's status.
    pub(crate) fn on_gripper(&mut self, closed: bool) {
        if closed && matches!(self, Pending::Gripper { .. }) {
            *self = Pending::None;
        }
    }

    /// When [`Pending::poll`] next acts (repeats the request or gives up): `timeout_ms`
    /// after the request was sent or last repeated; `None` when nothing is awaited.
    pub(crate) fn deadline(&self, timeout_ms: u32) -> Option<u32> {
        match *self {
            Pending::None => None,
            Pending::Servos { since_ms, .. }
            | Pending::Observation { since_ms, .. }
            | Pending::Gripper { since_ms, .. } => Some(since_ms.wrapping_add(timeout_ms)),
        }
    }

    /// Timers: repeats a request whose answer is overdue (returns `Ok(true)` when it did),
    /// or gives up after `retries` repeats.
    pub(crate) fn poll(
        &mut self,
        now_ms: u32,
        timeout_ms: u32,
        max_retries: u8,
        out: &mut Outbox,
    ) -> Result<bool, GaveUp> {
        let (since, retries) = match self {
            Pending::None => return Ok(false),
            Pending::Servos {
                since_ms, retries, ..
            }
            | Pending::Observation {
                since_ms, retries, ..
            }
            | Pending::Gripper { since_ms, retries } => (since_ms, retries),
        };
        if now_ms.wrapping_sub(*since) < timeout_ms {
            return Ok(false);
        }
        if *retries >= max_retries {
            let gave_up = match *self {
                Pending::Servos {
                    seq,
                    joints,
                    confirmed,
                    ..
                } => {
                    let j = (0..joints).find(|j| confirmed & (1 << j) == 0).unwrap_or(0);
                    GaveUp::Servo(((j as u32) << 16) | seq as u32)
                }
                Pending::Observation { seq, .. } => GaveUp::Observation(seq),
                _ => GaveUp::Gripper,
            };
            *self = Pending::None;
            return Err(gave_up);
        }
        *since = now_ms;
        *retries += 1;
        match *self {
            Pending::Servos {
                seq,
                raw,
                joints,
                confirmed,
                ..
            } => {
                for j in (0..joints as usize).filter(|j| confirmed & (1 << j) == 0) {
                    command(out, j, seq, raw[j]);
                }
            }
            Pending::Observation { seq, what, .. } => capture(out, seq, what),
            Pending::Gripper { .. } => close(out),
            Pending::None => {}
        }
        Ok(true)
    }
}

/// The controller's input from an observation (its points valid).
pub(crate) fn reading(o: &trn_protocol::Observation) -> trn_controller::Observation {
    let p = &o.points;
    match o.what {
        CaptureKind::GripperLights => trn_controller::Observation::Lights([
            p[0].x, p[0].y, p[1].x, p[1].y, p[2].x, p[2].y, p[3].x, p[3].y,
        ]),
        CaptureKind::GripperCentre => {
            trn_controller::Observation::Centre([p[0].x, p[0].y, p[1].x, p[1].y])
        }
    }
}
