//! `ControllerNode::poll_timeout`: the time a loop may sleep until. Each check polls a copy
//! of the node one millisecond before the time it names (nothing may be due yet: a time
//! later than a due heartbeat or repeat fails here) and at that time (something must be
//! sent: a time earlier than needed fails here), across heartbeats, repeats, give-ups and
//! the wrap of the millisecond clock.

use trn_controller::{Config, Controller};
use trn_node::{ControllerNode, NodeConfig, Outbox};
use trn_protocol::{
    Envelope, Message, NodeId, SafeState, ServoStatus, Stage1Target, FINE_MOVES_POLICY,
};

const V: [f32; 8] = [300.0, 200.0, 310.0, 210.0, 320.0, 220.0, 330.0, 230.0];

fn controller() -> Box<Controller> {
    let mut c = Box::new(Controller::new(Config::project_default()));
    c.init_random(1);
    c
}

fn target(trial: u32) -> Envelope {
    let t = Stage1Target {
        trial,
        learn: false,
        grasp: false,
        fine_moves: FINE_MOVES_POLICY,
        v: V,
    };
    Envelope::new(NodeId::Controller, t.into())
}

/// What a copy of `node` sends when polled at `now_ms` (the controller is not changed unless
/// a request is given up, which only happens at a deadline).
fn polled(node: &ControllerNode, ctrl: &mut Controller, now_ms: u32) -> Outbox {
    let mut copy = node.clone();
    let mut out = Outbox::new();
    copy.poll(ctrl, now_ms, &mut out);
    out
}

/// Checks the node's timeout against what polling does around it; returns it.
fn check_timeout(node: &ControllerNode, ctrl: &mut Controller) -> u32 {
    let due = node.poll_timeout().expect("a timeout once the timers ran");
    let early = polled(node, ctrl, due.wrapping_sub(1));
    assert!(
        early.is_empty(),
        "poll_timeout {due} is later than something due: polled at {} the node sent {early:?}",
        due.wrapping_sub(1)
    );
    let on_time = polled(node, ctrl, due);
    assert!(
        !on_time.is_empty(),
        "poll_timeout {due} is earlier than needed: polled then the node sent nothing"
    );
    due
}

fn heartbeats(out: &Outbox) -> usize {
    out.iter()
        .filter(|e| matches!(e.msg, Message::Heartbeat(_)))
        .count()
}

fn pressure_commands(out: &Outbox) -> usize {
    out.iter()
        .filter(|e| matches!(e.msg, Message::PressureCommand(_)))
        .count()
}

#[test]
fn no_timeout_before_the_timers_first_ran_then_the_next_heartbeat() {
    let mut ctrl = controller();
    let mut node = ControllerNode::new(NodeConfig::DEFAULT);
    assert_eq!(node.poll_timeout(), None);
    let mut out = Outbox::new();
    node.poll(&mut *ctrl, 1_000, &mut out);
    assert_eq!(
        heartbeats(&out),
        1,
        "the first poll sends a heartbeat at once"
    );
    assert_eq!(check_timeout(&node, &mut ctrl), 1_100);
    assert_eq!(heartbeats(&polled(&node, &mut ctrl, 1_100)), 1);
}

/// A loop that sleeps until each timeout and polls then sends every heartbeat on time and
/// every repeat of an unanswered request, up to the give-up (the trial aborted with its
/// reason), with the clock wrapping through zero on the way.
#[test]
fn sleeping_until_each_timeout_misses_no_heartbeat_repeat_or_give_up() {
    let cfg = NodeConfig {
        heartbeat_period_ms: 100,
        reply_timeout_ms: 35,
        retries: 3,
        ..NodeConfig::DEFAULT
    };
    let mut ctrl = controller();
    let mut node = ControllerNode::new(cfg);
    let start = u32::MAX - 120;
    let mut out = Outbox::new();
    node.poll(&mut *ctrl, start, &mut out);
    // a trial starts 7 ms later: its commands are sent and wait for the drives
    out.clear();
    node.on_message(&mut *ctrl, &target(1), start.wrapping_add(7), &mut out);
    assert_eq!(pressure_commands(&out), 5, "{out:?}");
    let mut now = start.wrapping_add(7);
    let (mut beats, mut repeats, mut gave_up) = (0, 0, false);
    for _ in 0..20 {
        let due = check_timeout(&node, &mut ctrl);
        assert!(
            due.wrapping_sub(now) <= cfg.heartbeat_period_ms,
            "{due} after {now}"
        );
        now = due;
        out.clear();
        node.poll(&mut *ctrl, now, &mut out);
        beats += heartbeats(&out);
        repeats += usize::from(pressure_commands(&out) == 5);
        gave_up |= out
            .iter()
            .any(|e| matches!(e.msg, Message::ErrorReport(r) if r.code == trn_node::codes::SERVO_TIMEOUT));
    }
    assert_eq!(repeats, 3, "every repeat of the commands");
    assert!(gave_up, "the trial was given up after its repeats");
    assert_eq!(node.trial(), None);
    // with no request pending, only heartbeats remain: 100 ms apart
    let due = check_timeout(&node, &mut ctrl);
    assert_eq!(due.wrapping_sub(now) % 100, 0);
    assert!(beats >= 10, "{beats} heartbeats");
    assert!(now < start, "the clock wrapped through zero");
}

/// An answer resets the request's deadline: after every drive confirmed, the capture
/// request that follows is repeated `reply_timeout_ms` after it was sent, not after the
/// commands were.
#[test]
fn an_answered_request_moves_the_timeout_to_the_next_request() {
    let cfg = NodeConfig {
        heartbeat_period_ms: 1_000,
        reply_timeout_ms: 50,
        retries: 2,
        ..NodeConfig::DEFAULT
    };
    let mut ctrl = controller();
    let mut node = ControllerNode::new(cfg);
    let mut out = Outbox::new();
    node.poll(&mut *ctrl, 0, &mut out);
    out.clear();
    node.on_message(&mut *ctrl, &target(3), 10, &mut out);
    assert_eq!(check_timeout(&node, &mut ctrl), 60);
    let commands: Vec<_> = out
        .iter()
        .filter_map(|e| match (e.node, e.msg) {
            (NodeId::Servo(j), Message::PressureCommand(p)) => Some((j, p)),
            _ => None,
        })
        .collect();
    let mut answers = Outbox::new();
    for (j, p) in commands {
        let status = ServoStatus {
            seq: p.seq,
            raw: p.raw,
            applied: p.raw,
            saturated: false,
            safe_state: SafeState::Normal,
        };
        node.on_message(
            &mut *ctrl,
            &Envelope::new(NodeId::Servo(j), status.into()),
            40,
            &mut answers,
        );
    }
    assert!(answers
        .iter()
        .any(|e| matches!(e.msg, Message::CaptureRequest(_))));
    assert_eq!(check_timeout(&node, &mut ctrl), 90);
    let repeat = polled(&node, &mut ctrl, 90);
    assert!(
        repeat
            .iter()
            .any(|e| matches!(e.msg, Message::CaptureRequest(_))),
        "{repeat:?}"
    );
}

/// While a save can make a step the node is due at once (a time already past), so a loop
/// that sleeps until `poll_timeout` runs the save's steps back to back instead of one per
/// heartbeat; once it is stored, only the heartbeat is due again. A node without a store
/// never stays due. Fails if a loop would wait a heartbeat period between save steps.
#[test]
fn a_save_in_progress_is_due_at_once() {
    use trn_controller::WithStore;
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
    let mut c = controller();
    let mut n = ControllerNode::new(NodeConfig::default());
    n.poll(&mut *c, 0, &mut out);
    let mature = trn_protocol::ModeChange {
        mode: trn_protocol::Mode::Mature,
    };
    n.on_message(
        &mut *c,
        &Envelope::new(NodeId::Controller, mature.into()),
        1,
        &mut out,
    );
    n.poll(&mut *c, 2, &mut out);
    assert_eq!(n.poll_timeout(), Some(100), "the heartbeat only");
}
