//! Deterministic traffic for the DBC interop check: every single-frame id with varied
//! values, plus long (segmented) messages that a DBC tool must skip. Shared by
//! `examples/gen_candump.rs` and `tests/dbc.rs`.
#![allow(dead_code)]

use std::fmt::Write as _;

use trn_protocol::*;

struct Lcg(u64);
impl Lcg {
    fn next(&mut self) -> u64 {
        self.0 = self
            .0
            .wrapping_mul(6364136223846793005)
            .wrapping_add(1442695040888963407);
        self.0 >> 16
    }
}

fn single_message(kind: MessageKind, r: &mut Lcg, round: u64) -> Message {
    let u16v = |r: &mut Lcg| {
        if round == 0 {
            u16::MAX
        } else {
            r.next() as u16
        }
    };
    let raw = |r: &mut Lcg| {
        if round == 0 {
            4095
        } else {
            (r.next() % 4096) as u16
        }
    };
    let b = |r: &mut Lcg| r.next() % 2 == 1;
    let pick = |r: &mut Lcg, n: u64| r.next() % n;
    match kind {
        MessageKind::Emergency => Emergency {
            reason: [
                EmergencyReason::Operator,
                EmergencyReason::HeartbeatLost,
                EmergencyReason::PressureFault,
                EmergencyReason::ControllerFault,
                EmergencyReason::BusFault,
            ][pick(r, 5) as usize],
        }
        .into(),
        MessageKind::SafeStateEntered => SafeStateEntered {
            reason: [
                SafeStateReason::HeartbeatLost,
                SafeStateReason::Emergency,
                SafeStateReason::Commanded,
            ][pick(r, 3) as usize],
            action: if b(r) {
                SafeStateAction::Vent
            } else {
                SafeStateAction::HoldLast
            },
            held_raw: raw(r),
        }
        .into(),
        MessageKind::PressureCommand => PressureCommand {
            seq: u16v(r),
            raw: raw(r),
        }
        .into(),
        MessageKind::ServoStatus => ServoStatus {
            seq: u16v(r),
            raw: raw(r),
            applied: raw(r),
            saturated: b(r),
            safe_state: [SafeState::Normal, SafeState::HoldLast, SafeState::Vented]
                [pick(r, 3) as usize],
        }
        .into(),
        MessageKind::GripperCommand => GripperCommand { close: b(r) }.into(),
        MessageKind::GripperStatus => GripperStatus { closed: b(r) }.into(),
        MessageKind::CaptureRequest => CaptureRequest {
            seq: u16v(r),
            what: if b(r) {
                CaptureKind::GripperCentre
            } else {
                CaptureKind::GripperLights
            },
        }
        .into(),
        MessageKind::ModeChange => ModeChange {
            mode: [Mode::Idle, Mode::Priming, Mode::Training, Mode::Mature][pick(r, 4) as usize],
        }
        .into(),
        MessageKind::GraspRequest => GraspRequest {
            trial: if round == 0 {
                u32::MAX
            } else {
                r.next() as u32
            },
        }
        .into(),
        MessageKind::ErrorReport => ErrorReport {
            code: u16v(r),
            detail: r.next() as u32,
        }
        .into(),
        MessageKind::Heartbeat => Heartbeat {
            counter: r.next() as u8,
            state: [
                NodeState::Booting,
                NodeState::Operational,
                NodeState::SafeState,
                NodeState::Fault,
            ][pick(r, 4) as usize],
        }
        .into(),
        MessageKind::GuardRequest => GuardRequest {
            op: [GuardOp::Reseed, GuardOp::TableWrite, GuardOp::StoreErase][pick(r, 3) as usize],
        }
        .into(),
        MessageKind::GuardNonce => GuardNonce {
            op: [GuardOp::Reseed, GuardOp::TableWrite, GuardOp::StoreErase][pick(r, 3) as usize],
            nonce: r.next() as u32,
            window_ms: u16v(r),
        }
        .into(),
        MessageKind::StoreCommand => StoreCommand {
            op: [StoreOp::Status, StoreOp::Save, StoreOp::Erase][pick(r, 3) as usize],
            nonce: r.next() as u32,
        }
        .into(),
        MessageKind::TableWriteEnd => TableWriteEnd {
            image_crc: r.next() as u32,
        }
        .into(),
        MessageKind::TableReadRequest => TableReadRequest { index: u16v(r) }.into(),
        MessageKind::TableWriteAck => TableWriteAck {
            next: u16v(r),
            image_crc: r.next() as u32,
        }
        .into(),
        other => panic!("{other:?} is not a single-frame kind"),
    }
}

/// The traffic: three rounds over every valid single-frame id, with a long message
/// after every tenth frame.
pub fn traffic() -> Vec<Envelope> {
    let mut r = Lcg(0x5EED);
    let mut out = Vec::new();
    for round in 0..3 {
        for raw in 0..=MAX_STANDARD_ID {
            let Ok(id) = CanId::from_raw(raw) else {
                continue;
            };
            if !id.kind.is_single_frame() {
                continue;
            }
            out.push(Envelope::new(
                id.node,
                single_message(id.kind, &mut r, round),
            ));
            if out.len() % 10 == 0 {
                let t = r.next() as u32;
                out.push(Envelope::new(
                    NodeId::Controller,
                    Stage1Target {
                        trial: t,
                        learn: true,
                        grasp: false,
                        fine_moves: trn_protocol::FINE_MOVES_POLICY,
                        v: [t as f32; 8],
                    }
                    .into(),
                ));
            }
        }
    }
    out
}

/// The DBC signal values (enum = variant index, bool = 0/1) of a single-frame message.
pub fn signals(msg: &Message) -> Vec<(&'static str, u64)> {
    match *msg {
        Message::Emergency(m) => vec![("reason", m.reason as u64)],
        Message::SafeStateEntered(m) => vec![
            ("reason", m.reason as u64),
            ("action", m.action as u64),
            ("held_raw", m.held_raw as u64),
        ],
        Message::PressureCommand(m) => vec![("seq", m.seq as u64), ("raw", m.raw as u64)],
        Message::ServoStatus(m) => vec![
            ("seq", m.seq as u64),
            ("raw", m.raw as u64),
            ("applied", m.applied as u64),
            ("saturated", m.saturated as u64),
            ("safe_state", m.safe_state as u64),
        ],
        Message::GripperCommand(m) => vec![("close", m.close as u64)],
        Message::GripperStatus(m) => vec![("closed", m.closed as u64)],
        Message::CaptureRequest(m) => vec![("seq", m.seq as u64), ("what", m.what as u64)],
        Message::ModeChange(m) => vec![("mode", m.mode as u64)],
        Message::GraspRequest(m) => vec![("trial", m.trial as u64)],
        Message::ErrorReport(m) => vec![("code", m.code as u64), ("detail", m.detail as u64)],
        Message::Heartbeat(m) => vec![("counter", m.counter as u64), ("state", m.state as u64)],
        Message::GuardRequest(m) => vec![("op", m.op as u64)],
        Message::GuardNonce(m) => vec![
            ("op", m.op as u64),
            ("nonce", m.nonce as u64),
            ("window_ms", m.window_ms as u64),
        ],
        Message::StoreCommand(m) => vec![("op", m.op as u64), ("nonce", m.nonce as u64)],
        Message::TableWriteEnd(m) => vec![("image_crc", m.image_crc as u64)],
        Message::TableReadRequest(m) => vec![("index", m.index as u64)],
        Message::TableWriteAck(m) => {
            vec![("next", m.next as u64), ("image_crc", m.image_crc as u64)]
        }
        _ => vec![],
    }
}

/// Encodes the traffic on a classical bus. Returns the candump log and the expectations
/// (one JSON object per line: log line index, id, signal values; single frames only).
pub fn render() -> (String, String) {
    let mut enc = Encoder::new(BusMode::Classic);
    let mut log = String::new();
    let mut expected = String::new();
    let mut line = 0usize;
    let mut t = 1_700_000_000_000_000u64;
    for env in traffic() {
        let frames = enc.encode(&env).unwrap();
        for f in &frames {
            candump::write_line(&mut log, t, "vcan0", f).unwrap();
            log.push('\n');
            t += 250;
            line += 1;
        }
        if env.msg.kind().is_single_frame() {
            let sigs: Vec<String> = signals(&env.msg)
                .iter()
                .map(|(k, v)| format!("\"{k}\": {v}"))
                .collect();
            writeln!(
                expected,
                "{{\"line\": {}, \"id\": {}, \"signals\": {{{}}}}}",
                line - 1,
                frames[0].raw_id(),
                sigs.join(", ")
            )
            .unwrap();
        }
    }
    (log, expected)
}
