//! The camera processor as a sans-IO node: a `CaptureRequest` lets the arm settle, reads the
//! requested lights in both cameras and answers with an `Observation` of the same `seq`.

use trn_protocol as proto;
use trn_protocol::{CaptureKind, Envelope, Message, NodeId, PixelPoint};

use super::Outbox;
use crate::{Plant, Pose, Readings};

/// What a capture saw, with the ground truth beside it (for scoring only: the controller
/// gets the noisy readings).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Sight {
    /// The gripper lights p and q (stage 1).
    Lights {
        /// As sent to the controller.
        noisy: Readings<4>,
        /// Noise-free projections.
        truth: Readings<4>,
    },
    /// The gripper-centre light (stage 2).
    Centre {
        /// As sent.
        noisy: Readings<2>,
        /// Noise-free.
        truth: Readings<2>,
    },
}

/// One served capture request: a move of the controller, as the runner scores it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Capture {
    /// The request's sequence number.
    pub seq: u16,
    /// The readings.
    pub sight: Sight,
    /// The gripper's pose when the reading was taken (ground truth).
    pub pose: Pose,
    /// The plant's simulated time when the reading was taken, after the settle (s).
    pub time_s: f64,
    /// What the camera processor saw before filling in hidden lights, and why it could not
    /// fill one in (for diagnosis: the controller gets the readings only).
    pub fill: crate::markers::Fill,
}

/// The camera processor (both cameras).
#[derive(Debug, Clone, Default)]
pub struct CameraProcessor {
    captures: u64,
    /// The trial whose target it heard last.
    trial: Option<u32>,
    /// Where the gripper's markers were at the trial's last capture, and where its targets
    /// show them (a marker fit's start, and its prior where the readings say nothing).
    tracker: crate::markers::Tracker,
    /// The last observation sent, to send again when its request is repeated.
    last: Option<proto::Observation>,
    /// A point to report invalid in the next new capture (a fault injected by a test).
    spoil: Option<(usize, proto::PointStatus)>,
}

/// What a message was for the camera processor.
#[derive(Debug, Clone, PartialEq)]
pub enum Served {
    /// Not a capture request for it.
    Nothing,
    /// A new capture: the arm settled, both cameras read.
    Capture(Box<Capture>),
    /// A repeat of the last request (its observation was lost): the same observation sent
    /// again, no new reading.
    Repeat,
    /// An older request (late or reordered): ignored.
    Stale,
}

/// The protocol's points for plant readings: a valid or estimated reading as is; an invalid
/// one as `(0, 0)` with its status (out of view, occluded, not detected).
pub fn points_of<const K: usize>(r: &Readings<K>) -> [PixelPoint; 4] {
    let mut points = [PixelPoint::UNUSED; 4];
    for (p, r) in points.iter_mut().zip(r.points.iter()) {
        let status = r.status;
        let located = matches!(
            status,
            proto::PointStatus::Valid | proto::PointStatus::Estimated
        );
        *p = if located && r.x.is_finite() && r.y.is_finite() {
            PixelPoint {
                x: r.x as f32,
                y: r.y as f32,
                status,
            }
        } else {
            PixelPoint {
                x: 0.0,
                y: 0.0,
                status: if located {
                    proto::PointStatus::NotDetected
                } else {
                    status
                },
            }
        };
    }
    points
}

impl CameraProcessor {
    /// A camera processor.
    pub fn new() -> Self {
        Self::default()
    }

    /// Makes the next new capture report point `index` (0..4) as invalid with `status`
    /// (x = y = 0), whatever the cameras see: a fault the conformance suite injects.
    pub fn spoil_next(&mut self, index: usize, status: proto::PointStatus) {
        self.spoil = Some((index, status));
    }

    /// A trial's start heard on the bus (the runner's `GraspRequest`, `Stage1Target`,
    /// `Stage2Target`; a repeat of the trial in progress changes nothing). A new trial ends
    /// the track of the last one, which says nothing of where the arm is now (the runner
    /// moved it); until the trial's first capture the track is where its target shows the
    /// markers (triangulated from the target message), the place the coarse move aims at.
    fn hear_target(&mut self, plant: &Plant, msg: &Message) {
        let (trial, lights, centre) = match msg {
            Message::GraspRequest(g) => (g.trial, None, None),
            Message::Stage1Target(t) => (t.trial, plant.target_track(&t.v), None),
            Message::Stage2Target(t) => (t.trial, None, plant.centre_track(&t.c)),
            _ => return,
        };
        if self.trial != Some(trial) {
            self.trial = Some(trial);
            self.tracker = crate::markers::Tracker::default();
        }
        // a grasp's start comes in three messages; a repeat changes nothing
        let t = &mut self.tracker;
        t.aim_lights = t.aim_lights.or(lights);
        t.aim_centre = t.aim_centre.or(centre);
    }

    /// Captures served so far (each is one move of the controller).
    pub fn captures(&self) -> u64 {
        self.captures
    }

    /// A received message: a `CaptureRequest` is served (the arm settles, both cameras
    /// read) and answered; what was seen is returned for scoring. A trial's target (to the
    /// controller) starts the markers' track. A repeat of the last
    /// request (its observation was lost) gets the same observation again without a new
    /// reading; an older request (late, reordered) is ignored.
    pub fn on_message(&mut self, plant: &mut Plant, env: &Envelope, out: &mut Outbox) -> Served {
        if env.node == NodeId::Controller {
            self.hear_target(plant, &env.msg);
        }
        let (NodeId::CameraProcessor, Message::CaptureRequest(req)) = (env.node, env.msg) else {
            return Served::Nothing;
        };
        if let Some(last) = self.last {
            if last.seq == req.seq && last.what == req.what {
                out.push(Envelope::new(NodeId::CameraProcessor, last.into()));
                return Served::Repeat;
            }
            let behind = last.seq.wrapping_sub(req.seq);
            if behind != 0 && behind < 0x8000 {
                return Served::Stale;
            }
        }
        plant.settle();
        self.captures += 1;
        // the stereo check, new frames for a light not detected or inconsistent, a hidden
        // light filled in from the marker layout (plant::stereo): not a move
        let (sight, points, fill) = match req.what {
            CaptureKind::GripperLights => {
                let (noisy, fill) = plant.gripper_lights_filled(&mut self.tracker);
                let truth = plant.observe_gripper_lights_true();
                (Sight::Lights { noisy, truth }, points_of(&noisy), fill)
            }
            CaptureKind::GripperCentre => {
                let (noisy, fill) = plant.gripper_centre_filled(&mut self.tracker);
                let truth = plant.observe_gripper_centre_true();
                (Sight::Centre { noisy, truth }, points_of(&noisy), fill)
            }
        };
        let mut obs = proto::Observation {
            seq: req.seq,
            what: req.what,
            points,
        };
        if let Some((i, status)) = self.spoil.take() {
            if let Some(p) = obs.points.get_mut(i) {
                *p = PixelPoint {
                    x: 0.0,
                    y: 0.0,
                    status,
                };
            }
        }
        self.last = Some(obs);
        out.push(Envelope::new(NodeId::CameraProcessor, obs.into()));
        Served::Capture(Box::new(Capture {
            seq: req.seq,
            sight,
            pose: plant.gripper_pose(),
            time_s: plant.time_s(),
            fill,
        }))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::SimConfig;
    use trn_protocol::CaptureRequest;

    fn request(seq: u16, what: CaptureKind) -> Envelope {
        Envelope::new(NodeId::CameraProcessor, CaptureRequest { seq, what }.into())
    }

    #[test]
    fn a_capture_settles_the_arm_and_echoes_the_seq() {
        let mut plant = Plant::new(&SimConfig::default(), 1).unwrap();
        let mut cam = CameraProcessor::new();
        let mut out = Outbox::new();
        let t0 = plant.time_s();
        let req = request(42, CaptureKind::GripperCentre);
        let Served::Capture(cap) = cam.on_message(&mut plant, &req, &mut out) else {
            panic!("a capture")
        };
        assert!((plant.time_s() - t0 - plant.config().settle_s).abs() < 1e-9);
        let Message::Observation(o) = out[0].msg else {
            panic!()
        };
        assert_eq!((o.seq, o.what), (42, CaptureKind::GripperCentre));
        assert!(o.all_valid(), "the rest pose is in view");
        let Sight::Centre { noisy, truth } = cap.sight else {
            panic!()
        };
        assert_eq!(o.points[0].x, noisy.points[0].x as f32);
        assert_ne!(noisy.points[0].x, truth.points[0].x, "noise is added");
        assert_eq!(cam.captures(), 1);
        // other messages are not for it
        let hb = Envelope::new(
            NodeId::CameraProcessor,
            trn_protocol::GripperStatus { closed: true }.into(),
        );
        assert_eq!(cam.on_message(&mut plant, &hb, &mut out), Served::Nothing);
        // the request repeated (its observation was lost): the same observation, no new
        // reading, no time; an older request: nothing
        let t = plant.time_s();
        let repeat = request(42, CaptureKind::GripperCentre);
        assert_eq!(
            cam.on_message(&mut plant, &repeat, &mut out),
            Served::Repeat
        );
        assert_eq!(out[0], out[1]);
        assert_eq!(plant.time_s(), t);
        let old = request(41, CaptureKind::GripperCentre);
        assert_eq!(cam.on_message(&mut plant, &old, &mut out), Served::Stale);
        assert_eq!(cam.captures(), 1);
    }

    #[test]
    fn invalid_readings_keep_their_status() {
        let r = Readings::<2> {
            points: [
                crate::PixelReading {
                    x: f64::NAN,
                    y: f64::NAN,
                    status: proto::PointStatus::Occluded,
                },
                crate::PixelReading {
                    x: f64::NAN,
                    y: f64::NAN,
                    status: proto::PointStatus::OutOfView,
                },
            ],
        };
        let p = points_of(&r);
        assert_eq!(
            p[0],
            PixelPoint {
                x: 0.0,
                y: 0.0,
                status: proto::PointStatus::Occluded
            }
        );
        assert_eq!(p[1].status, proto::PointStatus::OutOfView);
        assert_eq!(p[2], PixelPoint::UNUSED);
    }
}
