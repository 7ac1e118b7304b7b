//! The gripper's markers as the camera processor knows them: lights p and q
//! `light_offset_mm` either side of the centre light c along the gripper normal
//! (`kinematics::lights`), one rigid body of five degrees of freedom (a centre and a
//! direction). A light hidden from a camera (by the hand, a link, or the cylinder in front of
//! the gripper) is filled in from the body fitted to the readings that are seen, as
//! motion-capture systems fill a marker gap. What a capture saw and filled in, and why not,
//! is its [`Fill`].
//!
//! - **Filled (Valid)** only when the readings determine the hidden one: its standard error,
//!   propagated from the fit's covariance with the centroid noise on every reading, is within
//!   a third of the stereo check's tolerance ([`super::stereo::tolerance_px`]), so it is as
//!   good as a reading. One marker seen by both cameras and another by one camera determine
//!   the body (the second lies on a ray at a known distance from the first). Markers seen by
//!   one camera only do not: the depth along that camera's rays shows only in the
//!   perspective of a 100 mm body at 2 m, so a fit to them can be far off without leaving a
//!   reading off, and such a fill was reported as valid before.
//! - **Estimated** when the readings do not determine it but the camera processor tracked
//!   the body earlier in the trial (its last capture, one move ago): the body fitted to the
//!   readings with the track as a weak prior takes from the readings what they determine
//!   and the rest (typically the depth along the seeing camera's rays) from where the body
//!   was. Such a reading is reported `Estimated`, never valid: its error is the move's
//!   component the cameras did not see.
//! - Otherwise (no marker seen at all, nothing tracked, or readings that no body explains:
//!   an outlier seen by one camera only) the hidden reading stays as it is, and the
//!   controller aborts.

use super::geometry::unit;
use super::{PixelReading, PointStatus, Vector3};

mod fill;
mod fit;
#[cfg(test)]
mod tests;

/// The prior's scale for the centre: about one move of the arm between two captures (mm).
/// Where the readings see the body (sub-millimetre) it does not pull; where they do not,
/// the body stays where it was.
pub const PRIOR_MOVE_MM: f64 = 50.0;

/// The prior's scale for the normal: about one move's turn of the gripper (radians).
pub const PRIOR_TURN_RAD: f64 = 0.1;

/// An estimate more than this many [`PRIOR_MOVE_MM`] from its prior is refused, unless a
/// marker seen by both cameras anchors it.
pub const FAR_MOVES: f64 = 4.0;

/// How the camera processor's fit of the marker body ([`Body`]) to a capture's readings
/// iterates (Levenberg-Marquardt in the body's five local coordinates, from several starts).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Fit {
    /// The lab's: each iteration's Jacobian by forward differences, iterated until no
    /// damping lowers the cost (or 40 iterations). Every figure of the lab is measured with
    /// it.
    #[default]
    Differences,
    /// The Jacobian differentiated analytically (one evaluation of the readings instead of
    /// six) and each step solved by Cholesky; starts within a few millimetres of one another
    /// fitted once; the iterations stopped once a step promises to lower the cost by less
    /// than a 1e-12 fraction of it, and a start without a prior given up once it is stuck in
    /// a minimum that leaves a reading beyond the stereo tolerance. The bodies the fill takes
    /// are the lab fit's to about 1e-4 px (its differences stop a little short of the
    /// minimum), in a fraction of the instructions (docs/python/step-cost.md and
    /// fit-agreement.md). The Python environment's fast physics (`dt_s`) fits with it.
    Analytic,
}

/// The marker body: its centre (the centre light) and unit normal; p = c + d n, q = c - d n.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Body {
    /// The centre light (mm).
    pub centre: Vector3<f64>,
    /// The unit normal, from q towards p.
    pub normal: Vector3<f64>,
}

impl Body {
    /// The markers p, q and c (mm) with the lights `d` mm either side of the centre.
    pub fn markers(&self, d: f64) -> [Vector3<f64>; 3] {
        let n = self.normal * d;
        [self.centre + n, self.centre - n, self.centre]
    }

    /// The body through lights `p` and `q`.
    fn through(p: &Vector3<f64>, q: &Vector3<f64>) -> Option<Body> {
        let n = p - q;
        (n.norm() > 1e-6).then(|| Body {
            centre: (p + q) * 0.5,
            normal: unit(&n),
        })
    }

    /// This body moved by local coordinates `x`: the centre by `x[0..3]` (mm), the normal
    /// turned by `x[3]`, `x[4]` (radians) about two axes perpendicular to it.
    fn moved(&self, x: &[f64; 5]) -> Body {
        let (t1, t2) = tangents(&self.normal);
        let n = self.normal + (t1 * x[3] + t2 * x[4]);
        Body {
            centre: self.centre + Vector3::new(x[0], x[1], x[2]),
            normal: unit(&n),
        }
    }
}

/// Two unit vectors perpendicular to unit `n` and to each other.
fn tangents(n: &Vector3<f64>) -> (Vector3<f64>, Vector3<f64>) {
    let axis = if n[0].abs() < 0.6 {
        Vector3::new(1.0, 0.0, 0.0)
    } else {
        Vector3::new(0.0, 1.0, 0.0)
    };
    let t1 = unit(&n.cross(&axis));
    (t1, n.cross(&t1))
}

/// What the camera processor knows of where the markers are: the body of the trial's last
/// capture, or only its centre (a centre capture seen by both cameras, before any capture
/// of the lights in the trial).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Track {
    /// The centre light (mm).
    pub centre: Vector3<f64>,
    /// The normal, when known.
    pub normal: Option<Vector3<f64>>,
}

/// What the camera processor knows of where the markers are in a trial: the body of its
/// last capture, and where the trial's targets (heard on the bus) put them.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct Tracker {
    /// The body at the trial's last capture.
    pub last: Option<Track>,
    /// Where stage 1's target shows the markers.
    pub aim_lights: Option<Track>,
    /// Where stage 2's target shows the centre light.
    pub aim_centre: Option<Track>,
}

impl Tracker {
    /// A new trial's tracker: nothing seen yet, its targets' markers.
    pub fn new(aim_lights: Option<Track>, aim_centre: Option<Track>) -> Tracker {
        Tracker {
            aim_lights,
            aim_centre,
            ..Tracker::default()
        }
    }

    /// The prior of an estimate in a capture of the centre (`centre`) or of the lights.
    fn prior(&self, centre: bool) -> Option<Track> {
        let aim = if centre {
            self.aim_centre.map(|a| Track {
                normal: self.last.and_then(|t| t.normal).or(a.normal),
                ..a
            })
        } else {
            self.aim_lights
        };
        self.last.or(aim)
    }

    /// A capture's body.
    fn update(&mut self, body: Track) {
        self.last = Some(body);
    }
}

/// Why no marker body filled a hidden reading in.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum NoFit {
    /// No marker seen by either camera: nothing to fill in or estimate from.
    Unseen,
    /// The readings do not determine it and nothing was tracked in the trial to estimate
    /// it from (this many readings were valid).
    Undetermined(usize),
    /// No marker seen by both cameras to start a fit from, and nothing tracked.
    NoStart,
    /// The best body leaves a reading this far off (pixels), beyond the stereo tolerance:
    /// the readings are not one body (an outlier seen by one camera only).
    Residual(f64),
    /// The readings put the estimated body this far (mm) from where the markers were,
    /// beyond [`FAR_MOVES`] moves, with no marker seen by both cameras: an outlier seen by
    /// one camera only.
    Far(f64),
}

impl NoFit {
    /// Its name in reports (without the figures of one capture).
    pub fn name(self) -> &'static str {
        match self {
            NoFit::Unseen => "no marker seen by either camera",
            NoFit::Undetermined(_) => "marker fit undetermined, nothing tracked",
            NoFit::NoStart => "no marker seen by both cameras, nothing tracked",
            NoFit::Residual(_) => "marker fit residual beyond tolerance",
            NoFit::Far(_) => "estimate far from the markers' last place",
        }
    }
}

/// What a capture of the gripper's lights saw, filled in and estimated: the camera
/// processor's own account (nothing it could not know), kept beside the readings.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct Fill {
    /// Status of each marker's reading before any fill, `[p_cam0, p_cam1, q_cam0, q_cam1,
    /// c_cam0, c_cam1]`; `None` for a capture not taken (no fill was needed).
    pub seen: [Option<PointStatus>; 6],
    /// Readings filled in as valid: determined by the readings seen.
    pub filled: usize,
    /// Readings estimated from the readings seen and the track.
    pub estimated: usize,
    /// Why a hidden reading was neither filled in nor estimated.
    pub no_fit: Option<NoFit>,
}

impl Fill {
    /// What `lights` (p and q, 4 readings, or none) and `centre` (c, 2 readings) saw.
    fn seen(lights: &[PixelReading], centre: &[PixelReading]) -> Fill {
        let mut f = Fill::default();
        for (s, p) in f.seen.iter_mut().zip(lights) {
            *s = Some(p.status);
        }
        for (s, p) in f.seen[4..].iter_mut().zip(centre) {
            *s = Some(p.status);
        }
        f
    }

    /// Valid readings before the fill (of those taken).
    pub fn valid(&self) -> usize {
        self.seen
            .iter()
            .filter(|s| **s == Some(PointStatus::Valid))
            .count()
    }
}
