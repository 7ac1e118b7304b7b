//! SocketCAN over a virtual interface. The `#[ignore]`d tests need `vcan0` with MTU 72
//! (CAN FD) and are run by the VM harness:
//!
//! ```text
//! ip link add dev vcan0 type vcan && ip link set vcan0 mtu 72 && ip link set up vcan0
//! cargo test -p trn-protocol --features socketcan --test vcan -- --include-ignored
//! ```
//!
//! They fail (not skip) when the interface is missing. `TRN_VCAN` overrides the name.
#![cfg(target_os = "linux")]

use std::time::{Duration, Instant};

use embedded_can::blocking::Can;
use trn_protocol::bus::{ReceiveTimeout, RecordingPort, SocketCanPort};
use trn_protocol::*;

fn iface() -> String {
    std::env::var("TRN_VCAN").unwrap_or_else(|_| "vcan0".to_owned())
}

fn open() -> SocketCanPort {
    let name = iface();
    SocketCanPort::open(&name).unwrap_or_else(|e| {
        panic!("{name} is required for this test (ip link add dev {name} type vcan): {e}")
    })
}

fn drain(p: &mut SocketCanPort) {
    while p
        .receive_timeout(Duration::from_millis(10))
        .unwrap()
        .is_some()
    {}
}

fn traffic() -> Vec<Envelope> {
    vec![
        Envelope::new(
            NodeId::servo(2).unwrap(),
            PressureCommand { seq: 9, raw: 4095 }.into(),
        ),
        Envelope::new(
            NodeId::Controller,
            Heartbeat {
                counter: 3,
                state: NodeState::Operational,
            }
            .into(),
        ),
        Envelope::new(
            NodeId::CameraProcessor,
            Observation {
                seq: 4,
                what: CaptureKind::GripperLights,
                points: [
                    PixelPoint::valid(1.5, 2.5),
                    PixelPoint::valid(3.5, 4.5),
                    PixelPoint {
                        x: 0.0,
                        y: 0.0,
                        status: PointStatus::Occluded,
                    },
                    PixelPoint::valid(7.5, 8.5),
                ],
            }
            .into(),
        ),
        Envelope::new(
            NodeId::Controller,
            Stage1Target {
                trial: 77,
                learn: true,
                grasp: false,
                fine_moves: trn_protocol::FINE_MOVES_POLICY,
                v: [10.0; 8],
            }
            .into(),
        ),
    ]
}

fn send_and_receive(mode: BusMode) {
    let mut a = open();
    let mut b = open();
    drain(&mut b);
    let mut enc = Encoder::new(mode);
    let mut rx: Reassembler = Reassembler::new(DEFAULT_STALE_MS);
    for env in traffic() {
        let frames = enc.encode(&env).unwrap();
        for f in &frames {
            a.transmit(f).unwrap();
        }
        let mut got = None;
        for _ in 0..frames.len() {
            let f = b
                .receive_timeout(Duration::from_secs(2))
                .unwrap()
                .expect("frame not received within 2 s");
            assert_eq!(f.is_fd(), mode == BusMode::Fd);
            got = rx.push(&f, 0).unwrap();
        }
        assert_eq!(got, Some(env));
    }
}

#[test]
fn missing_interface_is_a_clear_error() {
    let e = SocketCanPort::open("trnnone9").unwrap_err();
    assert_eq!(e, Error::InterfaceNotFound("trnnone9".try_into().unwrap()));
    assert!(e.to_string().contains("trnnone9"));
}

#[test]
#[ignore = "needs vcan0: run by the VM harness"]
fn classic_traffic_over_vcan() {
    send_and_receive(BusMode::Classic);
}

#[test]
#[ignore = "needs vcan0: run by the VM harness"]
fn fd_traffic_over_vcan() {
    send_and_receive(BusMode::Fd);
}

#[test]
#[ignore = "needs vcan0: run by the VM harness"]
fn nb_receive_and_timeout() {
    let mut a = open();
    let mut b = open();
    drain(&mut b);
    assert!(matches!(
        embedded_can::nb::Can::receive(&mut b),
        Err(nb::Error::WouldBlock)
    ));
    let t = Instant::now();
    assert_eq!(b.receive_timeout(Duration::from_millis(50)).unwrap(), None);
    assert!(t.elapsed() >= Duration::from_millis(40));
    let f = CanFrame::classic(0x701, &[1, 1]).unwrap();
    embedded_can::nb::Can::transmit(&mut a, &f).unwrap();
    let deadline = Instant::now() + Duration::from_secs(2);
    loop {
        match embedded_can::nb::Can::receive(&mut b) {
            Ok(g) => {
                assert_eq!(g, f);
                break;
            }
            Err(nb::Error::WouldBlock) if Instant::now() < deadline => {
                std::thread::sleep(Duration::from_millis(1))
            }
            Err(e) => panic!("{e:?}"),
        }
    }
}

#[test]
#[ignore = "needs vcan0: run by the VM harness"]
fn record_and_replay_over_vcan() {
    let mut t = 0u64;
    let mut rec = RecordingPort::new(open(), Vec::new(), &iface(), move || {
        t += 1;
        t
    });
    let frames = [
        CanFrame::classic(0x082, &[1, 0, 0, 8]).unwrap(),
        CanFrame::fd(0x111, &[5; 48]).unwrap(),
    ];
    for f in &frames {
        rec.transmit(f).unwrap();
    }
    let (_, log) = rec.into_parts().unwrap();
    let mut player = open();
    let mut listener = open();
    drain(&mut listener);
    assert_eq!(candump::replay(&log[..], &mut player).unwrap(), 2);
    for f in &frames {
        assert_eq!(
            listener.receive_timeout(Duration::from_secs(2)).unwrap(),
            Some(*f)
        );
    }
}
