use super::*;
use crate::processor::Calibration;
use crate::source::{AnyFrame, CaptureFrames, Recording};
use crate::CameraError;
use std::path::Path;
use trn_protocol::{CaptureKind, CaptureRequest, PointStatus, SessionConfig};
use trn_vision::{CaptureProtocol, Emitter, Renderer, Sensor};

/// p and q, where the rendered frames show them (both cameras alike).
const LIGHTS: [[f64; 2]; 2] = [[40.3, 30.6], [80.8, 52.2]];

/// Rendered captures of [`LIGHTS`] (or the first alone), counted; `fail` makes every capture
/// an error.
struct Rendered {
    captures: usize,
    fail: bool,
}

impl FrameSource for Rendered {
    fn capture(&mut self, what: CaptureKind) -> Result<CaptureFrames, CameraError> {
        self.captures += 1;
        if self.fail {
            return Err(CameraError::Source("the camera is gone".into()));
        }
        let n = crate::source::lights_of(what);
        let protocol = CaptureProtocol::sequential(n)?;
        let renderer = Renderer::<u8>::new(&Sensor::machine_vision(128, 96))?;
        let spots: Vec<Emitter> = LIGHTS[..n]
            .iter()
            .map(|&c| Emitter::new(c, 1.3, 30_000.0))
            .collect();
        let mut cameras = [Vec::new(), Vec::new()];
        for (cam, frames) in cameras.iter_mut().enumerate() {
            for (f, s) in protocol.scenes(&spots, &[])?.iter().enumerate() {
                let seed = (self.captures * 16 + cam * 4 + f) as u64;
                frames.push(AnyFrame::U8(renderer.render(s, seed)?));
            }
        }
        Ok(CaptureFrames {
            what,
            protocol,
            cameras,
        })
    }
}

fn node(fail: bool) -> CameraNode<Rendered> {
    let p = Processor::new(Default::default(), 3.0, None).unwrap();
    CameraNode::new(Rendered { captures: 0, fail }, p, 0)
}

fn request(seq: u16, what: CaptureKind) -> Envelope {
    Envelope::new(NodeId::CameraProcessor, CaptureRequest { seq, what }.into())
}

fn observation(out: &[Envelope]) -> Observation {
    match out {
        [Envelope {
            node: NodeId::CameraProcessor,
            msg: Message::Observation(o),
        }] => *o,
        other => panic!("not one observation: {other:?}"),
    }
}

/// Fails if the answer has another seq or kind, a light is not valid or lies 0.1 px or more
/// from where the frames show it, or the unused slots of a centre observation are not
/// `UNUSED`.
#[test]
fn a_request_is_answered_with_its_seq_and_the_lights_where_they_are() {
    let mut n = node(false);
    let mut out = Vec::new();
    assert!(matches!(
        n.on_message(&request(7, CaptureKind::GripperLights), &mut out),
        Served::Capture(_)
    ));
    let o = observation(&out);
    assert_eq!((o.seq, o.what), (7, CaptureKind::GripperLights));
    for (k, p) in o.points.iter().enumerate() {
        let [x, y] = LIGHTS[k / 2];
        assert_eq!(p.status, PointStatus::Valid, "{k}");
        assert!(((p.x as f64) - x).hypot(p.y as f64 - y) < 0.1, "{k}: {p:?}");
    }
    out.clear();
    n.on_message(&request(8, CaptureKind::GripperCentre), &mut out);
    let o = observation(&out);
    assert_eq!(o.points[0].status, PointStatus::Valid);
    assert_eq!(o.points[1].status, PointStatus::Valid);
    assert_eq!(&o.points[2..], &[PixelPoint::UNUSED; 2]);
    assert_eq!(n.stats().captures, 2);
    assert_eq!(n.stats().valid_points, 6);
}

/// Fails if a repeated request takes a new capture or gets another observation, or if an
/// older one is answered.
#[test]
fn a_repeat_gets_the_same_observation_and_an_older_request_nothing() {
    let mut n = node(false);
    let mut out = Vec::new();
    n.on_message(&request(0xFFFF, CaptureKind::GripperLights), &mut out);
    let first = observation(&out);
    out.clear();
    assert_eq!(
        n.on_message(&request(0xFFFF, CaptureKind::GripperLights), &mut out),
        Served::Repeat
    );
    assert_eq!(observation(&out), first);
    assert_eq!(n.source().captures, 1);
    out.clear();
    // the counter wraps: 0 is newer than 0xFFFF, 0xFFFE older
    assert_eq!(
        n.on_message(&request(0xFFFE, CaptureKind::GripperLights), &mut out),
        Served::Stale
    );
    assert!(out.is_empty());
    assert!(matches!(
        n.on_message(&request(0, CaptureKind::GripperLights), &mut out),
        Served::Capture(_)
    ));
    assert_eq!(n.source().captures, 2);
    let s = n.stats();
    assert_eq!((s.captures, s.repeats, s.stale), (2, 1, 1));
}

/// Fails if a capture that cannot be had goes unanswered, is answered with a valid point, or
/// is not counted.
#[test]
fn a_capture_that_cannot_be_had_is_answered_with_its_lights_not_detected() {
    let mut n = node(true);
    let mut out = Vec::new();
    let served = n.on_message(&request(3, CaptureKind::GripperLights), &mut out);
    assert_eq!(served, Served::Failed("the camera is gone".into()));
    let o = observation(&out);
    assert_eq!(o.seq, 3);
    assert!(o
        .points
        .iter()
        .all(|p| p.status == PointStatus::NotDetected));
    assert_eq!((n.stats().captures, n.stats().failed), (0, 1));
}

/// Fails if the node does not follow the session's choice of CAN FD, or answers messages
/// that are not capture requests to it.
#[test]
fn the_session_decides_the_frames() {
    let mut n = node(false);
    let mut out = Vec::new();
    let mut s = SessionConfig {
        seed: 1,
        preset: 0,
        ablation: 0,
        image_width: 1024,
        image_height: 768,
        fd: true,
        keep_tables: false,
        law: 0,
    };
    assert_eq!(n.mode(), BusMode::Classic);
    n.on_message(&Envelope::new(NodeId::Controller, s.into()), &mut out);
    assert_eq!(n.mode(), BusMode::Fd);
    s.fd = false;
    n.on_message(&Envelope::new(NodeId::Controller, s.into()), &mut out);
    assert_eq!(n.mode(), BusMode::Classic);
    // a capture request to the controller's node id is not the camera's
    let to_controller = Envelope::new(
        NodeId::Controller,
        CaptureRequest {
            seq: 1,
            what: CaptureKind::GripperLights,
        }
        .into(),
    );
    let _ = n.on_message(&to_controller, &mut out);
    assert!(out.is_empty());
}

/// Fails if heartbeats are not sent every 100 ms from the start, or `poll_timeout` does not
/// say when the next is due.
#[test]
fn a_heartbeat_every_100_ms() {
    let mut n = node(false);
    let mut out = Vec::new();
    for t in [0, 50, 99, 100, 150, 230] {
        n.poll(t, &mut out);
    }
    let counters: Vec<u8> = out
        .iter()
        .map(|e| match (e.node, e.msg) {
            (NodeId::CameraProcessor, Message::Heartbeat(h)) => {
                assert_eq!(h.state, NodeState::Operational);
                h.counter
            }
            other => panic!("{other:?}"),
        })
        .collect();
    assert_eq!(counters, [0, 1, 2]);
    assert_eq!(n.poll_timeout(), 330);
}

/// Fails if the recording's first capture is not read whole with its calibration, or if a
/// calibration that turns camera 1 (about 3.5 degrees up) does not turn its lights not detected (and count
/// them).
#[test]
fn the_stereo_check_refuses_readings_that_are_not_one_point() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/recording");
    let recording = Recording::open(&dir).unwrap();
    let mut k = recording.manifest().calibration.clone().unwrap();
    let read = |k: &crate::source::CalibrationConfig| {
        let p =
            Processor::new(Default::default(), 3.0, Some(Calibration::new(k).unwrap())).unwrap();
        p.observe(&recording.frames(0).unwrap()).unwrap()
    };
    let o = read(&k);
    assert_eq!(o.inconsistent, 0);
    assert!(o.points.iter().all(|p| p.status == PointStatus::Valid));
    k.cameras[1].look_at_mm[2] += 100.0;
    let o = read(&k);
    assert_eq!(o.inconsistent, 2);
    assert!(o
        .points
        .iter()
        .all(|p| p.status == PointStatus::NotDetected));
}
