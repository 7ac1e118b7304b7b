//! `trn eval --external-controller` against an outside controller: a small one written here
//! from protocol/SPEC.md (the framing is the protocol crate's; what it answers, and its
//! fingerprint, come from the spec), on the serial SLCAN bus of a pseudo-terminal pair. It
//! answers the tables' status, echoes the session's configuration and modes, and beats; it
//! runs no trial (the evaluation has 0 targets and 0 grasps). Its fingerprint for the one
//! configuration it runs (the project preset, no ablation, the TRN, 1024 x 768 images) is the
//! CRC-32 of SPEC.md 3.2.1's test vector, or a number of its own.
//!
//! The runner (SPEC.md 3.5, "What the host checks of the fingerprint") keeps tables whose
//! announced fingerprint is the run's configuration's, seeds new ones under the run's when
//! the tables never learned under another, then checks the fingerprint announced for the
//! configuration accepted; anything else is refused naming both numbers.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use embedded_can::blocking::Can;
use serialport::{SerialPort, TTYPort};
use trn_bench::schedule::Plan;
use trn_bench::{run, Command, RunSpec};
use trn_protocol::bus::ReceiveTimeout;
use trn_protocol::{
    BusMode, Encoder, Envelope, ErrorReport, Heartbeat, Message, NodeId, NodeState, Reassembler,
    SessionConfig, StoreOp, TablesEvent, TablesStatus, DEFAULT_STALE_MS,
};
use trn_transport::slcan_serial::SerialSlcan;
use trn_transport::BusSpec;

/// SPEC.md 3.2.1's test vector: the bytes of the project preset's configuration (no
/// ablation, the TRN, 1024 x 768 images), read from the spec itself.
fn spec_vector() -> Vec<u8> {
    let spec = include_str!("../../../protocol/SPEC.md");
    let from = spec
        .find("**Test vector**")
        .expect("SPEC.md 3.2.1 has a test vector");
    let block = &spec[from..];
    let start = block.find("```text\n").unwrap() + "```text\n".len();
    let end = start + block[start..].find("```").unwrap();
    let hex: String = block[start..end].split_whitespace().collect();
    (0..hex.len())
        .step_by(2)
        .map(|i| u8::from_str_radix(&hex[i..i + 2], 16).unwrap())
        .collect()
}

/// The fingerprint by SPEC.md 3.2.1: CRC-32/ISO-HDLC of the configuration's bytes.
fn spec_fingerprint() -> u32 {
    let bytes = spec_vector();
    assert_eq!(bytes.len(), 305, "the spec's vector is 305 bytes");
    crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC).checksum(&bytes)
}

/// A fingerprint of the controller's own: the CRC of all but the vector's last byte (a
/// formula that is not the spec's).
fn own_fingerprint() -> u32 {
    let bytes = spec_vector();
    crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC).checksum(&bytes[..bytes.len() - 1])
}

/// What the outside controller holds and how it computes its fingerprint.
#[derive(Debug, Clone, Copy)]
struct Outside {
    /// The fingerprint its tables announce before any session (0: no configuration yet).
    fingerprint: u32,
    /// Their learning steps.
    steps: (u32, u32),
    /// The fingerprint it computes for the configuration it runs.
    computes: u32,
}

/// The image length of tables that never learned (SPEC.md 3.5).
const IMAGE_LEN: u32 = 227_226;
/// `CONFIG_REJECTED` (SPEC.md 7).
const CONFIG_REJECTED: u16 = 0x010A;

/// What the controller saw: the session configurations it accepted.
#[derive(Debug, Default)]
struct Seen {
    accepted: Vec<SessionConfig>,
}

fn send(port: &mut SerialSlcan, enc: &mut Encoder, node: NodeId, msg: Message) {
    for f in enc.encode(&Envelope::new(node, msg)).unwrap().iter() {
        port.transmit(f).unwrap();
    }
}

/// The controller's loop on `port` until `stop`.
fn serve(mut port: SerialSlcan, mut me: Outside, stop: Arc<AtomicBool>, seen: Arc<Mutex<Seen>>) {
    let mut enc = Encoder::new(BusMode::Classic);
    let mut rx: Reassembler = Reassembler::new(DEFAULT_STALE_MS);
    let start = Instant::now();
    let mut beat: Option<Instant> = None;
    let mut counter = 0u8;
    while !stop.load(Ordering::Relaxed) {
        if beat.is_none_or(|b| b.elapsed() >= Duration::from_millis(100)) {
            beat = Some(Instant::now());
            counter = counter.wrapping_add(1);
            let hb = Heartbeat {
                counter,
                state: NodeState::Operational,
            };
            send(&mut port, &mut enc, NodeId::Controller, hb.into());
        }
        let Ok(Some(frame)) = port.receive_timeout(Duration::from_millis(10)) else {
            continue;
        };
        let now_ms = start.elapsed().as_millis() as u32;
        let Ok(Some(env)) = rx.push(&frame, now_ms) else {
            continue;
        };
        if env.node != NodeId::Controller {
            continue;
        }
        match env.msg {
            Message::StoreCommand(c) if c.op == StoreOp::Status => {
                let s = TablesStatus {
                    event: TablesEvent::Status,
                    image_len: IMAGE_LEN,
                    fingerprint: me.fingerprint,
                    steps1: me.steps.0,
                    steps2: me.steps.1,
                    stored_sequence: 0,
                };
                send(&mut port, &mut enc, NodeId::Controller, s.into());
            }
            Message::SessionConfig(c) => {
                let runs = (c.preset, c.ablation, c.image_width, c.image_height, c.law)
                    == (0, 0, 1024, 768, 0);
                let learned = me.steps != (0, 0);
                let detail = if !runs {
                    Some(4)
                } else if c.keep_tables && me.fingerprint != me.computes {
                    Some(2)
                } else if !c.keep_tables && learned {
                    // its guard: never exercised here
                    Some(1)
                } else {
                    None
                };
                match detail {
                    Some(detail) => {
                        let e = ErrorReport {
                            code: CONFIG_REJECTED,
                            detail,
                        };
                        send(&mut port, &mut enc, NodeId::Controller, e.into());
                    }
                    None => {
                        if !c.keep_tables {
                            me.fingerprint = me.computes;
                            me.steps = (0, 0);
                        }
                        seen.lock().unwrap().accepted.push(c);
                        send(&mut port, &mut enc, NodeId::Broadcast, c.into());
                    }
                }
            }
            Message::ModeChange(m) => send(&mut port, &mut enc, NodeId::Broadcast, m.into()),
            _ => {}
        }
    }
}

/// `trn eval --external-controller --bus slcan:PTY --eval-targets 0 --grasps 0` against
/// `outside`: the run's outcome and the configurations the controller accepted.
fn eval(outside: Outside) -> (Result<trn_bench::Report, String>, Vec<SessionConfig>) {
    let (adapter, ours) = TTYPort::pair().expect("a pseudo-terminal pair");
    let path = ours.name().expect("the pseudo-terminal's name");
    let stop = Arc::new(AtomicBool::new(false));
    let seen = Arc::new(Mutex::new(Seen::default()));
    let controller = {
        let (stop, seen) = (stop.clone(), seen.clone());
        std::thread::spawn(move || serve(SerialSlcan::on(Box::new(adapter)), outside, stop, seen))
    };
    let mut spec = RunSpec::new(Command::Eval, 100);
    spec.plan = Plan::new(0, 0, 0);
    spec.bus.spec = BusSpec::SlcanSerial(path);
    spec.bus.external_controller = true;
    let outcome = run::run_quietly(&spec).map_err(|e| e.to_string());
    stop.store(true, Ordering::Relaxed);
    controller.join().unwrap();
    drop(ours);
    let accepted = std::mem::take(&mut seen.lock().unwrap().accepted);
    (outcome, accepted)
}

#[test]
fn the_spec_vector_is_the_project_presets_configuration() {
    // the same number SPEC.md 3.2.1 prints beside the vector
    assert_eq!(spec_fingerprint(), 0xf7f7_b721);
    assert_ne!(own_fingerprint(), spec_fingerprint());
}

/// Learned tables announced with the spec's fingerprint of the run's configuration are
/// evaluated as they are (`keep_tables = true`).
#[test]
fn an_outside_controller_with_the_spec_fingerprint_is_evaluated() {
    let (outcome, accepted) = eval(Outside {
        fingerprint: spec_fingerprint(),
        steps: (40, 10),
        computes: spec_fingerprint(),
    });
    let report = outcome.unwrap();
    assert_eq!(report.controller_protocol, Some(4));
    assert_eq!(accepted.len(), 1, "{accepted:?}");
    assert!(accepted[0].keep_tables, "its tables kept");
}

/// A controller whose tables never learned and that holds no configuration yet (it
/// announces fingerprint 0: SPEC.md gives no host controller's reset configuration) was
/// refused as "learned under another configuration": it is evaluated on new tables seeded
/// under the run's configuration, whose fingerprint it then announces.
#[test]
fn an_outside_controller_that_never_learned_is_evaluated_under_the_runs_configuration() {
    let (outcome, accepted) = eval(Outside {
        fingerprint: 0,
        steps: (0, 0),
        computes: spec_fingerprint(),
    });
    let report = outcome.unwrap();
    assert_eq!(report.controller_protocol, Some(4));
    assert_eq!(accepted.len(), 1, "{accepted:?}");
    assert!(!accepted[0].keep_tables, "new tables seeded");
    assert_eq!(accepted[0].seed, 100);
}

/// A fingerprint of the controller's own formula is refused, naming its number and the
/// spec's: on learned tables before anything changes, on tables that never learned once it
/// announces it for the configuration it accepted.
#[test]
fn a_fingerprint_not_the_specs_is_refused_naming_both_numbers() {
    let numbers = [
        format!("{:#010x}", own_fingerprint()),
        format!("{:#010x}", spec_fingerprint()),
    ];
    for (steps, before) in [((40, 10), own_fingerprint()), ((0, 0), 0)] {
        let (outcome, accepted) = eval(Outside {
            fingerprint: before,
            steps,
            computes: own_fingerprint(),
        });
        let e = outcome.unwrap_err();
        assert!(numbers.iter().all(|n| e.contains(n)), "{steps:?}: {e}");
        assert!(e.contains("SPEC.md 3.2.1"), "{e}");
        let kept = accepted.iter().any(|c| c.keep_tables);
        assert!(
            !kept,
            "{steps:?}: the held tables were not kept: {accepted:?}"
        );
    }
}
