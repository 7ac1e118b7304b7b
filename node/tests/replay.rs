//! A candump log of a real training session, replayed with its timing onto a node whose
//! tables learned, leaves them bit for bit as they were: its `SessionConfig` is refused
//! (no nonce), so its trials are refused too. The same log replayed onto a node that never
//! learned, or onto one whose board allows unguarded resets, does change the tables: the
//! guard is what keeps them.
//!
//! The log is made here: a scripted runner and plant on the in-process bus drive a session
//! (configuration, priming, training, a grasp in `Mature`, `Idle`) with the node, through
//! the protocol's `RecordingPort`.

mod common;

use std::cell::Cell;
use std::rc::Rc;

use common::*;
use embedded_can::blocking::Can;
use trn_controller::Controller;
use trn_node::{codes, ControllerNode, NodeConfig};
use trn_protocol::bus::{InProcBus, ReceiveTimeout, RecordingPort};
use trn_protocol::{
    candump, BusMode, Encoder, Envelope, GraspRequest, Message, Mode, ModeChange, NodeId,
    Reassembler, Stage1Target, Stage2Target, SupervisedPressure, DEFAULT_STALE_MS,
};

/// The recorded session: its log and the node's controller at its end.
struct Recorded {
    log: Vec<u8>,
    node: ControllerNode,
    ctrl: Box<Controller>,
}

const V: [f32; 8] = [420.0, 310.0, 395.0, 290.0, 405.0, 320.0, 380.0, 300.0];
const C: [f32; 4] = [410.0, 305.0, 390.0, 300.0];

/// Runs a short session on the in-process bus and records every frame.
fn record_session() -> Recorded {
    let bus = InProcBus::new(BusMode::Classic, 3);
    let clock = Rc::new(Cell::new(1_700_000_000_000_000u64));
    let c2 = clock.clone();
    let mut rig = RecordingPort::new(bus.port(), Vec::new(), "vcan0", move || c2.get());
    let mut node_port = bus.port();
    let mut ctrl = learned(21, 0);
    let mut node = ControllerNode::new(NodeConfig::DEFAULT);
    let (mut nrx, mut nenc): (Reassembler, _) = (
        Reassembler::new(DEFAULT_STALE_MS),
        Encoder::new(BusMode::Classic),
    );
    let (mut rx, mut enc): (Reassembler, _) = (
        Reassembler::new(DEFAULT_STALE_MS),
        Encoder::new(BusMode::Classic),
    );
    let mut plant = Plant::new();
    let mut now_ms = 0u32;
    // one millisecond of the session: the node serves its port, the rig answers for the plant
    // and collects what the runner waits for
    let mut step = |rig: &mut RecordingPort<_, _, _>,
                    heard: &mut Vec<Message>,
                    node: &mut ControllerNode,
                    ctrl: &mut Box<Controller>| {
        now_ms += 1;
        clock.set(clock.get() + 1000);
        node.service(ctrl, &mut nrx, &mut nenc, &mut node_port, now_ms)
            .unwrap();
        while let Some(f) = rig_receive(rig) {
            let Ok(Some(env)) = rx.push(&f, now_ms) else {
                continue;
            };
            for answer in plant.answer(&[env]) {
                for f in &enc.encode(&answer).unwrap() {
                    rig.transmit(f).unwrap();
                }
            }
            heard.push(env.msg);
        }
    };
    let mut run = |msgs: &[Message],
                   done: &dyn Fn(&[Message]) -> bool,
                   rig: &mut RecordingPort<_, _, _>,
                   node: &mut ControllerNode,
                   ctrl: &mut Box<Controller>| {
        let mut heard = Vec::new();
        for m in msgs {
            for f in &enc_runner()
                .encode(&Envelope::new(NodeId::Controller, *m))
                .unwrap()
            {
                rig.transmit(f).unwrap();
            }
        }
        for _ in 0..2000 {
            step(rig, &mut heard, node, ctrl);
            if done(&heard) {
                return;
            }
        }
        panic!("no answer to {msgs:?}: {heard:?}");
    };
    let echo = |m: Message| move |h: &[Message]| h.contains(&m);
    let report = |n: usize| {
        move |h: &[Message]| {
            h.iter()
                .filter(|m| matches!(m, Message::TrialReport(_)))
                .count()
                >= n
        }
    };
    let s = session(11, false);
    run(&[s.into()], &echo(s.into()), &mut rig, &mut node, &mut ctrl);
    for mode in [Mode::Priming, Mode::Training, Mode::Mature, Mode::Idle] {
        let m: Message = ModeChange { mode }.into();
        run(&[m], &echo(m), &mut rig, &mut node, &mut ctrl);
        let trials: Vec<Vec<Message>> = match mode {
            Mode::Priming => (1..=3)
                .map(|t| {
                    vec![
                        SupervisedPressure {
                            trial: t,
                            p: [0.1 * t as f32, -0.1, 0.2, 0.0, 0.05],
                        }
                        .into(),
                        stage1(t, false),
                    ]
                })
                .collect(),
            Mode::Training => (4..=7)
                .map(|t| {
                    vec![if t % 2 == 0 {
                        stage1(t, false)
                    } else {
                        stage2(t, false)
                    }]
                })
                .collect(),
            Mode::Mature => vec![vec![
                GraspRequest { trial: 8 }.into(),
                stage1(8, true),
                stage2(8, true),
            ]],
            _ => vec![],
        };
        for msgs in trials {
            let reports = if mode == Mode::Mature { 2 } else { 1 };
            run(&msgs, &report(reports), &mut rig, &mut node, &mut ctrl);
        }
    }
    let (_, log) = rig.into_parts().unwrap();
    Recorded { log, node, ctrl }
}

fn enc_runner() -> Encoder {
    Encoder::new(BusMode::Classic)
}

fn rig_receive<P: ReceiveTimeout>(p: &mut P) -> Option<trn_protocol::CanFrame> {
    // the bus delivers synchronously: a frame is there or none is
    p.receive_timeout(std::time::Duration::ZERO).unwrap()
}

fn stage1(trial: u32, grasp: bool) -> Message {
    Stage1Target {
        trial,
        learn: !grasp,
        grasp,
        fine_moves: 2,
        v: V,
    }
    .into()
}

fn stage2(trial: u32, grasp: bool) -> Message {
    Stage2Target {
        trial,
        learn: !grasp,
        grasp,
        fine_moves: 2,
        c: C,
    }
    .into()
}

/// Replays the log onto `node` with its timing (the node's clock is the log's), returning
/// the error reports the node sent.
fn replay<C: trn_controller::Control + ?Sized>(
    log: &[u8],
    node: &mut ControllerNode,
    ctrl: &mut C,
) -> Vec<(u16, u32)> {
    let records = candump::read_log(log).unwrap();
    let t0 = records[0].timestamp_us;
    let mut rx: Reassembler = Reassembler::new(DEFAULT_STALE_MS);
    let mut enc = Encoder::new(BusMode::Classic);
    let mut sent = Vec::new();
    let mut dec: Reassembler = Reassembler::new(DEFAULT_STALE_MS);
    let mut keep = |f: &trn_protocol::CanFrame| sent.push(*f);
    for r in &records {
        let now = 50_000 + ((r.timestamp_us - t0) / 1000) as u32;
        node.poll_frames(ctrl, &mut enc, now, &mut keep).unwrap();
        let _ = node.on_frame(ctrl, &mut rx, &mut enc, &r.frame, now, &mut keep);
    }
    sent.iter()
        .filter_map(|f| match dec.push(f, 0) {
            Ok(Some(Envelope {
                msg: Message::ErrorReport(e),
                ..
            })) => Some((e.code, e.detail)),
            _ => None,
        })
        .collect()
}

fn recorded() -> &'static Recorded {
    static R: std::sync::OnceLock<Recorded> = std::sync::OnceLock::new();
    R.get_or_init(|| {
        let r = record_session();
        // a real session: configured, trained, a grasp
        let lines = String::from_utf8(r.log.clone()).unwrap();
        assert!(
            lines.lines().count() > 300,
            "{} frames",
            lines.lines().count()
        );
        assert!(r.ctrl.stage1().learning_step() >= 5 && r.ctrl.stage2().learning_step() >= 2);
        r
    })
}

#[test]
fn a_replayed_session_leaves_a_booted_boards_learned_tables_bit_identical() {
    let log = &recorded().log;
    let (mut node, mut board) = booted_board(5, 4);
    let before = board.ctrl.clone();
    let errors = replay(log, &mut node, &mut board);
    assert!(same(&board.ctrl, &before), "the replay changed the tables");
    // the refusals were on the bus: the configuration (no nonce), then every target
    assert!(
        errors.contains(&(codes::GUARD_REFUSED, 1 << 8 | 1)),
        "{errors:?}"
    );
    assert!(errors.iter().any(|e| e.0 == codes::SESSION_REQUIRED));
}

#[test]
fn a_replayed_session_leaves_the_recording_nodes_own_tables_bit_identical() {
    let r = recorded();
    let (mut node, mut ctrl) = (r.node.clone(), r.ctrl.clone());
    node.seed_guard([1; 16]);
    let before = ctrl.clone();
    replay(&r.log, &mut node, &mut ctrl);
    assert!(same(&ctrl, &before), "the replay changed the tables");
}

/// Without the guard the same replay rewrites learned tables: a node that never learned
/// takes the session (nothing to lose) and learns from the replayed answers, and a board
/// allowing unguarded resets re-seeds.
#[test]
fn the_same_replay_changes_tables_the_guard_does_not_cover() {
    let r = recorded();
    let mut fresh = learned(99, 0);
    let before = fresh.clone();
    let mut node = ControllerNode::new(NodeConfig::DEFAULT);
    replay(&r.log, &mut node, &mut fresh);
    assert!(
        !same(&fresh, &before),
        "a fresh node takes the replayed session"
    );
    assert!(
        fresh.stage1().learning_step() > 0,
        "and learns from its answers"
    );
    let mut board = learned(5, 4);
    let before = board.clone();
    let mut node = ControllerNode::new(NodeConfig {
        allow_unguarded_reset: true,
        ..NodeConfig::DEFAULT
    });
    replay(&r.log, &mut node, &mut board);
    assert!(!same(&board, &before));
}
