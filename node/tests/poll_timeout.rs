//! `ControllerNode::poll_timeout`: when a loop must give the node its next turn. A loop that
//! sleeps until then (and until a frame arrives) misses no heartbeat and no repeat.

use trn_controller::{Config, Controller};
use trn_node::{ControllerNode, NodeConfig, Outbox};
use trn_protocol::{Envelope, Message, NodeId, Stage1Target};

const V: [f32; 8] = [300.0, 200.0, 310.0, 210.0, 320.0, 220.0, 330.0, 230.0];

fn setup() -> (Box<Controller>, ControllerNode) {
    let mut c = Box::new(Controller::new(Config::project_default()));
    c.init_random(1);
    (c, ControllerNode::new(NodeConfig::default()))
}

fn target(trial: u32) -> Envelope {
    let t = Stage1Target {
        trial,
        learn: false,
        grasp: false,
        fine_moves: trn_protocol::FINE_MOVES_POLICY,
        v: V,
    };
    Envelope::new(NodeId::Controller, t.into())
}

fn is_heartbeat(e: &Envelope) -> bool {
    matches!(e.msg, Message::Heartbeat(_))
}

/// Driven only at the times `poll_timeout` names, the node sends every heartbeat on time
/// (one per period) and nothing is due between those times. Fails if `poll_timeout`
/// returns a time later than a due heartbeat (beats are missed or late) or none at all.
#[test]
fn an_idle_node_is_due_at_each_heartbeat() {
    let (mut c, mut n) = setup();
    let period = NodeConfig::default().heartbeat_period_ms;
    let mut out = Outbox::new();
    n.poll(&mut c, 0, &mut out);
    assert_eq!(out.iter().filter(|e| is_heartbeat(e)).count(), 1);
    let mut now = 0;
    for k in 1..=20 {
        let due = n.poll_timeout().expect("a heartbeat is always scheduled");
        assert_eq!(due, k * period, "the next heartbeat");
        // nothing is due just before
        out.clear();
        n.poll(&mut c, due - 1, &mut out);
        assert!(out.is_empty(), "{out:?} before the deadline {due}");
        now = due;
        out.clear();
        n.poll(&mut c, now, &mut out);
        assert_eq!(out.iter().filter(|e| is_heartbeat(e)).count(), 1);
    }
    assert_eq!(now, 20 * period);
}

/// A request awaiting its answer is due at its repeat, which comes before the next
/// heartbeat here; driven at those times, the node repeats the request and then gives the
/// trial up after its retries, exactly when the bounded repeats say. Fails if
/// `poll_timeout` ignores the pending request (the repeat would wait for a heartbeat).
#[test]
fn a_pending_request_is_due_at_its_repeat() {
    let cfg = NodeConfig {
        heartbeat_period_ms: 1000,
        reply_timeout_ms: 30,
        retries: 3,
        ..NodeConfig::DEFAULT
    };
    let mut c = Box::new(Controller::new(Config::project_default()));
    c.init_random(1);
    let mut n = ControllerNode::new(cfg);
    let mut out = Outbox::new();
    n.poll(&mut c, 0, &mut out); // first heartbeat, next at 1000
    out.clear();
    n.on_message(&mut c, &target(1), 5, &mut out);
    assert!(!out.is_empty(), "the coarse move's commands");
    let mut repeats = 0;
    let mut gave_up = false;
    for _ in 0..10 {
        let due = n.poll_timeout().unwrap();
        if due >= 1000 {
            break;
        }
        out.clear();
        n.poll(&mut c, due, &mut out);
        let aborted = out.iter().any(|e| {
            matches!(e.msg, Message::ErrorReport(r) if r.code == trn_node::codes::TRIAL_ABORTED)
        });
        if aborted {
            gave_up = true;
            break;
        }
        assert!(!out.is_empty(), "due at {due} but nothing repeated");
        repeats += 1;
    }
    assert_eq!(repeats, 3, "one repeat per retry");
    assert!(gave_up, "the trial is given up after its retries");
    assert_eq!(
        n.poll_timeout(),
        Some(1000),
        "only the heartbeat is left to wait for"
    );
}

/// While a save can make a step the node is due at once (a time already past), so a loop
/// that sleeps until `poll_timeout` runs the save's steps back to back instead of one per
/// heartbeat; once it is stored, only the heartbeat is due again. A node without a store
/// never stays due. Fails if a loop would wait a heartbeat period between save steps.
#[test]
fn a_save_in_progress_is_due_at_once() {
    use trn_controller::persist::WithStore;
    use trn_protocol::{StoreCommand, StoreOp, TablesEvent};
    let slot = trn_store::FlashStore::<trn_store::sim::SimFlash<32, 4096>>::slot_size_needed();
    let flash = trn_store::sim::SimFlash::<32, 4096>::new(2 * slot as usize / 4096);
    let mut b = WithStore {
        ctrl: Box::new(Controller::new(Config::project_default())),
        store: trn_store::FlashStore::new(flash, 0, slot).unwrap(),
    };
    b.ctrl.init_random(1);
    let mut n = ControllerNode::new(NodeConfig::default());
    let mut out = Outbox::new();
    n.poll(&mut b, 0, &mut out);
    let save = StoreCommand {
        op: StoreOp::Save,
        nonce: 0,
    };
    n.on_message(
        &mut b,
        &Envelope::new(NodeId::Controller, save.into()),
        1,
        &mut out,
    );
    let now = 1;
    let mut steps = 0;
    loop {
        let due = n.poll_timeout().unwrap();
        assert!(
            due.wrapping_sub(now) > u32::MAX / 2 || due == now,
            "due {due} at {now}"
        );
        out.clear();
        n.poll(&mut b, now, &mut out);
        steps += 1;
        let saved = out
            .iter()
            .any(|e| matches!(e.msg, Message::TablesStatus(s) if s.event == TablesEvent::Saved));
        if saved {
            break;
        }
        assert!(steps < 1000, "the save never ended");
    }
    assert!(steps > 10, "{steps} steps: a save is many small steps");
    assert_eq!(
        n.poll_timeout(),
        Some(100),
        "only the heartbeat is due after the save"
    );
    // no store: entering Mature asks for a save that cannot run; it is not due for ever
    let (mut c, mut n) = setup();
    n.poll(&mut c, 0, &mut out);
    let mature = trn_protocol::ModeChange {
        mode: trn_protocol::Mode::Mature,
    };
    n.on_message(
        &mut c,
        &Envelope::new(NodeId::Controller, mature.into()),
        1,
        &mut out,
    );
    n.poll(&mut c, 2, &mut out);
    assert_eq!(n.poll_timeout(), Some(100), "the heartbeat only");
}
