//! The controller node at message level, across trials: heartbeats, repeated targets and
//! lost answers, mode changes, session configurations that cannot apply.

mod common;

use common::trial::*;
use trn_controller::Config;
use trn_node::{codes, NodeConfig, Outbox};
use trn_protocol::{Envelope, Message, NodeId};

#[test]
fn heartbeats_every_period() {
    let (mut c, mut n) = setup();
    let mut out = Outbox::new();
    let mut beats = 0;
    for t in (0..1000).step_by(10) {
        out.clear();
        n.poll(&mut c, t, &mut out);
        beats += out
            .iter()
            .filter(|e| matches!(e.msg, Message::Heartbeat(_)))
            .count();
    }
    assert_eq!(beats, 10);
}

/// A lost frame anywhere is repeated, a repeated target is recognised: the target repeated
/// while its trial runs starts nothing; a lost confirmation repeats the command (same seq);
/// a drive that applied another value (a corrupted command) gets the command again; the
/// target repeated after the trial ended gets the same report again. Fails if a repeat
/// starts a second trial, moves the arm twice or is dropped.
#[test]
fn repeats_are_recognised_and_lost_answers_requested_again() {
    let (mut c, mut n) = setup();
    let mut out = Outbox::new();
    n.on_message(&mut c, &stage1(5), 0, &mut out);
    let first = out.clone();
    out.clear();
    n.on_message(&mut c, &stage1(5), 1, &mut out);
    assert!(out.is_empty(), "a repeated target starts nothing: {out:?}");
    assert_eq!(n.stats().trials, 1);
    assert_eq!(n.stats().repeated_targets, 1);
    // confirm 4 drives; drive 2 answers with another value, then not at all
    let ok = confirmations(&first);
    for (j, env) in ok.iter().enumerate() {
        let mut env = *env;
        if j == 2 {
            let Message::ServoStatus(mut s) = env.msg else {
                panic!()
            };
            s.applied = (s.applied + 1) % 4096;
            env.msg = s.into();
        }
        n.on_message(&mut c, &env, 2, &mut out);
    }
    assert_eq!(n.stats().corrected_commands, 1);
    let again: Vec<_> = out
        .iter()
        .filter(|e| matches!(e.msg, Message::PressureCommand(_)))
        .collect();
    assert_eq!(
        again.len(),
        1,
        "the corrupted command is sent again: {out:?}"
    );
    assert!(!out
        .iter()
        .any(|e| matches!(e.msg, Message::CaptureRequest(_))));
    out.clear();
    n.poll(&mut c, NodeConfig::default().reply_timeout_ms + 2, &mut out);
    assert_eq!(
        out.iter()
            .filter(|e| matches!(e.msg, Message::PressureCommand(_)))
            .count(),
        1,
        "only the unconfirmed drive is asked again"
    );
    // now drive 2 confirms: the capture follows
    let mut after = Outbox::new();
    n.on_message(&mut c, &ok[2], 3, &mut after);
    let seq = after
        .iter()
        .find_map(|e| match e.msg {
            Message::CaptureRequest(r) => Some(r.seq),
            _ => None,
        })
        .expect("capture after the last confirmation");
    // on target at once: the report
    after.clear();
    n.on_message(&mut c, &lights(seq, &V), 4, &mut after);
    let report = reports(&after);
    assert_eq!(report.len(), 1);
    // the report was lost: the runner repeats the target, and gets it again
    out.clear();
    n.on_message(&mut c, &stage1(5), 5, &mut out);
    assert_eq!(reports(&out), report);
    assert_eq!(n.stats().trials, 1);
}

/// A mode change is acknowledged to every node with the mode now in force.
#[test]
fn mode_changes_are_echoed() {
    let (mut c, mut n) = setup();
    let mut out = Outbox::new();
    let m = trn_protocol::ModeChange {
        mode: trn_protocol::Mode::Mature,
    };
    n.on_message(&mut c, &to_ctrl(m.into()), 0, &mut out);
    assert_eq!(
        out.as_slice(),
        &[Envelope::new(NodeId::Broadcast, m.into())]
    );
}

fn session(keep_tables: bool, law: u8, seed: u64) -> Envelope {
    to_ctrl(
        trn_protocol::SessionConfig {
            seed,
            preset: 0,
            ablation: 0,
            image_width: 1024,
            image_height: 768,
            fd: false,
            keep_tables,
            law,
        }
        .into(),
    )
}

/// A configuration the controller cannot apply is refused with its reason and changes
/// nothing: kept tables learned under another configuration (here the paper preset's), a
/// control law this controller does not run (the host's model reference).
#[test]
fn session_configs_that_cannot_apply_are_refused_and_change_nothing() {
    let (mut c, mut n) = setup();
    c.set_config(Config::paper()).unwrap();
    let tables = c.stage1().net().clone();
    let mut out = Outbox::new();
    n.on_message(&mut c, &session(true, 0, 5), 0, &mut out);
    assert_eq!(
        errors(&out),
        vec![(codes::CONFIG_REJECTED, codes::CONFIG_MISMATCH)]
    );
    // valid, but not a law this controller runs
    let mut out = Outbox::new();
    n.on_message(&mut c, &session(false, 2, 5), 0, &mut out);
    assert_eq!(
        errors(&out),
        vec![(codes::CONFIG_REJECTED, codes::CONFIG_UNSUPPORTED)]
    );
    assert_eq!(*c.config(), Config::paper());
    assert!(
        *c.stage1().net() == tables,
        "a refused configuration re-seeded the tables"
    );
    assert!(n.session().is_none());
    // a configuration it can apply is acknowledged (echo to Broadcast) and seeds new tables
    let mut out = Outbox::new();
    n.on_message(&mut c, &session(false, 0, 5), 0, &mut out);
    assert!(errors(&out).is_empty());
    assert!(out
        .iter()
        .any(|e| e.node == NodeId::Broadcast && matches!(e.msg, Message::SessionConfig(_))));
    assert!(*c.stage1().net() != tables);
}
