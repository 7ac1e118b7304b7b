//! A servo drive that loses the controller heartbeat enters its safe state and says so
//! on the bus (in-process bus, simulated clock).

use embedded_can::blocking::Can;
use trn_protocol::bus::InProcBus;
use trn_protocol::heartbeat::DEFAULT_PERIOD_MS;
use trn_protocol::*;

fn run(action: SafeStateAction) -> (u32, Envelope, u32) {
    let bus = InProcBus::new(BusMode::Classic, 3);
    let mut controller = bus.port();
    let mut servo = bus.port();
    let servo_node = NodeId::servo(3).unwrap();
    let mut enc_c = Encoder::new(BusMode::Classic);
    let mut enc_s = Encoder::new(BusMode::Classic);
    let mut rx_c: Reassembler = Reassembler::new(DEFAULT_STALE_MS);
    let mut rx_s: Reassembler = Reassembler::new(DEFAULT_STALE_MS);
    let mut hb = HeartbeatSender::new(DEFAULT_PERIOD_MS, 0);
    let mut monitor = HeartbeatMonitor::new(
        HeartbeatConfig {
            action,
            ..HeartbeatConfig::default()
        },
        0,
    );
    let mut last_raw = 0u16;
    let mut last_heartbeat_sent = 0;
    let mut entered_at = None;
    let mut announced = None;
    for t in (0..3000u32).step_by(10) {
        // Controller: heartbeats and a pressure command until it "crashes" at 1000 ms.
        if t < 1000 {
            if let Some(m) = hb.poll(t, NodeState::Operational) {
                for f in &enc_c.encode(&Envelope::new(NodeId::Controller, m)).unwrap() {
                    controller.transmit(f).unwrap();
                }
                last_heartbeat_sent = t;
            }
            let cmd = PressureCommand {
                seq: t as u16,
                raw: 1000 + (t % 1000) as u16,
            };
            for f in &enc_c
                .encode(&Envelope::new(servo_node, cmd.into()))
                .unwrap()
            {
                controller.transmit(f).unwrap();
            }
        }
        // Servo drive.
        while let Some(f) = servo.try_receive() {
            if let Some(env) = rx_s.push(&f, t).unwrap() {
                monitor.observe(&env, NodeId::Controller, t);
                if let (Message::PressureCommand(c), false) = (env.msg, monitor.is_safe()) {
                    last_raw = c.raw;
                }
            }
        }
        if let Some(HeartbeatEvent::EnteredSafeState(a)) = monitor.poll(t) {
            assert_eq!(a, action);
            entered_at = Some(t);
            let msg = monitor.safe_state_message(last_raw);
            for f in &enc_s.encode(&Envelope::new(servo_node, msg)).unwrap() {
                servo.transmit(f).unwrap();
            }
        }
        // Controller side (or the runner) listens.
        while let Some(f) = controller.try_receive() {
            if let Some(env) = rx_c.push(&f, t).unwrap() {
                assert!(announced.is_none(), "announced once");
                announced = Some(env);
            }
        }
    }
    let entered_at = entered_at.expect("safe state entered");
    assert!(entered_at > last_heartbeat_sent + 500 && entered_at <= last_heartbeat_sent + 510);
    (
        entered_at,
        announced.expect("announcement received"),
        last_raw as u32,
    )
}

#[test]
fn hold_last_is_entered_and_announced() {
    let (_, env, last_raw) = run(SafeStateAction::HoldLast);
    assert_eq!(env.node, NodeId::servo(3).unwrap());
    assert_eq!(
        env.msg,
        Message::SafeStateEntered(SafeStateEntered {
            reason: SafeStateReason::HeartbeatLost,
            action: SafeStateAction::HoldLast,
            held_raw: last_raw as u16,
        })
    );
    assert_eq!(last_raw, 1000 + 990);
}

#[test]
fn vent_is_entered_and_announced() {
    let (_, env, _) = run(SafeStateAction::Vent);
    match env.msg {
        Message::SafeStateEntered(s) => {
            assert_eq!(s.action, SafeStateAction::Vent);
            assert_eq!(s.held_raw, heartbeat::VENT_RAW);
        }
        other => panic!("{other:?}"),
    }
}
