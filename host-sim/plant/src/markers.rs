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

use nalgebra::{SMatrix, SVector};

use super::camera::Camera;
use super::readings::{PixelReading, PointStatus, Readings};
use super::stereo::{point_of, seen, tolerance_px, RECAPTURES};
use super::vec3::{add, cross, dot, norm, scale, sub, unit, V3};
use super::Plant;

/// The prior's scale for the centre: about one move of the arm between two captures (mm).
/// Where the readings see the body (sub-millimetre) it does not pull; where they do not,
/// the body stays where it was.
pub const PRIOR_MOVE_MM: f64 = 50.0;

/// The prior's scale for the normal: about one move's turn of the gripper (radians).
pub const PRIOR_TURN_RAD: f64 = 0.1;

/// An estimate more than this many [`PRIOR_MOVE_MM`] from its prior is refused, unless a
/// marker seen by both cameras anchors it.
pub const FAR_MOVES: f64 = 4.0;

/// The marker body: its centre (the centre light) and unit normal; p = c + d n, q = c - d n.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Body {
    /// The centre light (mm).
    pub centre: V3,
    /// The unit normal, from q towards p.
    pub normal: V3,
}

impl Body {
    /// The markers p, q and c (mm) with the lights `d` mm either side of the centre.
    pub fn markers(&self, d: f64) -> [V3; 3] {
        let n = scale(&self.normal, d);
        [add(&self.centre, &n), sub(&self.centre, &n), self.centre]
    }

    /// The body through lights `p` and `q`.
    fn through(p: &V3, q: &V3) -> Option<Body> {
        let n = sub(p, q);
        (norm(&n) > 1e-6).then(|| Body {
            centre: scale(&add(p, q), 0.5),
            normal: unit(&n),
        })
    }

    /// This body moved by local coordinates `x`: the centre by `x[0..3]` (mm), the normal
    /// turned by `x[3]`, `x[4]` (radians) about two axes perpendicular to it.
    fn moved(&self, x: &[f64; 5]) -> Body {
        let (t1, t2) = tangents(&self.normal);
        let n = add(&self.normal, &add(&scale(&t1, x[3]), &scale(&t2, x[4])));
        Body {
            centre: add(&self.centre, &[x[0], x[1], x[2]]),
            normal: unit(&n),
        }
    }
}

/// Two unit vectors perpendicular to unit `n` and to each other.
fn tangents(n: &V3) -> (V3, V3) {
    let axis = if n[0].abs() < 0.6 {
        [1.0, 0.0, 0.0]
    } else {
        [0.0, 1.0, 0.0]
    };
    let t1 = unit(&cross(n, &axis));
    (t1, cross(n, &t1))
}

/// What the camera processor knows of where the markers are: the body of the trial's last
/// capture, or only its centre (a centre capture seen by both cameras, before any capture
/// of the lights in the trial).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Track {
    /// The centre light (mm).
    pub centre: V3,
    /// The normal, when known.
    pub normal: Option<V3>,
}

/// What the camera processor knows of where the markers are in a trial: the body of its
/// last capture, and where the trial's targets (heard on the bus) put them.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
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

/// One valid reading: marker (0 p, 1 q, 2 c), camera, pixel.
#[derive(Debug, Clone, Copy)]
struct Reading {
    marker: usize,
    cam: usize,
    uv: (f64, f64),
}

/// A fit of the body to readings, with a track as prior or without.
struct Problem<'a> {
    cams: &'a [Camera; 2],
    d: f64,
    sigma: f64,
    readings: Vec<Reading>,
    prior: Option<Track>,
}

impl Problem<'_> {
    /// The residuals in noise units (readings, then the prior's rows); `None` when a marker
    /// leaves an image.
    fn residuals(&self, b: &Body) -> Option<Vec<f64>> {
        let m = b.markers(self.d);
        let mut r = Vec::with_capacity(2 * self.readings.len() + 6);
        for s in &self.readings {
            let (u, v) = self.cams[s.cam].project(&m[s.marker])?;
            r.extend([(u - s.uv.0) / self.sigma, (v - s.uv.1) / self.sigma]);
        }
        if let Some(t) = &self.prior {
            r.extend(sub(&b.centre, &t.centre).map(|x| x / PRIOR_MOVE_MM));
            if let Some(n) = &t.normal {
                r.extend(sub(&b.normal, n).map(|x| x / PRIOR_TURN_RAD));
            }
        }
        Some(r)
    }

    /// Residuals and their Jacobian in the body's local coordinates.
    fn linearised(&self, b: &Body) -> Option<(Vec<f64>, Vec<[f64; 5]>)> {
        const H: f64 = 1e-4;
        let r = self.residuals(b)?;
        let mut jac = vec![[0.0; 5]; r.len()];
        for k in 0..5 {
            let mut x = [0.0; 5];
            x[k] = H;
            let rk = self.residuals(&b.moved(&x))?;
            for (row, (a, b)) in jac.iter_mut().zip(rk.iter().zip(&r)) {
                row[k] = (a - b) / H;
            }
        }
        Some((r, jac))
    }

    /// Levenberg-Marquardt from `start`; the body and its cost.
    fn solve(&self, start: Body) -> Option<(Body, f64)> {
        let cost = |r: &[f64]| r.iter().map(|v| v * v).sum::<f64>();
        let mut b = start;
        let mut c = cost(&self.residuals(&b)?);
        let mut lambda = 1e-3;
        for _ in 0..40 {
            let (r, jac) = self.linearised(&b)?;
            let jtj = normal_matrix(&jac);
            let jtr =
                SVector::<f64, 5>::from_fn(|a, _| jac.iter().zip(&r).map(|(j, r)| j[a] * r).sum());
            let mut improved = false;
            for _ in 0..8 {
                let damped = jtj
                    + SMatrix::<f64, 5, 5>::from_diagonal(
                        &(jtj.diagonal() * lambda + SVector::<f64, 5>::repeat(1e-9)),
                    );
                let Some(step) = damped.lu().solve(&jtr) else {
                    lambda *= 10.0;
                    continue;
                };
                let x: [f64; 5] = core::array::from_fn(|k| -step[k]);
                let next = b.moved(&x);
                match self.residuals(&next) {
                    Some(rn) if cost(&rn) < c => {
                        (b, c) = (next, cost(&rn));
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
        Some((b, c))
    }

    /// The best body over `starts`.
    fn best(&self, starts: &[Body]) -> Option<Body> {
        self.all(starts)
            .into_iter()
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(b, _)| b)
    }

    /// The body each start leads to, with its cost.
    fn all(&self, starts: &[Body]) -> Vec<(Body, f64)> {
        starts.iter().filter_map(|s| self.solve(*s)).collect()
    }

    /// The largest reading residual of `b` (pixels).
    fn worst_px(&self, b: &Body) -> Option<f64> {
        let r = self.residuals(b)?;
        let n = 2 * self.readings.len();
        Some(r[..n].iter().fold(0.0f64, |m, v| m.max(v.abs())) * self.sigma)
    }

    /// The standard error (pixels, the larger axis) of marker `marker` seen by `cam` for
    /// the body `b` fitted to the readings alone; infinite when they do not determine it.
    fn fill_error_px(&self, b: &Body, marker: usize, cam: usize) -> f64 {
        const H: f64 = 1e-4;
        let data = Problem {
            prior: None,
            readings: self.readings.clone(),
            ..*self
        };
        // six coordinates at least for five unknowns, and no direction the readings do not
        // see: a plain inverse of a singular J^T J returns rounding noise, small numbers
        // that look like a determined fill
        if self.readings.len() < 3 {
            return f64::INFINITY;
        }
        let Some((_, jac)) = data.linearised(b) else {
            return f64::INFINITY;
        };
        let eig = normal_matrix(&jac).symmetric_eigen();
        let largest = eig.eigenvalues.max();
        if largest.is_nan() || largest <= 0.0 || eig.eigenvalues.min() <= 1e-9 * largest {
            return f64::INFINITY;
        }
        let inverse = SMatrix::<f64, 5, 5>::from_diagonal(&eig.eigenvalues.map(|l| 1.0 / l));
        let cov = eig.eigenvectors * inverse * eig.eigenvectors.transpose();
        let project = |b: &Body| self.cams[cam].project(&b.markers(self.d)[marker]);
        let Some(at) = project(b) else {
            return f64::INFINITY;
        };
        let mut jf = SMatrix::<f64, 2, 5>::zeros();
        for k in 0..5 {
            let mut x = [0.0; 5];
            x[k] = H;
            let Some(uv) = project(&b.moved(&x)) else {
                return f64::INFINITY;
            };
            jf[(0, k)] = (uv.0 - at.0) / H;
            jf[(1, k)] = (uv.1 - at.1) / H;
        }
        // the residuals are in noise units: the covariance is sigma^2 (J^T J)^-1
        let c = jf * cov * jf.transpose() * (self.sigma * self.sigma);
        let (a, bb, d) = (c[(0, 0)], c[(0, 1)], c[(1, 1)]);
        let largest = 0.5 * (a + d) + (0.25 * (a - d) * (a - d) + bb * bb).sqrt();
        if largest.is_finite() && largest >= 0.0 {
            largest.sqrt()
        } else {
            f64::INFINITY
        }
    }
}

/// `J^T J` of rows `jac`.
fn normal_matrix(jac: &[[f64; 5]]) -> SMatrix<f64, 5, 5> {
    SMatrix::<f64, 5, 5>::from_fn(|a, b| jac.iter().map(|j| j[a] * j[b]).sum())
}

/// Where the ray from `o` along unit `u` meets the sphere of radius `r` about `s`: both
/// points in front of the camera, or the ray's closest point when it misses (noise).
fn ray_sphere(o: &V3, u: &V3, s: &V3, r: f64) -> Vec<V3> {
    let w = sub(o, s);
    let b = dot(u, &w);
    let disc = b * b - (dot(&w, &w) - r * r);
    let ts = if disc >= 0.0 {
        vec![-b - disc.sqrt(), -b + disc.sqrt()]
    } else {
        vec![-b]
    };
    ts.into_iter()
        .filter(|t| *t > 0.0)
        .map(|t| add(o, &scale(u, t)))
        .collect()
}

impl Plant {
    /// Starts for a fit of the body to `readings` (`tri`: the markers seen by both cameras,
    /// triangulated): through two triangulated markers; from one, towards the points at the
    /// markers' distance on the rays of the others' single readings; the track; the track
    /// moved onto the ray of a single reading of the centre.
    fn starts(
        &self,
        readings: &[Reading],
        tri: &[Option<V3>; 3],
        track: Option<&Track>,
    ) -> Vec<Body> {
        let d = self.cfg.light_offset_mm;
        let mut out = vec![];
        // the offset of marker m from the centre, in units of the normal
        let along = [d, -d, 0.0];
        let ray = |s: &Reading| {
            let cam = &self.cameras[s.cam];
            (cam.position(), cam.ray(s.uv.0, s.uv.1))
        };
        if let (Some(p), Some(q)) = (tri[0], tri[1]) {
            out.extend(Body::through(&p, &q));
        }
        for (m, x) in tri.iter().enumerate() {
            let Some(x) = x else { continue };
            for s in readings.iter().filter(|s| s.marker != m) {
                let (o, u) = ray(s);
                let gap = (along[m] - along[s.marker]).abs();
                for y in ray_sphere(&o, &u, x, gap) {
                    // the normal from the marker further along it to the other
                    let n = if along[m] > along[s.marker] {
                        sub(x, &y)
                    } else {
                        sub(&y, x)
                    };
                    if norm(&n) > 1e-6 {
                        let normal = unit(&n);
                        let centre = sub(x, &scale(&normal, along[m]));
                        out.push(Body { centre, normal });
                    }
                }
            }
        }
        if let Some(t) = track {
            let normal = t.normal.unwrap_or([0.0, 0.0, 1.0]);
            out.push(Body {
                centre: t.centre,
                normal,
            });
            for s in readings.iter().filter(|s| s.marker == 2) {
                let (o, u) = ray(s);
                let centre = add(&o, &scale(&u, dot(&sub(&t.centre, &o), &u)));
                out.push(Body { centre, normal });
            }
        }
        if out.is_empty() {
            // a triangulated marker and nothing else: any direction, the fit turns it
            if let Some((m, x)) = tri.iter().enumerate().find_map(|(m, x)| x.map(|x| (m, x))) {
                for normal in [[0.0, 0.0, 1.0], [0.0, 1.0, 0.0], [1.0, 0.0, 0.0]] {
                    out.push(Body {
                        centre: sub(&x, &scale(&normal, along[m])),
                        normal,
                    });
                }
            }
        }
        out
    }

    /// Fills in the readings of `lights` (p, q) and `centre` (c) that are not valid and that
    /// `wanted` asks for (markers 0 p, 1 q, 2 c), from the marker body: valid where the
    /// readings determine them, estimated where only `track` does (see the module). The
    /// track becomes the body found. Returns what was done.
    fn fill_markers(
        &self,
        lights: &mut Readings<4>,
        centre: &mut Readings<2>,
        wanted: &[usize],
        tracker: &mut Tracker,
    ) -> Fill {
        let prior = tracker.prior(wanted == [2]);
        let mut fill = Fill::seen(&lights.points, &centre.points);
        let mut readings = vec![];
        for (k, p) in lights.points.iter().enumerate() {
            if p.status == PointStatus::Valid {
                readings.push(Reading {
                    marker: k / 2,
                    cam: k % 2,
                    uv: (p.x, p.y),
                });
            }
        }
        for (k, p) in centre.points.iter().enumerate() {
            if p.status == PointStatus::Valid {
                readings.push(Reading {
                    marker: 2,
                    cam: k,
                    uv: (p.x, p.y),
                });
            }
        }
        let cams = &self.cameras;
        let tri = [
            point_of(cams, lights, 0),
            point_of(cams, lights, 1),
            point_of(cams, centre, 0),
        ];
        if readings.is_empty() {
            fill.no_fit = Some(NoFit::Unseen);
            return fill;
        }
        let starts = self.starts(&readings, &tri, tracker.last.or(prior).as_ref());
        if starts.is_empty() {
            fill.no_fit = Some(NoFit::NoStart);
            return fill;
        }
        let data = Problem {
            cams,
            d: self.cfg.light_offset_mm,
            sigma: self.cfg.pixel_noise_px,
            readings,
            prior: None,
        };
        let tol = tolerance_px(self.cfg.pixel_noise_px);
        let mut found = data.all(&starts);
        found.sort_by(|a, b| a.1.total_cmp(&b.1));
        let fitted = found.first().map(|f| f.0);
        if let Some(worst) = fitted.as_ref().and_then(|b| data.worst_px(b)) {
            if worst > tol {
                fill.no_fit = Some(NoFit::Residual(worst));
                return fill;
            }
        }
        // every body that explains the readings: where two of them put a hidden marker apart
        // (a ray meets the sphere of a marker's distance twice), the readings do not say which
        let explaining: Vec<Body> = found
            .iter()
            .map(|f| f.0)
            .filter(|b| data.worst_px(b).is_some_and(|w| w <= tol))
            .collect();
        let d = self.cfg.light_offset_mm;
        let agree = |m: usize, cam: usize| {
            let at: Vec<Option<(f64, f64)>> = explaining
                .iter()
                .map(|b| self.cameras[cam].project(&b.markers(d)[m]))
                .collect();
            at.iter().all(|x| match (x, at[0]) {
                (Some(a), Some(b)) => (a.0 - b.0).hypot(a.1 - b.1) <= tol,
                _ => false,
            })
        };
        // the hidden readings asked for, and whether the readings alone determine each
        let hidden: Vec<(usize, usize, bool)> = wanted
            .iter()
            .flat_map(|&m| (0..2).map(move |cam| (m, cam)))
            .filter(|&(m, cam)| {
                let p = if m == 2 {
                    &centre.points[cam]
                } else {
                    &lights.points[2 * m + cam]
                };
                p.status != PointStatus::Valid
            })
            .map(|(m, cam)| {
                let determined = fitted
                    .as_ref()
                    .is_some_and(|b| 3.0 * data.fill_error_px(b, m, cam) <= tol)
                    && agree(m, cam);
                (m, cam, determined)
            })
            .collect();
        let estimated = if hidden.iter().all(|h| h.2) {
            None
        } else if let Some(t) = prior {
            // where the readings say nothing, the body stays where the track has it; of two
            // mirror bodies, the one nearer it
            let prior = Problem {
                prior: Some(t),
                readings: data.readings.clone(),
                ..data
            };
            let mut from = starts.clone();
            from.extend(fitted);
            from.push(Body {
                centre: t.centre,
                normal: t.normal.unwrap_or([0.0, 0.0, 1.0]),
            });
            let best = prior
                .best(&from)
                .filter(|b| prior.worst_px(b).is_some_and(|w| w <= tol));
            // readings that put the body several moves from where it was are not an
            // estimate's: a reflection seen by one camera only, which nothing else checks;
            // a marker seen by both cameras passed the stereo check and anchors the body
            // where it is, however far the move (an untrained network's moves can be
            // hundreds of millimetres)
            let anchored = tri.iter().any(Option::is_some);
            let moved = best.map(|b| norm(&sub(&b.centre, &t.centre)));
            match moved {
                Some(mm) if mm > FAR_MOVES * PRIOR_MOVE_MM && !anchored => {
                    fill.no_fit = Some(NoFit::Far(mm));
                    return fill;
                }
                _ => best,
            }
        } else {
            // nothing tracked: the best body, when it is one of a few that the readings
            // pin down each (mirror bodies), not one of a continuum (one camera's depth)
            fitted.filter(|b| {
                hidden
                    .iter()
                    .all(|&(m, cam, _)| 3.0 * data.fill_error_px(b, m, cam) <= tol)
            })
        };
        for &(m, cam, determined) in &hidden {
            let (body, status) = match (determined, fitted.as_ref(), estimated.as_ref()) {
                (true, Some(b), _) => (b, PointStatus::Valid),
                (false, _, Some(b)) => (b, PointStatus::Estimated),
                _ => {
                    fill.no_fit
                        .get_or_insert(NoFit::Undetermined(data.readings.len()));
                    continue;
                }
            };
            let Some((u, v)) = self.cameras[cam].project(&body.markers(d)[m]) else {
                continue;
            };
            let p = if m == 2 {
                &mut centre.points[cam]
            } else {
                &mut lights.points[2 * m + cam]
            };
            *p = PixelReading { x: u, y: v, status };
            match status {
                PointStatus::Valid => fill.filled += 1,
                _ => fill.estimated += 1,
            }
        }
        if let Some(b) = estimated.or(fitted) {
            tracker.update(Track {
                centre: b.centre,
                normal: Some(b.normal),
            });
        }
        fill
    }

    /// The gripper's lights p and q as a camera processor that knows the marker layout
    /// reports them: a light hidden from a camera is filled in from the marker body (the
    /// centre light read too), or estimated from it and `track`, the body of the trial's
    /// last capture (the module's rules). `track` follows the markers.
    ///
    /// Readings that no body explains (an outlier seen by one camera only, which the stereo
    /// check cannot catch) are read again from new frames (the arm stands still), up to
    /// [`RECAPTURES`] times, as the stereo check does.
    pub fn gripper_lights_filled(&mut self, tracker: &mut Tracker) -> (Readings<4>, Fill) {
        let mut frames = 0;
        loop {
            let mut r = self.capture_checked(Plant::observe_gripper_lights).0;
            if let (Some(p), Some(q)) = (
                point_of(&self.cameras, &r, 0),
                point_of(&self.cameras, &r, 1),
            ) {
                if let Some(b) = Body::through(&p, &q) {
                    let body = Track {
                        centre: b.centre,
                        normal: Some(b.normal),
                    };
                    tracker.update(body);
                }
                return (r, Fill::seen(&r.points, &[]));
            }
            let mut c = self.capture_checked(Plant::observe_gripper_centre).0;
            let fill = self.fill_markers(&mut r, &mut c, &[0, 1], tracker);
            frames += 1;
            if !matches!(fill.no_fit, Some(NoFit::Residual(_) | NoFit::Far(_)))
                || frames > RECAPTURES
            {
                return (r, fill);
            }
        }
    }

    /// The gripper centre light as the same camera processor reports it: hidden from a
    /// camera (the cylinder it is about to hold), filled in or estimated from the marker
    /// body with the lights p and q read too.
    pub fn gripper_centre_filled(&mut self, tracker: &mut Tracker) -> (Readings<2>, Fill) {
        let mut frames = 0;
        loop {
            let mut c = self.capture_checked(Plant::observe_gripper_centre).0;
            if seen(&c, 0) {
                if let Some(x) = point_of(&self.cameras, &c, 0) {
                    let normal = tracker.last.and_then(|t| t.normal);
                    tracker.update(Track { centre: x, normal });
                }
                return (c, Fill::seen(&[], &c.points));
            }
            let mut l = self.capture_checked(Plant::observe_gripper_lights).0;
            let fill = self.fill_markers(&mut l, &mut c, &[2], tracker);
            frames += 1;
            if !matches!(fill.no_fit, Some(NoFit::Residual(_) | NoFit::Far(_)))
                || frames > RECAPTURES
            {
                return (c, fill);
            }
        }
    }

    /// Where the centre light of a stage-2 target `c` (both cameras) is, triangulated.
    pub fn centre_track(&self, c: &[f32; 4]) -> Option<Track> {
        let (a, b) = ((c[0] as f64, c[1] as f64), (c[2] as f64, c[3] as f64));
        let (centre, _) = super::stereo::triangulate(&self.cameras, a, b)?;
        Some(Track {
            centre,
            normal: None,
        })
    }

    /// Where the markers of a stage-1 target `v` (lights p and q in both cameras, as the
    /// target message carries them) are, triangulated: the body the trial's coarse move
    /// aims at.
    pub fn target_track(&self, v: &[f32; 8]) -> Option<Track> {
        let pair = |i: usize| {
            let (a, b) = (
                (v[4 * i] as f64, v[4 * i + 1] as f64),
                (v[4 * i + 2] as f64, v[4 * i + 3] as f64),
            );
            super::stereo::triangulate(&self.cameras, a, b).map(|(x, _)| x)
        };
        let b = Body::through(&pair(0)?, &pair(1)?)?;
        Some(Track {
            centre: b.centre,
            normal: Some(b.normal),
        })
    }
}

#[cfg(test)]
mod tests {
    use rand_core::SeedableRng;

    use super::*;
    use crate::{kinematics, SimConfig};

    /// A reading of `x` in camera `cam` (noise-free), or hidden.
    fn reading(plant: &Plant, x: &V3, cam: usize, seen: bool) -> PixelReading {
        let (u, v) = plant.cameras[cam].project(x).expect("in view");
        if seen {
            PixelReading {
                x: u,
                y: v,
                status: PointStatus::Valid,
            }
        } else {
            PixelReading {
                x: f64::NAN,
                y: f64::NAN,
                status: PointStatus::Occluded,
            }
        }
    }

    /// A pose whose three markers both cameras have in view, the markers p, q, c (mm).
    fn pose(plant: &mut Plant) -> [V3; 3] {
        let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(7);
        loop {
            let p = plant.random_pressures(&mut rng);
            plant.command(&p);
            plant.settle();
            let pose = plant.gripper_pose();
            let [p, q] = kinematics::lights(plant.config(), &pose);
            let m = [p, q, pose.centre_mm];
            if m.iter()
                .all(|x| (0..2).all(|cam| plant.cameras[cam].project(x).is_some()))
            {
                return m;
            }
        }
    }

    /// Lights p, q and centre c with `seen[marker][cam]`.
    fn readings(plant: &Plant, m: &[V3; 3], seen: [[bool; 2]; 3]) -> (Readings<4>, Readings<2>) {
        let lights = Readings {
            points: core::array::from_fn(|k| reading(plant, &m[k / 2], k % 2, seen[k / 2][k % 2])),
        };
        let centre = Readings {
            points: core::array::from_fn(|cam| reading(plant, &m[2], cam, seen[2][cam])),
        };
        (lights, centre)
    }

    /// A tracker whose last body is the true one moved `by` (mm).
    fn tracker(m: &[V3; 3], by: &V3) -> Tracker {
        Tracker {
            last: Some(Track {
                centre: add(&m[2], by),
                normal: Some(unit(&sub(&m[0], &m[1]))),
            }),
            ..Tracker::default()
        }
    }

    /// A move of `mm` at right angles to both cameras' rays to `x`.
    fn across(plant: &Plant, x: &V3, mm: f64) -> V3 {
        let ray = |cam: usize| unit(&sub(x, &plant.cameras[cam].position()));
        scale(&unit(&cross(&ray(0), &ray(1))), mm)
    }

    /// A marker seen by both cameras passed the stereo check: it anchors the body however
    /// far the arm moved since the last capture (an untrained network's move), and the
    /// hidden lights are placed from it. Markers seen by one camera only, as far from the
    /// track, are refused as an outlier; from a near track they are estimated.
    #[test]
    fn a_marker_seen_by_both_cameras_anchors_an_estimate_after_a_long_move() {
        let cfg = SimConfig::realistic();
        let mut plant = Plant::new(&cfg, 5).unwrap();
        let m = pose(&mut plant);
        let tol = tolerance_px(cfg.pixel_noise_px);
        // 300 mm: beyond what an estimate may move from its track without an anchor
        let far = across(&plant, &m[2], 1.5 * FAR_MOVES * PRIOR_MOVE_MM);

        // c in both cameras, p in camera 0 only, q hidden: the track far away
        let (mut l, mut c) = readings(&plant, &m, [[true, false], [false, false], [true, true]]);
        let mut t = tracker(&m, &far);
        let fill = plant.fill_markers(&mut l, &mut c, &[0, 1], &mut t);
        assert_eq!(fill.no_fit, None, "{fill:?}");
        assert_eq!(fill.filled + fill.estimated, 3, "{fill:?}");
        let truth = readings(&plant, &m, [[true; 2]; 3]).0;
        for (a, b) in l.points.iter().zip(&truth.points) {
            assert_ne!(a.status, PointStatus::Occluded);
            let off = (a.x - b.x).hypot(a.y - b.y);
            assert!(off <= tol, "{off} px off: {l:?}");
        }
        assert!(norm(&sub(&t.last.unwrap().centre, &m[2])) < 1.0, "{t:?}");

        // every marker in camera 0 only: nothing anchors them
        let only0 = [[true, false]; 3];
        let (mut l, mut c) = readings(&plant, &m, only0);
        let fill = plant.fill_markers(&mut l, &mut c, &[0, 1], &mut tracker(&m, &far));
        assert!(matches!(fill.no_fit, Some(NoFit::Far(_))), "{fill:?}");
        assert!(l.points[1].status == PointStatus::Occluded);
        assert!(l.points[3].status == PointStatus::Occluded);
        let (mut l, mut c) = readings(&plant, &m, only0);
        let near = tracker(&m, &[0.0; 3]);
        let fill = plant.fill_markers(&mut l, &mut c, &[0, 1], &mut near.clone());
        assert_eq!(fill.no_fit, None, "{fill:?}");
        assert_eq!(fill.estimated, 2, "{fill:?}");
    }
}
