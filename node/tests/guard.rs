//! The guard of learned tables at the node: a re-seed, a table write or an erase of the
//! stored copy only with a fresh nonce; refusals on the bus with their reason; trials
//! refused after a refused session; never-trained tables configured freely.

mod common;

use common::*;
use trn_controller::persist::TableStore;
use trn_node::{codes, NodeConfig, Outbox, Refusal};
use trn_protocol::{
    ConfirmedSessionConfig, GuardOp, GuardRequest, Message, Mode, ModeChange, Stage1Target,
    StoreCommand, StoreOp, TableWriteBegin, TablesEvent,
};

const RESEED: u32 = 1 << 8;

/// Asks the node for a nonce for `op` at `now`.
fn issue(n: &mut trn_node::ControllerNode, b: &mut Board, op: GuardOp, now: u32) -> u32 {
    nonce(&send(n, b, GuardRequest { op }.into(), now), op)
}

fn nonce(out: &Outbox, op: GuardOp) -> u32 {
    out.iter()
        .find_map(|e| match e.msg {
            Message::GuardNonce(n) if n.op == op => Some(n.nonce),
            _ => None,
        })
        .expect("a nonce")
}

fn echoed(out: &Outbox) -> bool {
    out.iter()
        .any(|e| matches!(e.msg, Message::SessionConfig(_)))
}

fn target(trial: u32) -> Message {
    Stage1Target {
        trial,
        learn: true,
        grasp: false,
        fine_moves: 0,
        v: [300.0, 200.0, 310.0, 210.0, 320.0, 220.0, 330.0, 230.0],
    }
    .into()
}

/// Each refusal with its own reason, nothing changed after any; then a fresh nonce re-seeds.
#[test]
fn a_reseed_of_learned_tables_needs_a_fresh_nonce() {
    let (mut n, mut b) = booted_board(1, 3);
    let before = image(&b.ctrl);
    let other = session(77, false);
    let refused = |out: &Outbox, r: Refusal| {
        assert_eq!(errors(out), vec![(codes::GUARD_REFUSED, RESEED | r as u32)]);
        assert!(!echoed(out));
    };
    // no nonce: the plain SessionConfig of a second runner or of a replayed log
    refused(&send(&mut n, &mut b, other.into(), 0), Refusal::NoNonce);
    // a nonce never issued
    let wrong = ConfirmedSessionConfig {
        config: other,
        nonce: 12345,
    };
    refused(&send(&mut n, &mut b, wrong.into(), 10), Refusal::Wrong);
    // issued, presented too late (2 s of the node's clock)
    let stale = ConfirmedSessionConfig {
        config: other,
        nonce: issue(&mut n, &mut b, GuardOp::Reseed, 100),
    };
    refused(&send(&mut n, &mut b, stale.into(), 2101), Refusal::Stale);
    // issued for another operation
    let other_op = ConfirmedSessionConfig {
        config: other,
        nonce: issue(&mut n, &mut b, GuardOp::StoreErase, 3000),
    };
    refused(&send(&mut n, &mut b, other_op.into(), 3001), Refusal::Wrong);
    assert_eq!(image(&b.ctrl), before, "a refusal changed the tables");
    // fresh: accepted, echoed as the plain configuration, new tables seeded
    let fresh = ConfirmedSessionConfig {
        config: other,
        nonce: issue(&mut n, &mut b, GuardOp::Reseed, 4000),
    };
    let out = send(&mut n, &mut b, fresh.into(), 5999);
    assert!(errors(&out).is_empty(), "{out:?}");
    assert!(out.iter().any(|e| e.msg == Message::SessionConfig(other)));
    assert!(
        same(&b.ctrl, &learned(77, 0)),
        "the tables are those seeded with 77"
    );
    // the same confirmed message again (a repeat: its echo was lost): the configuration in
    // force, echoed without re-seeding
    let again = send(&mut n, &mut b, fresh.into(), 6000);
    assert!(echoed(&again));
}

fn learned_now(b: &mut Board) -> bool {
    b.ctrl.stage1().learning_step() + b.ctrl.stage2().learning_step() > 0
}

/// A nonce is good once: the confirmation replayed after a session ended is refused.
#[test]
fn a_replayed_confirmation_is_refused_as_used() {
    let (mut n, mut b) = booted_board(2, 2);
    let out = send(
        &mut n,
        &mut b,
        GuardRequest {
            op: GuardOp::Reseed,
        }
        .into(),
        0,
    );
    let c = ConfirmedSessionConfig {
        config: session(5, false),
        nonce: nonce(&out, GuardOp::Reseed),
    };
    assert!(echoed(&send(&mut n, &mut b, c.into(), 1)));
    // the new tables learn in a session, which ends
    let mut out = send(
        &mut n,
        &mut b,
        ModeChange {
            mode: Mode::Training,
        }
        .into(),
        2,
    );
    let mut plant = Plant::new();
    out.extend(send(&mut n, &mut b, target(1), 3));
    for _ in 0..20 {
        let answers = plant.answer(&out);
        out.clear();
        for a in &answers {
            n.on_message(&mut b, a, 4, &mut out);
        }
    }
    assert!(learned_now(&mut b), "the trial learned");
    send(&mut n, &mut b, ModeChange { mode: Mode::Idle }.into(), 5);
    let before = image(&b.ctrl);
    let out = send(&mut n, &mut b, c.into(), 6);
    assert_eq!(
        errors(&out),
        vec![(codes::GUARD_REFUSED, RESEED | Refusal::Used as u32)]
    );
    assert_eq!(image(&b.ctrl), before);
}

/// After a refused configuration, trials are refused (their start changes nothing) until a
/// session is accepted; the session keeping the tables is accepted without a nonce.
#[test]
fn after_a_refused_session_trials_are_refused_until_one_is_accepted() {
    let (mut n, mut b) = booted_board(3, 3);
    let before = image(&b.ctrl);
    // at boot with learned tables: no session yet
    assert!(n.session_required());
    assert_eq!(
        errors(&send(&mut n, &mut b, target(1), 0)),
        vec![(codes::SESSION_REQUIRED, 1)]
    );
    // a replayed session: refused, then its mode change and its targets start nothing
    send(&mut n, &mut b, session(9, false).into(), 1);
    send(
        &mut n,
        &mut b,
        ModeChange {
            mode: Mode::Training,
        }
        .into(),
        2,
    );
    let out = send(&mut n, &mut b, target(2), 3);
    assert_eq!(errors(&out), vec![(codes::SESSION_REQUIRED, 2)]);
    assert!(!out
        .iter()
        .any(|e| matches!(e.msg, Message::PressureCommand(_))));
    assert_eq!(n.trial(), None);
    assert_eq!(image(&b.ctrl), before);
    // the runner's session keeping these tables (their configuration): accepted
    send(&mut n, &mut b, ModeChange { mode: Mode::Idle }.into(), 4);
    let keep = send(&mut n, &mut b, session(9, true).into(), 5);
    assert!(echoed(&keep), "{keep:?}");
    assert!(!n.session_required());
    send(
        &mut n,
        &mut b,
        ModeChange {
            mode: Mode::Training,
        }
        .into(),
        6,
    );
    let out = send(&mut n, &mut b, target(3), 7);
    assert!(out
        .iter()
        .any(|e| matches!(e.msg, Message::PressureCommand(_))));
    assert_eq!(n.trial(), Some(3));
}

/// Tables that never learned have nothing to lose: any configuration is taken without a
/// nonce, and trials need no session.
#[test]
fn a_never_trained_node_is_configured_freely() {
    let mut c = learned(4, 0);
    let mut n = node();
    assert!(echoed(&send(&mut n, &mut c, session(1, false).into(), 0)));
    send(&mut n, &mut c, ModeChange { mode: Mode::Idle }.into(), 1);
    assert!(!n.session_required());
    assert!(echoed(&send(&mut n, &mut c, session(2, false).into(), 2)));
    // keep_tables with another configuration is still a mismatch: they were not learned
    // under it
    let mut paper = session(2, true);
    paper.preset = 1;
    assert_eq!(
        errors(&send(&mut n, &mut c, paper.into(), 3)),
        vec![(codes::CONFIG_REJECTED, codes::CONFIG_MISMATCH)]
    );
    assert!(!n.session_required(), "nothing learned: nothing to guard");
}

/// A board set to allow unguarded resets re-seeds learned tables on a plain configuration.
#[test]
fn a_board_may_allow_unguarded_resets() {
    let mut b = learned(5, 2);
    let mut n = trn_node::ControllerNode::new(NodeConfig {
        allow_unguarded_reset: true,
        ..NodeConfig::DEFAULT
    });
    assert!(echoed(&send(&mut n, &mut b, session(6, false).into(), 0)));
    assert_eq!(b.stage1().learning_step(), 0, "re-seeded");
}

/// A node whose embedding never seeded its generator issues no nonce: nothing destructive
/// can happen to learned tables over the bus.
#[test]
fn an_unseeded_node_issues_no_nonce() {
    let mut b = learned(6, 2);
    let mut n = trn_node::ControllerNode::new(NodeConfig::DEFAULT);
    let out = send(
        &mut n,
        &mut b,
        GuardRequest {
            op: GuardOp::Reseed,
        }
        .into(),
        0,
    );
    assert_eq!(
        errors(&out),
        vec![(codes::GUARD_REFUSED, RESEED | Refusal::Unavailable as u32)]
    );
}

/// Erasing the stored copy and writing tables in are guarded the same way; the erase with a
/// fresh nonce erases.
#[test]
fn erasing_and_writing_in_are_guarded() {
    let (mut n, mut b) = booted_board(7, 2);
    let erase = |nonce| {
        Message::from(StoreCommand {
            op: StoreOp::Erase,
            nonce,
        })
    };
    let out = send(&mut n, &mut b, erase(0), 0);
    assert_eq!(
        errors(&out),
        vec![(codes::GUARD_REFUSED, 3 << 8 | Refusal::NoNonce as u32)]
    );
    assert!(b.store.stored().is_some());
    let begin = TableWriteBegin {
        nonce: 99,
        image_len: 1000,
        image_crc: 1,
        fingerprint: 2,
    };
    let out = send(&mut n, &mut b, begin.into(), 1);
    assert_eq!(
        errors(&out),
        vec![(codes::GUARD_REFUSED, 2 << 8 | Refusal::Wrong as u32)]
    );
    let out = send(
        &mut n,
        &mut b,
        GuardRequest {
            op: GuardOp::StoreErase,
        }
        .into(),
        2,
    );
    let out = send(&mut n, &mut b, erase(nonce(&out, GuardOp::StoreErase)), 3);
    assert!(out.iter().any(|e| matches!(
        e.msg,
        Message::TablesStatus(s) if s.event == TablesEvent::Erased && s.stored_sequence == 0
    )));
    assert_eq!(b.store.stored(), None);
}
