//! The camera processor's fill of hidden marker readings: the starts of a fit to what a
//! capture saw, the fill itself (valid, estimated, or none, with why), the captures of the
//! gripper's lights and centre light that fill in, and the tracks the trial's targets give.

use super::fit::{Problem, Reading};
use super::{Body, Fill, Fit, NoFit, Track, Tracker, FAR_MOVES, PRIOR_MOVE_MM};
use crate::geometry::unit;
use crate::stereo::{point_of, seen, tolerance_px, RECAPTURES};
use crate::{PixelReading, Plant, PointStatus, Readings, Vector3};

/// The smallest noise (pixels) the fit weighs its residuals by: the fit works in noise units,
/// so a camera configured without noise (`pixel_noise_px = 0`, exact readings) would divide
/// by zero and never fill a hidden light; below this floor the readings' own rounding is the
/// noise. Above it the fit's sigma is the camera's.
const MIN_FIT_SIGMA_PX: f64 = 0.01;

fn fit_sigma_px(pixel_noise_px: f64) -> f64 {
    pixel_noise_px.max(MIN_FIT_SIGMA_PX)
}

/// Where the ray from `o` along unit `u` meets the sphere of radius `r` about `s`: both
/// points in front of the camera, or the ray's closest point when it misses (noise).
fn ray_sphere(o: &Vector3<f64>, u: &Vector3<f64>, s: &Vector3<f64>, r: f64) -> Vec<Vector3<f64>> {
    let w = o - s;
    let b = u.dot(&w);
    let disc = b * b - (w.dot(&w) - r * r);
    let ts = if disc >= 0.0 {
        vec![-b - disc.sqrt(), -b + disc.sqrt()]
    } else {
        vec![-b]
    };
    ts.into_iter()
        .filter(|t| *t > 0.0)
        .map(|t| o + u * t)
        .collect()
}

/// Starts that lie within [`SAME_START_MM`] and [`SAME_START_RAD`] of one kept before them
/// are one start ([`Fit::Analytic`]): two cameras' rays of one marker meet the sphere about
/// another a noise apart, and fits from starts this close end at the same body (a mirror
/// body lies a marker's distance away). The lab's fit solves every start.
fn distinct(starts: Vec<Body>) -> Vec<Body> {
    let mut kept: Vec<Body> = Vec::with_capacity(starts.len());
    for s in starts {
        let same = |k: &Body| {
            (k.centre - s.centre).norm() <= SAME_START_MM
                && (k.normal - s.normal).norm() <= SAME_START_RAD
        };
        if !kept.iter().any(same) {
            kept.push(s);
        }
    }
    kept
}

/// See [`distinct`].
const SAME_START_MM: f64 = 10.0;

/// See [`distinct`].
const SAME_START_RAD: f64 = 0.1;

impl Plant {
    /// Starts for a fit of the body to `readings` (`tri`: the markers seen by both cameras,
    /// triangulated): through two triangulated markers; from one, towards the points at the
    /// markers' distance on the rays of the others' single readings; the track; the track
    /// moved onto the ray of a single reading of the centre.
    pub(super) fn starts(
        &self,
        readings: &[Reading],
        tri: &[Option<Vector3<f64>>; 3],
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
                        x - y
                    } else {
                        y - x
                    };
                    if n.norm() > 1e-6 {
                        let normal = unit(&n);
                        let centre = x - normal * along[m];
                        out.push(Body { centre, normal });
                    }
                }
            }
        }
        if let Some(t) = track {
            let normal = t.normal.unwrap_or(Vector3::new(0.0, 0.0, 1.0));
            out.push(Body {
                centre: t.centre,
                normal,
            });
            for s in readings.iter().filter(|s| s.marker == 2) {
                let (o, u) = ray(s);
                let centre = o + u * (t.centre - o).dot(&u);
                out.push(Body { centre, normal });
            }
        }
        if out.is_empty() {
            // a triangulated marker and nothing else: any direction, the fit turns it
            if let Some((m, x)) = tri.iter().enumerate().find_map(|(m, x)| x.map(|x| (m, x))) {
                for normal in [
                    Vector3::new(0.0, 0.0, 1.0),
                    Vector3::new(0.0, 1.0, 0.0),
                    Vector3::new(1.0, 0.0, 0.0),
                ] {
                    out.push(Body {
                        centre: x - normal * along[m],
                        normal,
                    });
                }
            }
        }
        out
    }

    /// The valid readings of `lights` (p, q) and `centre` (c) as the fit takes them, and each
    /// marker triangulated where both cameras saw it.
    pub(super) fn valid_readings(
        &self,
        lights: &Readings<4>,
        centre: &Readings<2>,
    ) -> (Vec<Reading>, [Option<Vector3<f64>>; 3]) {
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
        (readings, tri)
    }

    /// Fills in the readings of `lights` (p, q) and `centre` (c) that are not valid and that
    /// `wanted` asks for (markers 0 p, 1 q, 2 c), from the marker body: valid where the
    /// readings determine them, estimated where only `track` does (see the module). The
    /// track becomes the body found. Returns what was done.
    pub(super) fn fill_markers(
        &self,
        lights: &mut Readings<4>,
        centre: &mut Readings<2>,
        wanted: &[usize],
        tracker: &mut Tracker,
    ) -> Fill {
        let prior = tracker.prior(wanted == [2]);
        let mut fill = Fill::seen(&lights.points, &centre.points);
        let (readings, tri) = self.valid_readings(lights, centre);
        let cams = &self.cameras;
        if readings.is_empty() {
            fill.no_fit = Some(NoFit::Unseen);
            return fill;
        }
        let mut starts = self.starts(&readings, &tri, tracker.last.or(prior).as_ref());
        if self.fit == Fit::Analytic {
            starts = distinct(starts);
        }
        if starts.is_empty() {
            fill.no_fit = Some(NoFit::NoStart);
            return fill;
        }
        let data = Problem {
            cams,
            d: self.cfg.light_offset_mm,
            sigma: fit_sigma_px(self.cfg.pixel_noise_px),
            readings,
            prior: None,
            method: self.fit,
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
                normal: t.normal.unwrap_or(Vector3::new(0.0, 0.0, 1.0)),
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
            let moved = best.map(|b| (b.centre - t.centre).norm());
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
        let (centre, _) = crate::stereo::triangulate(&self.cameras, a, b)?;
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
            crate::stereo::triangulate(&self.cameras, a, b).map(|(x, _)| x)
        };
        let b = Body::through(&pair(0)?, &pair(1)?)?;
        Some(Track {
            centre: b.centre,
            normal: Some(b.normal),
        })
    }
}
