//! Stereo consistency: what a camera processor with calibrated cameras checks before it
//! reports a light. A light seen by both cameras must be one point in space: its two
//! readings, triangulated, reproject onto themselves within the centroid noise. A reflection
//! taken for the LED in one camera (`realism.outlier_rate`) breaks this (it lies off the
//! epipolar line but by chance), and a light not detected in one frame
//! (`realism.dropout_rate`) is usually there in the next. So a capture whose lights are
//! inconsistent or not detected is read again, from a new frame of both cameras (no move:
//! the arm stands still), up to [`RECAPTURES`] times; what is still wrong is reported as
//! not detected. Out of view and occluded are geometry: reading again changes nothing.

use super::camera::Camera;
use super::{PixelReading, Plant, PointStatus, Readings, Vector3};

/// New frames a capture may take when a light is not detected or inconsistent. Each costs a
/// frame (tens of milliseconds), not a move; four frames in a row with a random fault on the
/// same light are rare (rate^4).
pub const RECAPTURES: usize = 3;

/// Largest reprojection error (pixels) of a consistent pair for centroid noise `sigma`:
/// 1 px (calibration, lens model) plus 6 sigma, far beyond what the noise gives (the
/// residual of one pair has one degree of freedom, about sigma / sqrt 2 per coordinate),
/// far below an outlier's (uniform over the image: within a few pixels of the epipolar
/// line with probability of one or two in a hundred).
pub fn tolerance_px(sigma: f64) -> f64 {
    1.0 + 6.0 * sigma
}

/// The largest reprojection error (pixels) of the point that best explains readings `a`
/// (camera 0) and `b` (camera 1) ([`triangulate`]).
pub fn reprojection_error(cams: &[Camera; 2], a: (f64, f64), b: (f64, f64)) -> Option<f64> {
    triangulate(cams, a, b).map(|(_, e)| e)
}

/// The point (mm) that best explains readings `a` (camera 0) and `b` (camera 1), and its
/// largest reprojection error (pixels): midpoint triangulation of the pinhole rays, then
/// Gauss-Newton on the full camera model. `None` when the rays are parallel or the point
/// leaves the images.
pub fn triangulate(
    cams: &[Camera; 2],
    a: (f64, f64),
    b: (f64, f64),
) -> Option<(Vector3<f64>, f64)> {
    let (o0, o1) = (cams[0].position(), cams[1].position());
    let (d0, d1) = (cams[0].ray(a.0, a.1), cams[1].ray(b.0, b.1));
    // closest points of the two rays
    let w = o0 - o1;
    let (bb, d, e) = (d0.dot(&d1), d0.dot(&w), d1.dot(&w));
    let den = 1.0 - bb * bb;
    if den < 1e-9 || d0.cross(&d1).norm() < 1e-9 {
        return None;
    }
    let s = (bb * e - d) / den;
    let t = (e - bb * d) / den;
    let mut x = ((o0 + d0 * s) + (o1 + d1 * t)) * 0.5;
    let obs = [a.0, a.1, b.0, b.1];
    let residual = |x: &Vector3<f64>| -> Option<[f64; 4]> {
        let (p, q) = (cams[0].project(x)?, cams[1].project(x)?);
        Some([p.0 - obs[0], p.1 - obs[1], q.0 - obs[2], q.1 - obs[3]])
    };
    for _ in 0..5 {
        let r = residual(&x)?;
        let mut jac = nalgebra::Matrix4x3::<f64>::zeros();
        for k in 0..3 {
            let mut xk = x;
            xk[k] += 1e-3;
            let rk = residual(&xk)?;
            for row in 0..4 {
                jac[(row, k)] = (rk[row] - r[row]) / 1e-3;
            }
        }
        let rv = nalgebra::Vector4::from(r);
        let step = (jac.transpose() * jac)
            .try_inverse()
            .map(|m| m * jac.transpose() * rv)?;
        for k in 0..3 {
            x[k] -= step[k];
        }
    }
    residual(&x).map(|r| (x, r.iter().fold(0.0f64, |m, v| m.max(v.abs()))))
}

/// The light `i` of `r` (its readings `2i`, `2i + 1`) in space, when both are valid.
pub(crate) fn point_of<const K: usize>(
    cams: &[Camera; 2],
    r: &Readings<K>,
    i: usize,
) -> Option<Vector3<f64>> {
    let (a, b) = (r.points.get(2 * i)?, r.points.get(2 * i + 1)?);
    if a.status != PointStatus::Valid || b.status != PointStatus::Valid {
        return None;
    }
    triangulate(cams, (a.x, a.y), (b.x, b.y)).map(|(x, _)| x)
}

/// True when light `i` of `r` is valid in both cameras.
pub(crate) fn seen<const K: usize>(r: &Readings<K>, i: usize) -> bool {
    r.points[2 * i..2 * i + 2]
        .iter()
        .all(|p| p.status == PointStatus::Valid)
}

impl Plant {
    /// Marks the lights of `r` whose two readings disagree (beyond [`tolerance_px`] for this
    /// plant's centroid noise) as not detected; true when every light is valid afterwards.
    pub fn check_stereo<const K: usize>(&self, r: &mut Readings<K>) -> bool {
        let tol = tolerance_px(self.cfg.pixel_noise_px);
        let mut all = true;
        for pair in r.points.chunks_mut(2) {
            let [a, b] = pair else {
                all = false;
                continue;
            };
            if a.status == PointStatus::Valid && b.status == PointStatus::Valid {
                let err = reprojection_error(&self.cameras, (a.x, a.y), (b.x, b.y));
                if !err.is_some_and(|e| e <= tol) {
                    let lost = PixelReading {
                        x: f64::NAN,
                        y: f64::NAN,
                        status: PointStatus::NotDetected,
                    };
                    (*a, *b) = (lost, lost);
                }
            }
            all &= a.status == PointStatus::Valid && b.status == PointStatus::Valid;
        }
        all
    }

    /// A capture by `read` with the stereo check, read again from new frames (up to
    /// [`RECAPTURES`] times) while a light is not detected or inconsistent; a light seen
    /// better in a new frame (more of its two readings valid) replaces its bad readings (the
    /// arm stands still), the good ones are kept. A light hidden from one camera counts
    /// too: its reading in the other camera, lost to a dropout in one frame, comes back
    /// from the next (before, only a light valid in both cameras replaced a bad one, so
    /// such a reading was never read again). Returns the readings and the frames taken
    /// beyond the first.
    pub fn capture_checked<const K: usize>(
        &mut self,
        read: impl Fn(&mut Plant) -> Readings<K>,
    ) -> (Readings<K>, usize) {
        let mut r = read(self);
        self.check_stereo(&mut r);
        let lost = |r: &Readings<K>| {
            r.points
                .iter()
                .any(|p| p.status == PointStatus::NotDetected)
        };
        for extra in 0..RECAPTURES {
            if !lost(&r) {
                return (r, extra);
            }
            let mut again = read(self);
            self.check_stereo(&mut again);
            for (old, new) in r.points.chunks_mut(2).zip(again.points.chunks(2)) {
                let valid = |pair: &[PixelReading]| {
                    pair.iter()
                        .filter(|p| p.status == PointStatus::Valid)
                        .count()
                };
                let bad = old.iter().any(|p| p.status == PointStatus::NotDetected);
                if bad && valid(new) > valid(old) {
                    old.copy_from_slice(new);
                }
            }
        }
        (r, RECAPTURES)
    }

    /// Two captures by [`Plant::capture_checked`] whose valid lights agree (each coordinate
    /// within [`tolerance_px`]), taken again (up to [`RECAPTURES`] times) while they do not:
    /// an outlier that passes the stereo check by chance (it lies near the epipolar line,
    /// about one in a hundred) does not come back in the next frame.
    pub fn capture_twice_checked<const K: usize>(
        &mut self,
        read: impl Fn(&mut Plant) -> Readings<K>,
    ) -> (Readings<K>, Readings<K>) {
        let checked = |p: &mut Plant| p.capture_checked(&read).0;
        let mut pair = (checked(self), checked(self));
        self.until_agreeing(&mut pair, checked);
        pair
    }

    /// Takes both captures of `pair` again (by `read`, a checked capture, up to
    /// [`RECAPTURES`] times) while their valid lights disagree.
    pub fn until_agreeing<const K: usize>(
        &mut self,
        pair: &mut (Readings<K>, Readings<K>),
        read: impl Fn(&mut Plant) -> Readings<K>,
    ) {
        let tol = tolerance_px(self.cfg.pixel_noise_px);
        for _ in 0..RECAPTURES {
            let agree = pair.0.points.iter().zip(&pair.1.points).all(|(a, b)| {
                a.status != PointStatus::Valid
                    || b.status != PointStatus::Valid
                    || ((a.x - b.x).abs() <= tol && (a.y - b.y).abs() <= tol)
            });
            if agree {
                return;
            }
            *pair = (read(self), read(self));
        }
    }
}
