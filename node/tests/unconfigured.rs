//! A node whose controller is still zeroed, as the board images start (configured only by
//! the `SessionConfig` they receive): every target is refused with a report and nothing
//! moves or panics; after a `SessionConfig` it runs trials.

use trn_controller::Controller;
use trn_node::{codes, ControllerNode, NodeConfig, Outbox};
use trn_protocol::{
    Envelope, GraspRequest, Message, NodeId, SessionConfig, Stage1Target, Stage2Target,
    SupervisedPressure, FINE_MOVES_POLICY,
};

const V: [f32; 8] = [300.0, 200.0, 310.0, 210.0, 320.0, 220.0, 330.0, 230.0];
const C: [f32; 4] = [300.0, 200.0, 310.0, 210.0];

fn to_ctrl(msg: Message) -> Envelope {
    Envelope::new(NodeId::Controller, msg)
}

fn stage1(trial: u32, grasp: bool) -> Envelope {
    let t = Stage1Target {
        trial,
        learn: true,
        grasp,
        fine_moves: FINE_MOVES_POLICY,
        v: V,
    };
    to_ctrl(t.into())
}

fn stage2(trial: u32, grasp: bool) -> Envelope {
    let t = Stage2Target {
        trial,
        learn: true,
        grasp,
        fine_moves: FINE_MOVES_POLICY,
        c: C,
    };
    to_ctrl(t.into())
}

fn moves(out: &Outbox) -> usize {
    out.iter()
        .filter(|e| matches!(e.msg, Message::PressureCommand(_)))
        .count()
}

fn aborted(out: &Outbox, trial: u32) -> bool {
    out.iter().any(
        |e| matches!(e.msg, Message::ErrorReport(r) if r.code == codes::TRIAL_ABORTED && r.detail == trial),
    )
}

#[test]
fn a_zeroed_controller_refuses_every_target_until_a_session_configures_it() {
    let mut ctrl = Box::new(Controller::new_zeroed());
    let mut node = ControllerNode::new(NodeConfig::DEFAULT);
    let mut out = Outbox::new();
    node.on_message(&mut *ctrl, &stage1(1, false), 0, &mut out);
    assert_eq!(moves(&out), 0, "{out:?}");
    assert!(aborted(&out, 1), "{out:?}");
    out.clear();
    node.on_message(&mut *ctrl, &stage2(2, false), 0, &mut out);
    assert_eq!(moves(&out), 0, "{out:?}");
    assert!(aborted(&out, 2), "{out:?}");
    // a supervised priming trial and a grasp: refused the same way
    out.clear();
    let p = SupervisedPressure {
        trial: 3,
        p: [0.1; 5],
    };
    node.on_message(&mut *ctrl, &to_ctrl(p.into()), 0, &mut out);
    node.on_message(&mut *ctrl, &stage1(3, false), 0, &mut out);
    let g = GraspRequest { trial: 4 };
    node.on_message(&mut *ctrl, &to_ctrl(g.into()), 0, &mut out);
    node.on_message(&mut *ctrl, &stage1(4, true), 0, &mut out);
    node.on_message(&mut *ctrl, &stage2(4, true), 0, &mut out);
    assert_eq!(moves(&out), 0, "{out:?}");
    assert!(aborted(&out, 3) && aborted(&out, 4), "{out:?}");
    assert!(!ctrl.busy());
    // the session's configuration and seed: now a target moves the arm
    out.clear();
    let session = SessionConfig {
        seed: 7,
        preset: 0,
        ablation: 0,
        image_width: 1024,
        image_height: 768,
        fd: false,
        keep_tables: false,
        law: 0,
    };
    node.on_message(&mut *ctrl, &to_ctrl(session.into()), 0, &mut out);
    out.clear();
    node.on_message(&mut *ctrl, &stage1(5, false), 0, &mut out);
    assert_eq!(moves(&out), 5, "{out:?}");
}
