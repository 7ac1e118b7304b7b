//! A plain controller node (no store) and its controller, the messages of a trial to send
//! it (targets, observations, the drives' confirmations) and what it answered (capture
//! requests, reports, errors).

use trn_controller::{Config, Controller};
use trn_node::{ControllerNode, NodeConfig, Outbox};
use trn_protocol::{
    CaptureKind, Envelope, Message, NodeId, Observation, PixelPoint, SafeState, ServoStatus,
    Stage1Target,
};

pub const V: [f32; 8] = [300.0, 200.0, 310.0, 210.0, 320.0, 220.0, 330.0, 230.0];
pub const C: [f32; 4] = [300.0, 200.0, 310.0, 210.0];

pub fn setup() -> (Box<Controller>, ControllerNode) {
    let mut c = Box::new(Controller::new(Config::project_default()));
    c.init_random(1);
    (c, ControllerNode::new(NodeConfig::default()))
}

pub fn to_ctrl(msg: Message) -> Envelope {
    Envelope::new(NodeId::Controller, msg)
}

pub fn lights(seq: u16, v: &[f32; 8]) -> Envelope {
    let p = |i: usize| PixelPoint::valid(v[2 * i], v[2 * i + 1]);
    let o = Observation {
        seq,
        what: CaptureKind::GripperLights,
        points: [p(0), p(1), p(2), p(3)],
    };
    Envelope::new(NodeId::CameraProcessor, o.into())
}

pub fn centre(seq: u16, c: &[f32; 4]) -> Envelope {
    let o = Observation::centre(
        seq,
        PixelPoint::valid(c[0], c[1]),
        PixelPoint::valid(c[2], c[3]),
    );
    Envelope::new(NodeId::CameraProcessor, o.into())
}

/// Every drive's confirmation of the pressure commands of `out`.
pub fn confirmations(out: &Outbox) -> Vec<Envelope> {
    out.iter()
        .filter_map(|e| match (e.node, e.msg) {
            (NodeId::Servo(j), Message::PressureCommand(p)) => Some(Envelope::new(
                NodeId::Servo(j),
                ServoStatus {
                    seq: p.seq,
                    raw: p.raw,
                    applied: p.raw,
                    saturated: false,
                    safe_state: SafeState::Normal,
                }
                .into(),
            )),
            _ => None,
        })
        .collect()
}

/// The capture request that follows the drives' confirmations of the pressure commands of
/// `out` (there must be `joints` of them, and no capture before they are confirmed).
pub fn capture(
    n: &mut ControllerNode,
    c: &mut Controller,
    out: &Outbox,
    joints: usize,
) -> (u16, CaptureKind) {
    let ok = confirmations(out);
    assert_eq!(ok.len(), joints, "{out:?}");
    assert!(
        !out.iter()
            .any(|e| matches!(e.msg, Message::CaptureRequest(_))),
        "no capture before the drives confirmed: {out:?}"
    );
    let mut after = Outbox::new();
    for env in &ok {
        n.on_message(c, env, 0, &mut after);
    }
    after
        .iter()
        .find_map(|e| match e.msg {
            Message::CaptureRequest(r) => Some((r.seq, r.what)),
            _ => None,
        })
        .expect("a capture request")
}

pub fn reports(out: &Outbox) -> Vec<trn_protocol::TrialReport> {
    out.iter()
        .filter_map(|e| match e.msg {
            Message::TrialReport(r) => Some(r),
            _ => None,
        })
        .collect()
}

pub fn errors(out: &Outbox) -> Vec<(u16, u32)> {
    out.iter()
        .filter_map(|e| match e.msg {
            Message::ErrorReport(r) => Some((r.code, r.detail)),
            _ => None,
        })
        .collect()
}

pub fn stage1(trial: u32) -> Envelope {
    to_ctrl(
        Stage1Target {
            trial,
            learn: false,
            grasp: false,
            fine_moves: trn_protocol::FINE_MOVES_POLICY,
            v: V,
        }
        .into(),
    )
}
