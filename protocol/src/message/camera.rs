//! The cameras: capture requests and observations of the lights.

use postcard::experimental::max_size::MaxSize;
use serde::{Deserialize, Serialize};

/// What the camera processor is asked to capture.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, MaxSize)]
pub enum CaptureKind {
    /// The two gripper lights p, q in both cameras (8-D stage-1 input).
    GripperLights,
    /// The gripper centre light in both cameras (4-D stage-2 input).
    GripperCentre,
}

/// Validity of one observed light.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, MaxSize)]
pub enum PointStatus {
    /// Detected; `x`, `y` are valid pixel coordinates.
    Valid,
    /// The light projects outside the image.
    OutOfView,
    /// The light is hidden behind the arm or an object.
    Occluded,
    /// Not detected for another reason (or an unused slot).
    NotDetected,
    /// Hidden from this camera; `x`, `y` are the camera processor's estimate of where the
    /// light projects, from what it sees and where the light was one move ago (SPEC.md
    /// 3): a best guess whose error is not bounded by the centroid noise.
    Estimated,
}

/// One light in one camera. Pixels, origin top-left.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, MaxSize)]
pub struct PixelPoint {
    /// Column, pixels.
    pub x: f32,
    /// Row, pixels.
    pub y: f32,
    /// Validity of this point.
    pub status: PointStatus,
}

impl PixelPoint {
    /// An unused slot: `(0, 0, NotDetected)`.
    pub const UNUSED: PixelPoint = PixelPoint {
        x: 0.0,
        y: 0.0,
        status: PointStatus::NotDetected,
    };

    /// A valid point.
    pub const fn valid(x: f32, y: f32) -> PixelPoint {
        PixelPoint {
            x,
            y,
            status: PointStatus::Valid,
        }
    }
}

/// Ask the camera processor for an observation (node = camera processor).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, MaxSize)]
pub struct CaptureRequest {
    /// Sequence number echoed in the [`Observation`].
    #[serde(with = "super::fixint")]
    pub seq: u16,
    /// What to capture.
    pub what: CaptureKind,
}

/// A camera observation (node = camera processor).
///
/// `GripperLights`: `points = [p_cam0, p_cam1, q_cam0, q_cam1]` (the stage-1 `v` order).
/// `GripperCentre`: `points = [g_cam0, g_cam1, UNUSED, UNUSED]`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, MaxSize)]
pub struct Observation {
    /// Sequence number of the request.
    #[serde(with = "super::fixint")]
    pub seq: u16,
    /// What was captured.
    pub what: CaptureKind,
    /// The points, see the type docs for the order.
    pub points: [PixelPoint; 4],
}

impl Observation {
    /// A `GripperLights` observation from `[p_cam0, p_cam1, q_cam0, q_cam1]`.
    pub const fn lights(seq: u16, points: [PixelPoint; 4]) -> Observation {
        Observation {
            seq,
            what: CaptureKind::GripperLights,
            points,
        }
    }

    /// The points used by this kind of observation (4 for lights, 2 for the centre).
    pub fn used_points(&self) -> &[PixelPoint] {
        match self.what {
            CaptureKind::GripperLights => &self.points,
            CaptureKind::GripperCentre => &self.points[..2],
        }
    }

    /// True if every used point is `Valid`.
    pub fn all_valid(&self) -> bool {
        self.used_points()
            .iter()
            .all(|p| p.status == PointStatus::Valid)
    }

    /// The stage-1 vector `v = [p0x, p0y, p1x, p1y, q0x, q0y, q1x, q1y]` of a
    /// `GripperLights` observation (`None` for the centre).
    pub fn v(&self) -> Option<[f32; 8]> {
        if self.what != CaptureKind::GripperLights {
            return None;
        }
        let p = &self.points;
        Some([
            p[0].x, p[0].y, p[1].x, p[1].y, p[2].x, p[2].y, p[3].x, p[3].y,
        ])
    }

    /// The stage-2 vector `c = [g0x, g0y, g1x, g1y]` of a `GripperCentre` observation
    /// (`None` for the lights).
    pub fn c(&self) -> Option<[f32; 4]> {
        if self.what != CaptureKind::GripperCentre {
            return None;
        }
        let p = &self.points;
        Some([p[0].x, p[0].y, p[1].x, p[1].y])
    }

    /// A `GripperCentre` observation (fills the unused slots).
    pub const fn centre(seq: u16, cam0: PixelPoint, cam1: PixelPoint) -> Observation {
        Observation {
            seq,
            what: CaptureKind::GripperCentre,
            points: [cam0, cam1, PixelPoint::UNUSED, PixelPoint::UNUSED],
        }
    }
}
