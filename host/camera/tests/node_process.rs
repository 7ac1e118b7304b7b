//! The `camera-node` process on a serial line, as a rig puts it on its bus: the recording in
//! host/camera/tests/recording (rendered by the simulator's `record` example, the lights'
//! true projections in its manifest) replayed through it, each capture requested over SLCAN
//! on a pseudo-terminal, each Observation decoded and held against the truth.

#![cfg(unix)]

use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use embedded_can::blocking::Can;
use serialport::{SerialPort, TTYPort};
use trn_camera::source::{Manifest, MANIFEST};
use trn_protocol::bus::ReceiveTimeout;
use trn_protocol::{
    BusMode, CaptureKind, CaptureRequest, Encoder, Envelope, Message, NodeId, Observation,
    PointStatus, Reassembler,
};
use trn_transport::slcan_serial::SerialSlcan;

fn recording() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/recording")
}

fn manifest(dir: &Path) -> Manifest {
    toml::from_str(&std::fs::read_to_string(dir.join(MANIFEST)).unwrap()).unwrap()
}

/// The node on one end of a pseudo-terminal pair, the test's port on the other.
struct Node {
    child: Child,
    port: SerialSlcan,
    enc: Encoder,
    rx: Reassembler,
    // the end the node opened by its path, kept open while it runs
    _theirs: TTYPort,
    heartbeats: usize,
}

impl Node {
    fn start(dir: &Path) -> Node {
        let (ours, theirs) = TTYPort::pair().expect("a pseudo-terminal pair");
        let path = theirs.name().expect("the pseudo-terminal's name");
        let child = Command::new(env!("CARGO_BIN_EXE_camera-node"))
            .args(["--slcan", &path, "--recording"])
            .arg(dir)
            .stderr(Stdio::piped())
            .spawn()
            .expect("camera-node starts");
        Node {
            child,
            port: SerialSlcan::on(Box::new(ours)),
            enc: Encoder::new(BusMode::Classic),
            rx: Reassembler::new(trn_protocol::DEFAULT_STALE_MS),
            _theirs: theirs,
            heartbeats: 0,
        }
    }

    fn send(&mut self, env: Envelope) {
        for f in &self.enc.encode(&env).unwrap() {
            self.port.transmit(f).unwrap();
        }
    }

    /// The next Observation, within 10 s (the node's first answer waits for its start).
    fn observation(&mut self) -> Observation {
        let deadline = Instant::now() + Duration::from_secs(10);
        let start = Instant::now();
        while Instant::now() < deadline {
            let Some(frame) = self
                .port
                .receive_timeout(Duration::from_millis(50))
                .unwrap()
            else {
                continue;
            };
            let now = start.elapsed().as_millis() as u32;
            match self.rx.push(&frame, now) {
                Ok(Some(Envelope {
                    node: NodeId::CameraProcessor,
                    msg: Message::Observation(o),
                })) => return o,
                Ok(Some(Envelope {
                    node: NodeId::CameraProcessor,
                    msg: Message::Heartbeat(_),
                })) => self.heartbeats += 1,
                Ok(_) => {}
                Err(e) => panic!("a frame no message's: {e:?}"),
            }
        }
        panic!("no Observation within 10 s")
    }

    fn capture(&mut self, seq: u16, what: CaptureKind) -> Observation {
        self.send(Envelope::new(
            NodeId::CameraProcessor,
            CaptureRequest { seq, what }.into(),
        ));
        self.observation()
    }

    /// SIGTERM, then its exit status and what it wrote.
    fn stop(mut self) -> String {
        let pid = self.child.id() as i32;
        // SAFETY-free: kill(2) through the command line
        Command::new("kill")
            .args(["-TERM", &pid.to_string()])
            .status()
            .unwrap();
        let status = self.child.wait().unwrap();
        let mut err = String::new();
        self.child
            .stderr
            .take()
            .unwrap()
            .read_to_string(&mut err)
            .unwrap();
        assert!(status.success(), "camera-node ended with {status}: {err}");
        err
    }
}

/// Fails if a capture is answered with another seq or kind, a light seen in a frame of the
/// recording in clear view is not valid or lies more than 0.1 px from its true projection, one
/// partly hidden is read farther off than a valid point may be (1 px + 6 sigma), one hidden
/// or outside the frames is not reported not detected, the recording has no such light, a
/// repeated
/// request gets another observation, or the node does not end cleanly on SIGTERM with its
/// counters. Prints the centroid errors' median, 95th percentile and largest.
#[test]
fn a_recorded_sequence_replayed_through_the_node_gives_the_lights_where_they_are() {
    let dir = recording();
    let m = manifest(&dir);
    let mut node = Node::start(&dir);
    let (mut errors, mut partial, mut unseen) = (Vec::new(), Vec::new(), 0);
    let tolerance = 1.0 + 6.0 * m.calibration.as_ref().unwrap().pixel_noise_px;
    for (i, c) in m.captures.iter().enumerate() {
        let seq = 100 + i as u16;
        let o = node.capture(seq, c.what);
        assert_eq!((o.seq, o.what), (seq, c.what), "capture {i}");
        for (k, (p, t)) in o.used_points().iter().zip(&c.truth).enumerate() {
            match t.status {
                PointStatus::Valid => {}
                PointStatus::Occluded if p.status == PointStatus::Valid => {
                    // hidden in part: a valid reading must still be one (SPEC.md 3: within
                    // 1 px + 6 sigma of where the light projects)
                    let e = (p.x as f64 - t.x).hypot(p.y as f64 - t.y);
                    assert!(e <= tolerance, "capture {i} point {k}: {e} px off");
                    partial.push(e);
                    continue;
                }
                _ => {
                    // outside the frame (the recording's frames are the middle of the
                    // plant's image) or hidden: on pixels alone, not detected
                    assert_eq!(p.status, PointStatus::NotDetected, "capture {i} point {k}");
                    unseen += 1;
                    continue;
                }
            }
            assert_eq!(p.status, PointStatus::Valid, "capture {i} point {k}: {p:?}");
            let e = (p.x as f64 - t.x).hypot(p.y as f64 - t.y);
            assert!(e < 0.1, "capture {i} point {k}: {e} px from the truth");
            errors.push(e);
        }
        if i == 1 {
            // the observation lost: the request again gets the same one
            let again = node.capture(seq, c.what);
            assert_eq!(again, o);
        }
    }
    errors.sort_by(f64::total_cmp);
    let q = |f: f64| errors[((errors.len() - 1) as f64 * f).round() as usize];
    println!(
        "{} points in clear view: centroid error p50 {:.4} px, p95 {:.4} px, max {:.4} px; \
         {} partly hidden and read (errors {partial:.3?} px); {unseen} hidden or outside the frames, reported not detected",
        errors.len(),
        q(0.5),
        q(0.95),
        q(1.0),
        partial.len()
    );
    assert!(unseen > 0, "the recording has no light outside its frames");
    let log = node.stop();
    let n = m.captures.len();
    assert!(
        log.contains(&format!("{n} captures (0 failed, 1 repeated, 0 stale)")),
        "{log}"
    );
}

/// Fails if a capture whose frames do not show each light's code (one camera's second frame
/// replaced by its first: light p then reads as lit in both frames, light q in none) is
/// passed on with a valid point for that camera, if a light valid in one camera alone
/// is refused, or if a request beyond the recording goes unanswered.
#[test]
fn a_capture_whose_codes_do_not_read_is_refused_not_swapped() {
    let dir = std::env::temp_dir().join(format!("trn-camera-swapped-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).unwrap();
    for e in std::fs::read_dir(recording()).unwrap() {
        let e = e.unwrap();
        std::fs::copy(e.path(), dir.join(e.file_name())).unwrap();
    }
    let m = manifest(&dir);
    let c = &m.captures[0];
    assert_eq!(c.what, CaptureKind::GripperLights);
    std::fs::copy(dir.join(&c.cam1[0]), dir.join(&c.cam1[1])).unwrap();
    let mut node = Node::start(&dir);
    let o = node.capture(1, c.what);
    let status: Vec<PointStatus> = o.points.iter().map(|p| p.status).collect();
    assert_eq!(
        status,
        [
            PointStatus::Valid,
            PointStatus::NotDetected,
            PointStatus::Valid,
            PointStatus::NotDetected
        ]
    );
    // the rest served, then one more than the recording has: answered, not detected
    for (i, c) in m.captures.iter().enumerate().skip(1) {
        node.capture(1 + i as u16, c.what);
    }
    let n = m.captures.len() as u16;
    let o = node.capture(1 + n, CaptureKind::GripperLights);
    assert!(o
        .points
        .iter()
        .all(|p| p.status == PointStatus::NotDetected));
    assert!(node.heartbeats > 0, "no heartbeat heard");
    let log = node.stop();
    assert!(log.contains("were all served"), "{log}");
    let _ = std::fs::remove_dir_all(&dir);
}
