//! Estimated points (a light hidden from one camera, placed by the camera processor from
//! what it sees and where the markers were one move ago): a trial that does not learn moves
//! on with them; a trial that learns aborts as for any invalid point, so that no table takes
//! an estimate's error for the arm's.

use trn_controller::{Config, Controller};
use trn_node::{codes, ControllerNode, NodeConfig, Outbox};
use trn_protocol::{
    CaptureKind, Envelope, GraspRequest, Message, Mode, ModeChange, NodeId, Observation,
    PixelPoint, PointStatus, SafeState, ServoStatus, Stage1Target, Stage2Target,
};

const V: [f32; 8] = [300.0, 200.0, 310.0, 210.0, 320.0, 220.0, 330.0, 230.0];
const C: [f32; 4] = [300.0, 200.0, 310.0, 210.0];

fn setup(mode: Mode) -> (Box<Controller>, ControllerNode) {
    let mut c = Box::new(Controller::new(Config::project_default()));
    c.init_random(1);
    let mut n = ControllerNode::new(NodeConfig::default());
    let mut out = Outbox::new();
    n.on_message(&mut c, &to_ctrl(ModeChange { mode }.into()), 0, &mut out);
    (c, n)
}

fn to_ctrl(msg: Message) -> Envelope {
    Envelope::new(NodeId::Controller, msg)
}

/// Confirms the move in `out` and returns the capture request that follows.
fn capture(n: &mut ControllerNode, c: &mut Controller, out: &Outbox) -> (u16, CaptureKind) {
    let mut after = Outbox::new();
    for e in out.iter() {
        if let (NodeId::Servo(j), Message::PressureCommand(p)) = (e.node, e.msg) {
            let ok = ServoStatus {
                seq: p.seq,
                raw: p.raw,
                applied: p.raw,
                saturated: false,
                safe_state: SafeState::Normal,
            };
            n.on_message(
                c,
                &Envelope::new(NodeId::Servo(j), ok.into()),
                0,
                &mut after,
            );
        }
    }
    after
        .iter()
        .find_map(|e| match e.msg {
            Message::CaptureRequest(r) => Some((r.seq, r.what)),
            _ => None,
        })
        .expect("a capture request")
}

/// A centre observation of `c` with camera 1's point estimated.
fn centre_estimated(seq: u16, c: &[f32; 4]) -> Envelope {
    let mut o = Observation::centre(
        seq,
        PixelPoint::valid(c[0], c[1]),
        PixelPoint::valid(c[2], c[3]),
    );
    o.points[1].status = PointStatus::Estimated;
    Envelope::new(NodeId::CameraProcessor, o.into())
}

fn errors(out: &Outbox) -> Vec<(u16, u32)> {
    out.iter()
        .filter_map(|e| match e.msg {
            Message::ErrorReport(r) => Some((r.code, r.detail)),
            _ => None,
        })
        .collect()
}

fn stage2(trial: u32, learn: bool) -> Envelope {
    to_ctrl(
        Stage2Target {
            trial,
            learn,
            grasp: false,
            fine_moves: 2,
            c: C,
        }
        .into(),
    )
}

#[test]
fn a_trial_that_does_not_learn_moves_on_with_an_estimated_point() {
    let (mut c, mut n) = setup(Mode::Training);
    let mut out = Outbox::new();
    n.on_message(&mut c, &stage2(3, false), 0, &mut out);
    let (seq, what) = capture(&mut n, &mut c, &out);
    assert_eq!(what, CaptureKind::GripperCentre);
    out.clear();
    n.on_message(&mut c, &centre_estimated(seq, &C), 1, &mut out);
    assert_eq!(errors(&out), vec![], "no abort: {out:?}");
    assert!(
        out.iter()
            .any(|e| matches!(e.msg, Message::PressureCommand(_))),
        "the next move: {out:?}"
    );
    assert_eq!(n.trial(), Some(3));
    assert_eq!(n.stats().estimated, 1);
    assert_eq!(n.stats().aborted, 0);
}

#[test]
fn a_trial_that_learns_aborts_on_an_estimated_point() {
    let (mut c, mut n) = setup(Mode::Training);
    let mut out = Outbox::new();
    n.on_message(&mut c, &stage2(4, true), 0, &mut out);
    let (seq, _) = capture(&mut n, &mut c, &out);
    out.clear();
    n.on_message(&mut c, &centre_estimated(seq, &C), 1, &mut out);
    assert_eq!(
        errors(&out),
        vec![
            (
                codes::INVALID_OBSERVATION,
                (1 << 8) | PointStatus::Estimated as u32
            ),
            (codes::TRIAL_ABORTED, 4)
        ]
    );
    assert_eq!(n.trial(), None);
    assert_eq!(n.stats().estimated, 0);
}

/// In `Mature` nothing learns, whatever the target says: estimates are taken.
#[test]
fn mature_mode_takes_estimates_whatever_the_target_asks() {
    let (mut c, mut n) = setup(Mode::Mature);
    let mut out = Outbox::new();
    n.on_message(&mut c, &stage2(5, true), 0, &mut out);
    let (seq, _) = capture(&mut n, &mut c, &out);
    out.clear();
    n.on_message(&mut c, &centre_estimated(seq, &C), 1, &mut out);
    assert_eq!(errors(&out), vec![]);
    assert_eq!(n.stats().estimated, 1);
}

/// A held-out grasp whose centre light the cylinder hides from one camera after stage 2's
/// coarse move goes on to its close.
#[test]
fn a_grasp_closes_through_an_estimated_centre() {
    let (mut c, mut n) = setup(Mode::Mature);
    let mut out = Outbox::new();
    n.on_message(
        &mut c,
        &to_ctrl(GraspRequest { trial: 9 }.into()),
        0,
        &mut out,
    );
    for msg in [
        Stage1Target {
            trial: 9,
            learn: false,
            grasp: true,
            fine_moves: 0,
            v: V,
        }
        .into(),
        Stage2Target {
            trial: 9,
            learn: false,
            grasp: true,
            fine_moves: 0,
            c: C,
        }
        .into(),
    ] {
        n.on_message(&mut c, &to_ctrl(msg), 0, &mut out);
    }
    let (seq, what) = capture(&mut n, &mut c, &out);
    assert_eq!(what, CaptureKind::GripperLights);
    out.clear();
    let p = |i: usize| PixelPoint::valid(V[2 * i], V[2 * i + 1]);
    let lights = Observation {
        seq,
        what: CaptureKind::GripperLights,
        points: [p(0), p(1), p(2), p(3)],
    };
    let lights = Envelope::new(NodeId::CameraProcessor, lights.into());
    n.on_message(&mut c, &lights, 1, &mut out);
    let (seq, what) = capture(&mut n, &mut c, &out);
    assert_eq!(what, CaptureKind::GripperCentre);
    out.clear();
    n.on_message(&mut c, &centre_estimated(seq, &C), 2, &mut out);
    assert_eq!(errors(&out), vec![]);
    assert!(out
        .iter()
        .any(|e| matches!(e.msg, Message::GripperCommand(g) if g.close)));
}
