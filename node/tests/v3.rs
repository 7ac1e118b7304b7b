//! The node in protocol version 3 (`NodeConfig::protocol`, the runner's fixture of an old
//! controller): what version 4 added is unknown to it. It answers no kind of the guard or the
//! tables, takes an observation with an `Estimated` point for an undecodable frame, re-seeds
//! learned tables on a plain `SessionConfig`, runs trials after `Idle` without asking for a
//! session, and sends nothing version 3 does not have (no boot announcement); the same
//! messages to a version-4 node are answered.

mod common;

use common::{booted_board, errors, project, send, session, Plant};
use trn_controller::Control;
use trn_node::{codes, ControllerNode, NodeConfig, Outbox};
use trn_protocol::{
    CaptureKind, GuardOp, GuardRequest, Message, Mode, ModeChange, Observation, PixelPoint,
    PointStatus, ProtocolVersion, StoreCommand, StoreOp, TableReadRequest,
};

/// A version-3 node on learned tables (seeded with 7, three trials) booted as a board boots:
/// what it restored told to it.
fn v3_board() -> (ControllerNode, common::Board) {
    let (_, mut board) = booted_board(7, 3);
    let mut n = ControllerNode::new(NodeConfig {
        protocol: ProtocolVersion::V3,
        ..NodeConfig::DEFAULT
    });
    n.seed_guard([0x5A; 16]);
    n.tables_restored(&mut board, None);
    (n, board)
}

fn steps(board: &common::Board) -> (u32, u32) {
    (
        board.ctrl.stage1().learning_step(),
        board.ctrl.stage2().learning_step(),
    )
}

#[test]
fn a_v3_node_answers_no_kind_of_the_guard_or_the_tables() {
    let (mut n, mut board) = v3_board();
    let mut out = Outbox::new();
    n.poll(&mut board, 0, &mut out);
    assert!(
        out.iter().all(|e| ProtocolVersion::V3.understands(&e.msg)),
        "a version-3 node announced {out:?}"
    );
    let asks: [Message; 3] = [
        StoreCommand {
            op: StoreOp::Status,
            nonce: 0,
        }
        .into(),
        GuardRequest {
            op: GuardOp::Reseed,
        }
        .into(),
        TableReadRequest { index: 0 }.into(),
    ];
    for ask in asks {
        let before = n.stats().frame_errors;
        let out = send(&mut n, &mut board, ask, 10);
        assert!(out.is_empty(), "{ask:?} answered {out:?}");
        assert_eq!(n.stats().frame_errors, before + 1, "{ask:?} not counted");
    }
    // the version-4 node answers the same requests
    let (mut v4, mut b4) = booted_board(7, 3);
    let ask = StoreCommand {
        op: StoreOp::Status,
        nonce: 0,
    };
    let out = send(&mut v4, &mut b4, ask.into(), 10);
    assert!(
        out.iter()
            .any(|e| matches!(e.msg, Message::TablesStatus(_))),
        "{out:?}"
    );
}

#[test]
fn a_v3_node_re_seeds_learned_tables_without_a_nonce_and_runs_trials_after_idle() {
    let (mut n, mut board) = v3_board();
    assert!(steps(&board).0 > 0, "the fixture's tables learned");
    let out = send(&mut n, &mut board, session(9, false).into(), 0);
    assert!(
        out.iter()
            .any(|e| e.msg == Message::SessionConfig(session(9, false))),
        "a plain SessionConfig re-seeds a v3 node's tables: {out:?}"
    );
    assert_eq!(steps(&board), (0, 0));
    assert_eq!(*board.ctrl.config(), project());
    // a trial after Idle starts (a v3 session did not end at Idle)
    send(
        &mut n,
        &mut board,
        ModeChange {
            mode: Mode::Priming,
        }
        .into(),
        1,
    );
    send(
        &mut n,
        &mut board,
        ModeChange { mode: Mode::Idle }.into(),
        2,
    );
    send(
        &mut n,
        &mut board,
        ModeChange { mode: Mode::Mature }.into(),
        3,
    );
    let out = send(&mut n, &mut board, common::trial::stage1(5).msg, 4);
    assert!(
        !errors(&out).iter().any(|e| e.0 == codes::SESSION_REQUIRED),
        "{out:?}"
    );
    assert!(
        out.iter()
            .any(|e| matches!(e.msg, Message::PressureCommand(_))),
        "the trial did not start: {out:?}"
    );
}

#[test]
fn a_v3_node_takes_an_estimated_point_for_an_undecodable_observation() {
    let (mut n, mut board) = v3_board();
    send(&mut n, &mut board, session(9, false).into(), 0);
    send(
        &mut n,
        &mut board,
        ModeChange { mode: Mode::Mature }.into(),
        1,
    );
    let out = send(&mut n, &mut board, common::trial::stage1(5).msg, 2);
    let mut plant = Plant::new();
    let answers = plant.answer(&out);
    let mut seq = 0;
    for a in &answers {
        let mut o = Outbox::new();
        n.on_message(&mut board, a, 3, &mut o);
        if let Some(r) = o.iter().find_map(|e| match e.msg {
            Message::CaptureRequest(r) => Some(r),
            _ => None,
        }) {
            seq = r.seq;
        }
    }
    assert!(seq > 0, "no capture requested");
    let mut points = [PixelPoint::valid(400.0, 300.0); 4];
    points[1].status = PointStatus::Estimated;
    let o = Observation {
        seq,
        what: CaptureKind::GripperLights,
        points,
    };
    let before = n.stats().frame_errors;
    let out = send(&mut n, &mut board, o.into(), 4);
    assert!(out.is_empty(), "{out:?}");
    assert_eq!(n.stats().frame_errors, before + 1);
    assert_eq!(n.stats().estimated, 0);
}
