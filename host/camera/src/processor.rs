//! The camera processor: the frames of a capture in, the Observation's points out.
//!
//! In each camera, every frame's blobs are found by `trn_vision`'s [`Detector`] (the
//! background's level and noise estimated from the frame itself, as nothing calibrates a
//! real sensor's stray light in advance) and the lights are told apart over the capture by
//! its [`Identifier`]. A light identified is `Valid` at its track's mean; any other
//! (hidden, dark, merged, doubled by a reflection) is `NotDetected`, never another light's
//! reading. With the cameras' [`Calibration`], a light valid in both cameras must then be one
//! point in space: its two readings, triangulated, reproject onto themselves within
//! `1 px + 6 x pixel_noise_px` (the simulator's stereo check, `trn_plant::stereo`), or both
//! are reported `NotDetected`.
//!
//! What the simulator's camera processor does beyond this, and this one does not: it reads
//! new frames while a light is missing or inconsistent (the arm stands still; a node fed by
//! a recording has no new frames to read), and it fills in a light hidden from one camera
//! from the marker body (which needs the trial's targets and the last capture's markers).
//! A light it cannot see here is `NotDetected`, which a controller treats as any invalid
//! point: the move is not learned from. A light outside the image cannot be told from a
//! hidden one on pixels alone: it is `NotDetected`, not `OutOfView`.

use trn_plant::camera::Camera;
use trn_plant::stereo;
use trn_protocol::PixelPoint;
use trn_vision::{Detector, DetectorParams, Identifier, LightStatus};

use crate::source::{CalibrationConfig, CaptureFrames};
use crate::CameraError;

/// The two cameras' calibration: what the stereo check needs.
#[derive(Debug, Clone)]
pub struct Calibration {
    cameras: [Camera; 2],
    tolerance_px: f64,
}

impl Calibration {
    /// From a recording's (or a rig's) calibration, which has two cameras.
    pub fn new(c: &CalibrationConfig) -> Result<Calibration, CameraError> {
        let [a, b] = c.cameras.as_slice() else {
            return Err(CameraError::Source(format!(
                "a calibration of {} cameras, not 2",
                c.cameras.len()
            )));
        };
        Ok(Calibration {
            cameras: [Camera::new(a), Camera::new(b)],
            tolerance_px: stereo::tolerance_px(c.pixel_noise_px),
        })
    }

    /// The largest reprojection error (pixels) of two readings of one light.
    pub fn tolerance_px(&self) -> f64 {
        self.tolerance_px
    }

    /// True when `a` (camera 0) and `b` (camera 1) are one point in space.
    pub fn consistent(&self, a: [f64; 2], b: [f64; 2]) -> bool {
        stereo::reprojection_error(&self.cameras, (a[0], a[1]), (b[0], b[1]))
            .is_some_and(|e| e <= self.tolerance_px)
    }
}

/// What one capture gave.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Observed {
    /// The Observation's points: `[p_cam0, p_cam1, q_cam0, q_cam1]`, or
    /// `[c_cam0, c_cam1, UNUSED, UNUSED]`.
    pub points: [PixelPoint; 4],
    /// Lights valid in both cameras that the stereo check refused.
    pub inconsistent: usize,
}

/// The camera processor.
#[derive(Debug, Clone)]
pub struct Processor {
    detector: DetectorParams,
    gate_px: f64,
    calibration: Option<Calibration>,
}

impl Processor {
    /// A processor with the detector's `params`, the identifier's `gate_px` (> 0) and, when
    /// given, the cameras' calibration for the stereo check.
    pub fn new(
        detector: DetectorParams,
        gate_px: f64,
        calibration: Option<Calibration>,
    ) -> Result<Processor, CameraError> {
        if !(gate_px.is_finite() && gate_px > 0.0) {
            return Err(CameraError::Source(format!(
                "gate_px {gate_px} is not a positive number"
            )));
        }
        Ok(Processor {
            detector,
            gate_px,
            calibration,
        })
    }

    /// The processor a recording's manifest describes: the detector's defaults, the
    /// manifest's gate and, when it has one, its cameras' calibration.
    pub fn for_recording(m: &crate::source::Manifest) -> Result<Processor, CameraError> {
        let calibration = m.calibration.as_ref().map(Calibration::new).transpose()?;
        Processor::new(DetectorParams::default(), m.gate_px, calibration)
    }

    /// The cameras' calibration, when they are checked against each other.
    pub fn calibration(&self) -> Option<&Calibration> {
        self.calibration.as_ref()
    }

    /// The points of one capture.
    pub fn observe(&self, c: &CaptureFrames) -> Result<Observed, CameraError> {
        let identifier = Identifier::new(c.protocol.clone(), self.gate_px)?;
        let lights = c.protocol.lights();
        if lights != crate::source::lights_of(c.what) {
            return Err(CameraError::Source(format!(
                "a capture of {:?} whose protocol has {lights} lights",
                c.what
            )));
        }
        let mut found = [Vec::new(), Vec::new()];
        for (cam, frames) in c.cameras.iter().enumerate() {
            let mut detections = Vec::with_capacity(frames.len());
            for f in frames {
                let (w, h) = f.dimensions();
                let detector = Detector::new(w, h, self.detector.clone())?;
                detections.push(f.detect(&detector)?);
            }
            found[cam] = identifier
                .identify(&detections)?
                .into_iter()
                .map(|id| match (id.status, id.centre) {
                    (LightStatus::Valid, Some(xy)) if xy.iter().all(|v| v.is_finite()) => Some(xy),
                    _ => None,
                })
                .collect();
        }
        let mut points = [PixelPoint::UNUSED; 4];
        let mut inconsistent = 0;
        for light in 0..lights {
            let (mut a, mut b) = (found[0][light], found[1][light]);
            if let (Some(k), Some(pa), Some(pb)) = (&self.calibration, a, b) {
                if !k.consistent(pa, pb) {
                    inconsistent += 1;
                    (a, b) = (None, None);
                }
            }
            for (cam, xy) in [a, b].into_iter().enumerate() {
                if let Some([x, y]) = xy {
                    points[2 * light + cam] = PixelPoint::valid(x as f32, y as f32);
                }
            }
        }
        Ok(Observed {
            points,
            inconsistent,
        })
    }
}
