//! The camera processor as a sans-IO node: a `CaptureRequest` lets the arm settle, reads the
//! requested lights in both cameras and answers with an `Observation` of the same `seq`.

use trn_protocol as proto;
use trn_protocol::{CaptureKind, Envelope, Message, NodeId, PixelPoint};

use super::Outbox;
use crate::plant::{self, Plant, Pose, Readings};

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
}

/// The camera processor (both cameras).
#[derive(Debug, Clone, Default)]
pub struct CameraProcessor {
    captures: u64,
}

/// The protocol's points for plant readings: a valid reading as is; an invalid one as
/// `(0, 0)` with its status (out of view, occluded, not detected).
pub fn points_of<const K: usize>(r: &Readings<K>) -> [PixelPoint; 4] {
    let mut points = [PixelPoint::UNUSED; 4];
    for (p, r) in points.iter_mut().zip(r.points.iter()) {
        let status = match r.status {
            plant::PointStatus::Valid => proto::PointStatus::Valid,
            plant::PointStatus::OutOfView => proto::PointStatus::OutOfView,
            plant::PointStatus::Occluded => proto::PointStatus::Occluded,
            plant::PointStatus::NotDetected => proto::PointStatus::NotDetected,
        };
        *p = if status == proto::PointStatus::Valid && r.x.is_finite() && r.y.is_finite() {
            PixelPoint::valid(r.x as f32, r.y as f32)
        } else {
            PixelPoint {
                x: 0.0,
                y: 0.0,
                status: if status == proto::PointStatus::Valid {
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

    /// Captures served so far (each is one move of the controller).
    pub fn captures(&self) -> u64 {
        self.captures
    }

    /// A received message: a `CaptureRequest` is served (the arm settles, both cameras
    /// read) and answered; what was seen is returned for scoring.
    pub fn on_message(
        &mut self,
        plant: &mut Plant,
        env: &Envelope,
        out: &mut Outbox,
    ) -> Option<Capture> {
        let (NodeId::CameraProcessor, Message::CaptureRequest(req)) = (env.node, env.msg) else {
            return None;
        };
        plant.settle();
        self.captures += 1;
        let (sight, points) = match req.what {
            CaptureKind::GripperLights => {
                let noisy = plant.observe_gripper_lights();
                let truth = plant.observe_gripper_lights_true();
                (Sight::Lights { noisy, truth }, points_of(&noisy))
            }
            CaptureKind::GripperCentre => {
                let noisy = plant.observe_gripper_centre();
                let truth = plant.observe_gripper_centre_true();
                (Sight::Centre { noisy, truth }, points_of(&noisy))
            }
        };
        let obs = proto::Observation {
            seq: req.seq,
            what: req.what,
            points,
        };
        out.push(Envelope::new(NodeId::CameraProcessor, obs.into()));
        Some(Capture {
            seq: req.seq,
            sight,
            pose: plant.gripper_pose(),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::plant::SimConfig;
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
        let cap = cam
            .on_message(
                &mut plant,
                &request(42, CaptureKind::GripperCentre),
                &mut out,
            )
            .unwrap();
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
        assert!(cam.on_message(&mut plant, &hb, &mut out).is_none());
    }

    #[test]
    fn invalid_readings_keep_their_status() {
        let r = Readings::<2> {
            points: [
                plant::PixelReading {
                    x: f64::NAN,
                    y: f64::NAN,
                    status: plant::PointStatus::Occluded,
                },
                plant::PixelReading {
                    x: f64::NAN,
                    y: f64::NAN,
                    status: plant::PointStatus::OutOfView,
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
