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
use super::readings::{PixelReading, PointStatus, Readings};
use super::vec3::{add, cross, dot, norm, scale, sub, V3};

use super::Plant;

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
pub fn triangulate(cams: &[Camera; 2], a: (f64, f64), b: (f64, f64)) -> Option<(V3, f64)> {
    let (o0, o1) = (cams[0].position(), cams[1].position());
    let (d0, d1) = (cams[0].ray(a.0, a.1), cams[1].ray(b.0, b.1));
    // closest points of the two rays
    let w = sub(&o0, &o1);
    let (bb, d, e) = (dot(&d0, &d1), dot(&d0, &w), dot(&d1, &w));
    let den = 1.0 - bb * bb;
    if den < 1e-9 || norm(&cross(&d0, &d1)) < 1e-9 {
        return None;
    }
    let s = (bb * e - d) / den;
    let t = (e - bb * d) / den;
    let mut x = scale(
        &add(&add(&o0, &scale(&d0, s)), &add(&o1, &scale(&d1, t))),
        0.5,
    );
    let obs = [a.0, a.1, b.0, b.1];
    let residual = |x: &V3| -> Option<[f64; 4]> {
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
fn point_of<const K: usize>(cams: &[Camera; 2], r: &Readings<K>, i: usize) -> Option<V3> {
    let (a, b) = (r.points.get(2 * i)?, r.points.get(2 * i + 1)?);
    if a.status != PointStatus::Valid || b.status != PointStatus::Valid {
        return None;
    }
    triangulate(cams, (a.x, a.y), (b.x, b.y)).map(|(x, _)| x)
}

/// True when light `i` of `r` is valid in both cameras.
fn seen<const K: usize>(r: &Readings<K>, i: usize) -> bool {
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
    /// [`RECAPTURES`] times) while a light is not detected or inconsistent; a light good in
    /// a new frame replaces its bad reading (the arm stands still), the good ones are kept.
    /// Returns the readings and the frames taken beyond the first.
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
                let bad = old.iter().any(|p| p.status == PointStatus::NotDetected);
                if bad && new.iter().all(|p| p.status == PointStatus::Valid) {
                    old.copy_from_slice(new);
                }
            }
        }
        (r, RECAPTURES)
    }

    /// The gripper's markers (lights p and q, the centre light c midway between them,
    /// `light_offset_mm` either side along the gripper normal: `kinematics::lights`) as a
    /// rigid body fitted to the readings that are valid: its centre and normal by
    /// Gauss-Newton on every valid reading's reprojection error, from the lights seen by
    /// both cameras, or else from `track` (where the markers were last seen). `None` with
    /// neither, or when the fit leaves a reading off by more than [`tolerance_px`].
    /// Returns p, q and c (mm).
    fn fit_markers(
        &self,
        lights: &Readings<4>,
        centre: &Readings<2>,
        track: Option<&[V3; 3]>,
    ) -> Option<[V3; 3]> {
        let d = self.cfg.light_offset_mm;
        let cams = &self.cameras;
        let (p, q, c) = (
            point_of(cams, lights, 0),
            point_of(cams, lights, 1),
            point_of(cams, centre, 0),
        );
        // the start: the centre triangulated, or between p and q, or on a camera's ray
        // through the centre light, nearest the light seen by both cameras
        let on_ray = |x: &V3| -> Option<V3> {
            let (cam, pt) = centre
                .points
                .iter()
                .enumerate()
                .find(|(_, pt)| pt.status == PointStatus::Valid)?;
            let o = cams[cam].position();
            let dir = cams[cam].ray(pt.x, pt.y);
            Some(add(&o, &scale(&dir, dot(&sub(x, &o), &dir))))
        };
        let c0 = match (p, q, c, track) {
            (_, _, Some(c), _) => c,
            (Some(p), Some(q), None, _) => scale(&add(&p, &q), 0.5),
            (Some(x), None, None, _) | (None, Some(x), None, _) => on_ray(&x).unwrap_or(x),
            (None, None, None, Some(m)) => m[2],
            (None, None, None, None) => return None,
        };
        let n0 = match (p, q, track) {
            (Some(p), Some(q), _) => sub(&p, &q),
            (Some(p), None, _) => sub(&p, &c0),
            (None, Some(q), _) => sub(&c0, &q),
            (None, None, Some(m)) => sub(&m[0], &m[2]),
            // from the centre alone: any direction, the fit turns it
            (None, None, None) => [0.0, 0.0, 1.0],
        };
        if norm(&n0) < 1e-6 {
            return None;
        }
        // (which marker, camera, reading): 0 = p, 1 = q, 2 = c
        let mut obs = vec![];
        for (k, pt) in lights.points.iter().enumerate() {
            if pt.status == PointStatus::Valid {
                obs.push((k / 2, k % 2, (pt.x, pt.y)));
            }
        }
        for (k, pt) in centre.points.iter().enumerate() {
            if pt.status == PointStatus::Valid {
                obs.push((2, k, (pt.x, pt.y)));
            }
        }
        if 2 * obs.len() < 6 {
            return None;
        }
        let markers = |x: &[f64; 6]| -> [V3; 3] {
            let c = [x[0], x[1], x[2]];
            let n = [x[3], x[4], x[5]];
            let n = scale(&n, d / norm(&n));
            [add(&c, &n), sub(&c, &n), c]
        };
        let residual = |x: &[f64; 6]| -> Option<Vec<f64>> {
            let m = markers(x);
            let mut r = Vec::with_capacity(2 * obs.len());
            for &(which, cam, (u, v)) in &obs {
                let (pu, pv) = cams[cam].project(&m[which])?;
                r.extend([pu - u, pv - v]);
            }
            Some(r)
        };
        let n0 = scale(&n0, 1.0 / norm(&n0));
        let mut x = [c0[0], c0[1], c0[2], n0[0], n0[1], n0[2]];
        let cost = |r: &[f64]| r.iter().map(|v| v * v).sum::<f64>();
        let mut r = residual(&x)?;
        let mut lambda = 1e-3;
        // Levenberg-Marquardt; the normal's length is free (the markers use its direction),
        // so it is kept at one after every step
        for _ in 0..40 {
            let cols: Vec<Vec<f64>> = (0..6)
                .map(|k| {
                    let mut xk = x;
                    xk[k] += 1e-4;
                    residual(&xk).map(|rk| rk.iter().zip(&r).map(|(a, b)| (a - b) / 1e-4).collect())
                })
                .collect::<Option<_>>()?;
            let jtj = nalgebra::SMatrix::<f64, 6, 6>::from_fn(|a, b| {
                cols[a].iter().zip(&cols[b]).map(|(x, y)| x * y).sum()
            });
            let jtr = nalgebra::SVector::<f64, 6>::from_fn(|a, _| {
                cols[a].iter().zip(&r).map(|(x, y)| x * y).sum()
            });
            let mut improved = false;
            for _ in 0..8 {
                let damped = jtj
                    + nalgebra::SMatrix::<f64, 6, 6>::from_diagonal(
                        &(jtj.diagonal() * lambda + nalgebra::SVector::<f64, 6>::repeat(1e-9)),
                    );
                let Some(step) = damped.lu().solve(&jtr) else {
                    lambda *= 10.0;
                    continue;
                };
                let mut y = x;
                for k in 0..6 {
                    y[k] -= step[k];
                }
                let n = norm(&[y[3], y[4], y[5]]);
                if n < 1e-9 {
                    lambda *= 10.0;
                    continue;
                }
                y[3..].iter_mut().for_each(|v| *v /= n);
                match residual(&y) {
                    Some(ry) if cost(&ry) < cost(&r) => {
                        (x, r) = (y, ry);
                        lambda = (lambda / 3.0).max(1e-9);
                        improved = true;
                        break;
                    }
                    _ => lambda *= 10.0,
                }
            }
            if !improved {
                break;
            }
        }
        let worst = residual(&x)?.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        (worst <= tolerance_px(self.cfg.pixel_noise_px)).then(|| markers(&x))
    }

    /// Fills in the readings of marker `which` (0 = p, 1 = q, 2 = c) in `r` (its light `i`)
    /// that are missing from `x`, the marker in space. Returns how many were filled in.
    fn fill<const K: usize>(&self, r: &mut Readings<K>, i: usize, x: &V3) -> usize {
        let mut filled = 0;
        for cam in 0..2 {
            let p = &mut r.points[2 * i + cam];
            if p.status != PointStatus::Valid {
                if let Some((u, v)) = self.cameras[cam].project(x) {
                    *p = PixelReading {
                        x: u,
                        y: v,
                        status: PointStatus::Valid,
                    };
                    filled += 1;
                }
            }
        }
        filled
    }

    /// The gripper's lights p and q as a camera processor that knows the marker layout
    /// reports them: a light hidden from a camera (by the hand, a link or the cylinder in
    /// front of it) is filled in from the rigid body fitted to the markers that are seen,
    /// the centre light's readings included ([`Plant::fit_markers`]), as motion-capture
    /// systems fill a marker gap. Its error is the fit's, about a centroid's. Without a fit
    /// the readings stay as they are. Returns the readings and how many were filled in.
    /// `track` is the camera processor's memory of where the markers were (updated here).
    pub fn gripper_lights_filled(&mut self, track: &mut Option<[V3; 3]>) -> (Readings<4>, usize) {
        let mut r = self.capture_checked(Plant::observe_gripper_lights).0;
        if let (Some(p), Some(q)) = (
            point_of(&self.cameras, &r, 0),
            point_of(&self.cameras, &r, 1),
        ) {
            *track = Some([p, q, scale(&add(&p, &q), 0.5)]);
            return (r, 0);
        }
        let c = self.capture_checked(Plant::observe_gripper_centre).0;
        let Some(m) = self.fit_markers(&r, &c, track.as_ref()) else {
            return (r, 0);
        };
        *track = Some(m);
        let n = self.fill(&mut r, 0, &m[0]) + self.fill(&mut r, 1, &m[1]);
        (r, n)
    }

    /// The gripper centre light as the same camera processor reports it: hidden from a
    /// camera (the cylinder it is about to hold), it is filled in from the marker fit.
    /// Returns the readings and how many were filled in.
    pub fn gripper_centre_filled(&mut self, track: &mut Option<[V3; 3]>) -> (Readings<2>, usize) {
        let mut c = self.capture_checked(Plant::observe_gripper_centre).0;
        if seen(&c, 0) {
            return (c, 0);
        }
        let l = self.capture_checked(Plant::observe_gripper_lights).0;
        let Some(m) = self.fit_markers(&l, &c, track.as_ref()) else {
            return (c, 0);
        };
        *track = Some(m);
        let n = self.fill(&mut c, 0, &m[2]);
        (c, n)
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
