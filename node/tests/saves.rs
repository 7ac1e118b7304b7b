//! The node and the stored copy: the announcement at boot, saves on a command, on entering
//! `Mature` and every N learning steps, never during a trial that learns.

mod common;

use common::*;
use trn_controller::persist::TableStore;
use trn_node::{codes, ControllerNode, NodeConfig, Outbox};
use trn_protocol::{Message, Mode, ModeChange, StoreCommand, StoreOp, TablesEvent, TablesStatus};

fn statuses(out: &[trn_protocol::Envelope]) -> Vec<TablesStatus> {
    out.iter()
        .filter_map(|e| match e.msg {
            Message::TablesStatus(s) => Some(s),
            _ => None,
        })
        .collect()
}

/// Polls the node until it announces `event` (at most `polls` times); the status.
fn poll_until(
    n: &mut ControllerNode,
    b: &mut Board,
    now: &mut u32,
    event: TablesEvent,
    polls: usize,
) -> Option<TablesStatus> {
    for _ in 0..polls {
        *now += 10;
        let mut out = Outbox::new();
        n.poll(b, *now, &mut out);
        if let Some(s) = statuses(&out).into_iter().find(|s| s.event == event) {
            return Some(s);
        }
    }
    None
}

/// Runs a learning stage-1 trial to its end with the plant answering.
fn learning_trial(n: &mut ControllerNode, b: &mut Board, trial: u32, now: &mut u32) {
    let t = learning_target(trial);
    let mut plant = Plant::new();
    let mut out = send(n, b, t.into(), *now);
    for _ in 0..20 {
        let answers = plant.answer(&out);
        out.clear();
        for a in &answers {
            n.on_message(b, a, *now, &mut out);
        }
        // a save may not start while it learns
        n.poll(b, *now, &mut out);
        if n.trial().is_none() {
            return;
        }
    }
    panic!("the trial did not end");
}

#[test]
fn the_boot_restore_is_announced_and_saves_follow_the_policy() {
    let (mut n, mut b) = booted_board(51, 2);
    let mut now = 0;
    let s = poll_until(&mut n, &mut b, &mut now, TablesEvent::Restored, 1).unwrap();
    assert_eq!(
        (s.steps1, s.stored_sequence),
        (b.ctrl.stage1().learning_step(), 1)
    );
    assert_eq!(s.fingerprint, project().fingerprint());
    // nothing changed: a save command is answered with the stored copy at once
    let out = send(
        &mut n,
        &mut b,
        StoreCommand {
            op: StoreOp::Save,
            nonce: 0,
        }
        .into(),
        now,
    );
    assert_eq!(statuses(&out)[0].event, TablesEvent::Saved);
    assert_eq!(statuses(&out)[0].stored_sequence, 1);
    // a session keeping the tables, a trial that learns, then Mature: saved
    send(&mut n, &mut b, session(1, true).into(), now);
    send(
        &mut n,
        &mut b,
        ModeChange {
            mode: Mode::Training,
        }
        .into(),
        now,
    );
    learning_trial(&mut n, &mut b, 1, &mut now);
    assert_eq!(
        b.store.stored().unwrap().sequence,
        1,
        "no save during training"
    );
    send(
        &mut n,
        &mut b,
        ModeChange { mode: Mode::Mature }.into(),
        now,
    );
    let s = poll_until(&mut n, &mut b, &mut now, TablesEvent::Saved, 200).unwrap();
    assert_eq!(s.stored_sequence, 2);
    assert_eq!(s.steps1, b.ctrl.stage1().learning_step());
    let mut back = learned(0, 0);
    b.store.restore(&mut back, None).unwrap();
    assert!(same(&back, &b.ctrl), "the stored copy is the tables");
}

#[test]
fn every_n_learning_steps_a_save_between_trials_and_a_learning_trial_waits_for_it() {
    let mut b = Board {
        ctrl: learned(52, 0),
        store: store(),
    };
    let mut n = ControllerNode::new(NodeConfig {
        save_every_steps: 2,
        ..NodeConfig::DEFAULT
    });
    let mut now = 0;
    send(&mut n, &mut b, session(3, false).into(), now);
    send(
        &mut n,
        &mut b,
        ModeChange {
            mode: Mode::Training,
        }
        .into(),
        now,
    );
    learning_trial(&mut n, &mut b, 1, &mut now);
    // one step: not yet due, its erases begin (a step ahead) but nothing is written
    assert!(poll_until(&mut n, &mut b, &mut now, TablesEvent::Saved, 5).is_none());
    learning_trial(&mut n, &mut b, 2, &mut now);
    // two: due between trials; the next trial's start waits for the save
    let mut out = Outbox::new();
    n.poll(&mut b, now + 10, &mut out);
    assert!(b.store.saving(), "a save runs");
    let t = learning_target(3);
    let out = send(&mut n, &mut b, t.into(), now);
    assert!(out.is_empty() && n.trial_deferred() && n.trial().is_none());
    let s = poll_until(&mut n, &mut b, &mut now, TablesEvent::Saved, 200).unwrap();
    assert_eq!(s.steps1, 2, "saved with the steps it was due at");
    assert_eq!(n.trial(), Some(3), "the trial started once the save ended");
    let mut back = learned(0, 0);
    b.store.restore(&mut back, None).unwrap();
    assert_eq!(back.stage1().learning_step(), 2);
}

/// A save that does not end within `save_hold_ms` of a trial's start lets the trial begin:
/// its writing is abandoned (its erases kept) and it ends after the trial.
#[test]
fn a_start_waits_for_a_save_no_longer_than_the_hold() {
    let mut b = Board {
        ctrl: learned(54, 0),
        store: store().with_step_bytes(256),
    };
    let mut n = ControllerNode::new(NodeConfig {
        save_every_steps: 1,
        save_hold_ms: 50,
        ..NodeConfig::DEFAULT
    });
    let mut now = 0;
    send(&mut n, &mut b, session(3, false).into(), now);
    let training = ModeChange {
        mode: Mode::Training,
    };
    send(&mut n, &mut b, training.into(), now);
    learning_trial(&mut n, &mut b, 1, &mut now);
    let mut out = Outbox::new();
    n.poll(&mut b, now, &mut out);
    assert!(b.store.saving());
    let t = learning_target(2);
    assert!(send(&mut n, &mut b, t.into(), now).is_empty());
    // a repeat of the start while it waits changes nothing
    assert!(send(&mut n, &mut b, t.into(), now + 20).is_empty());
    out.clear();
    n.poll(&mut b, now + 49, &mut out);
    assert_eq!(n.trial(), None, "still waiting");
    out.clear();
    n.poll(&mut b, now + 50, &mut out);
    assert_eq!(n.trial(), Some(2), "the hold is over: the trial runs");
    assert!(
        !b.store.saving(),
        "the save's writing waits for the trial's end"
    );
}

#[test]
fn a_node_without_a_store_says_so() {
    let mut c = learned(53, 1);
    let mut n = node();
    let out = send(
        &mut n,
        &mut c,
        StoreCommand {
            op: StoreOp::Save,
            nonce: 0,
        }
        .into(),
        0,
    );
    assert_eq!(
        errors(&out),
        vec![(
            codes::TABLES_FAILED,
            codes::table_op::SAVE << 8 | codes::table_reason::NO_STORE
        )]
    );
    let out = send(
        &mut n,
        &mut c,
        StoreCommand {
            op: StoreOp::Status,
            nonce: 0,
        }
        .into(),
        0,
    );
    let s = statuses(&out)[0];
    assert_eq!((s.stored_sequence, s.steps1), (0, 1));
    assert_eq!(s.image_len as usize, image(&c).len());
}

/// A loop that sleeps until `poll_timeout` (a board, the host's loops) completes a save
/// without waiting a heartbeat period between its steps: while a save runs the node is due
/// at once. Fails when `poll_timeout` ignores the save (each of its hundreds of steps would
/// wait 100 ms).
#[test]
fn a_running_save_makes_the_node_due_at_once() {
    let (mut n, mut b) = booted_board(53, 2);
    let mut now = 0u32;
    poll_until(&mut n, &mut b, &mut now, TablesEvent::Restored, 1).unwrap();
    send(&mut n, &mut b, session(1, true).into(), now);
    let training = ModeChange {
        mode: Mode::Training,
    };
    send(&mut n, &mut b, training.into(), now);
    learning_trial(&mut n, &mut b, 1, &mut now);
    let mut out = send(
        &mut n,
        &mut b,
        StoreCommand {
            op: StoreOp::Save,
            nonce: 0,
        }
        .into(),
        now,
    );
    let mut turns = 0;
    while statuses(&out).iter().all(|s| s.event != TablesEvent::Saved) {
        turns += 1;
        assert!(turns < 100_000, "the save never ended");
        let due = n.poll_timeout().expect("timers run");
        assert!(
            due.wrapping_sub(now) as i32 <= 0,
            "a turn {} ms away while a save runs",
            due.wrapping_sub(now)
        );
        out.clear();
        n.poll(&mut b, now, &mut out);
    }
    assert!(turns > 10, "a save is many small steps: {turns}");
    let idle = n.poll_timeout().unwrap();
    assert!(
        idle.wrapping_sub(now) as i32 > 0,
        "afterwards the next heartbeat"
    );
}
