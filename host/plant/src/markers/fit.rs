//! The fit of the marker body to the readings a capture saw: a Levenberg-Marquardt fit in
//! the body's five local coordinates, with the trial's track as a weak prior or without,
//! and the standard error of a hidden marker placed from the body the readings determine.

use nalgebra::{SMatrix, SVector, Vector3};
use rayon::prelude::*;

use super::{tangents, Body, Fit, Track, PRIOR_MOVE_MM, PRIOR_TURN_RAD};
use crate::camera::{Camera, PixelGradient};
use crate::stereo::tolerance_px;

/// One valid reading: marker (0 p, 1 q, 2 c), camera, pixel.
#[derive(Debug, Clone, Copy)]
pub(super) struct Reading {
    pub(super) marker: usize,
    pub(super) cam: usize,
    pub(super) uv: (f64, f64),
}

/// A fit of the body to readings, with a track as prior or without.
pub(super) struct Problem<'a> {
    pub(super) cams: &'a [Camera; 2],
    pub(super) d: f64,
    pub(super) sigma: f64,
    pub(super) readings: Vec<Reading>,
    pub(super) prior: Option<Track>,
    pub(super) method: Fit,
}

/// [`Fit::Analytic`] stops after a step whose linearisation promised to lower the cost (noise
/// units squared, at least 1) by no more than this fraction of it: the steps that follow
/// would move the body by less than about a millionth of the noise.
const CONVERGED: f64 = 1e-12;

/// [`Fit::Analytic`] leaves a start fitted without a prior once it is stuck in a minimum
/// that explains nothing: its cost above this many times that of every reading off by the
/// stereo tolerance (no such body is one the fill takes), and its last step lowering it by
/// less than [`STUCK_GAIN`] of it. The lab's fit follows such a start to its minimum, in
/// about twice the iterations of one that explains the readings.
const STUCK_COST: f64 = 2.0;

/// See [`STUCK_COST`].
const STUCK_GAIN: f64 = 0.1;

impl Problem<'_> {
    /// The residuals in noise units (readings, then the prior's rows); `None` when a marker
    /// leaves an image.
    fn residuals(&self, b: &Body) -> Option<Vec<f64>> {
        let mut r = Vec::with_capacity(2 * self.readings.len() + 6);
        self.residuals_into(b, &mut r)?;
        Some(r)
    }

    /// [`Problem::residuals`] into `r` (its allocation reused).
    fn residuals_into(&self, b: &Body, r: &mut Vec<f64>) -> Option<()> {
        r.clear();
        let m = b.markers(self.d);
        for s in &self.readings {
            let (u, v) = self.cams[s.cam].project(&m[s.marker])?;
            r.extend([(u - s.uv.0) / self.sigma, (v - s.uv.1) / self.sigma]);
        }
        if let Some(t) = &self.prior {
            r.extend((b.centre - t.centre).map(|x| x / PRIOR_MOVE_MM).iter());
            if let Some(n) = &t.normal {
                r.extend((b.normal - n).map(|x| x / PRIOR_TURN_RAD).iter());
            }
        }
        Some(())
    }

    /// The residuals and their Jacobian in the body's local coordinates by forward
    /// differences ([`Fit::Differences`]), into `s.r` and `s.jac` (`s.rk` the moved bodies' residuals).
    fn linearised_into(&self, b: &Body, s: &mut Scratch) -> Option<()> {
        const H: f64 = 1e-4;
        self.residuals_into(b, &mut s.r)?;
        s.jac.clear();
        s.jac.resize(s.r.len(), [0.0; 5]);
        for k in 0..5 {
            let mut x = [0.0; 5];
            x[k] = H;
            self.residuals_into(&b.moved(&x), &mut s.rk)?;
            for (row, (a, b)) in s.jac.iter_mut().zip(s.rk.iter().zip(&s.r)) {
                row[k] = (a - b) / H;
            }
        }
        Some(())
    }

    /// The residuals and their Jacobian as the fit's [`Fit`] works them out.
    fn linearise(&self, b: &Body, s: &mut Scratch) -> Option<()> {
        match self.method {
            Fit::Differences => self.linearised_into(b, s),
            Fit::Analytic => self.linearised_analytic_into(b, s),
        }
    }

    /// [`Problem::linearised_into`] with the Jacobian differentiated through the body, the
    /// lenses and the prior ([`Fit::Analytic`]); `s.rk` untouched.
    fn linearised_analytic_into(&self, b: &Body, s: &mut Scratch) -> Option<()> {
        s.r.clear();
        s.jac.clear();
        let m = b.markers(self.d);
        let (t1, t2) = tangents(&b.normal);
        for rd in &self.readings {
            let (uv, grad) = self.cams[rd.cam].project_with_gradient(&m[rd.marker])?;
            s.r.extend([(uv.0 - rd.uv.0) / self.sigma, (uv.1 - rd.uv.1) / self.sigma]);
            for row in self.marker_rows(&grad, rd.marker, &t1, &t2) {
                s.jac.push(row.map(|x| x / self.sigma));
            }
        }
        if let Some(t) = &self.prior {
            for i in 0..3 {
                s.r.push((b.centre[i] - t.centre[i]) / PRIOR_MOVE_MM);
                let mut row = [0.0; 5];
                row[i] = 1.0 / PRIOR_MOVE_MM;
                s.jac.push(row);
            }
            if let Some(n) = &t.normal {
                for i in 0..3 {
                    s.r.push((b.normal[i] - n[i]) / PRIOR_TURN_RAD);
                    s.jac.push([
                        0.0,
                        0.0,
                        0.0,
                        t1[i] / PRIOR_TURN_RAD,
                        t2[i] / PRIOR_TURN_RAD,
                    ]);
                }
            }
        }
        Some(())
    }

    /// A pixel's `u` and `v` rows of the Jacobian in the body's local coordinates
    /// ([`Body::moved`]: the centre's three, then the normal's turn about `t1` and `t2`,
    /// which moves marker `marker` by its offset along the normal times the tangent), from
    /// the pixel's gradient in the marker's position.
    fn marker_rows(
        &self,
        grad: &PixelGradient,
        marker: usize,
        t1: &Vector3<f64>,
        t2: &Vector3<f64>,
    ) -> [[f64; 5]; 2] {
        let along = [self.d, -self.d, 0.0][marker];
        grad.map(|g| [g.x, g.y, g.z, along * g.dot(t1), along * g.dot(t2)])
    }

    /// The cost of a body with every reading off by the stereo tolerance in both
    /// coordinates: a body that costs more leaves at least one reading beyond it.
    fn explaining_cost(&self) -> f64 {
        let k = tolerance_px(self.sigma) / self.sigma;
        2.0 * self.readings.len() as f64 * k * k
    }

    /// Levenberg-Marquardt from `start`; the body and its cost.
    fn solve(&self, start: Body) -> Option<(Body, f64)> {
        let cost = |r: &[f64]| r.iter().map(|v| v * v).sum::<f64>();
        let mut s = Scratch::default();
        let mut b = start;
        self.residuals_into(&b, &mut s.rn)?;
        let mut c = cost(&s.rn);
        let mut lambda = 1e-3;
        for _ in 0..40 {
            self.linearise(&b, &mut s)?;
            let (r, jac) = (&s.r, &s.jac);
            let jtj = normal_matrix(jac);
            let jtr =
                SVector::<f64, 5>::from_fn(|a, _| jac.iter().zip(r).map(|(j, r)| j[a] * r).sum());
            let mut improved = false;
            let mut converged = false;
            for _ in 0..8 {
                let damped = jtj
                    + SMatrix::<f64, 5, 5>::from_diagonal(
                        &(jtj.diagonal() * lambda + SVector::<f64, 5>::repeat(1e-9)),
                    );
                // (the damped normal matrix is positive definite: Cholesky takes half the
                // LU's work; the lab's fit keeps its LU, bit for bit)
                let step = match self.method {
                    Fit::Differences => damped.lu().solve(&jtr),
                    Fit::Analytic => damped.cholesky().map(|c| c.solve(&jtr)),
                };
                let Some(step) = step else {
                    lambda *= 10.0;
                    continue;
                };
                let x: [f64; 5] = core::array::from_fn(|k| -step[k]);
                let next = b.moved(&x);
                match self.residuals_into(&next, &mut s.rn) {
                    Some(()) if cost(&s.rn) < c => {
                        // what the step was to gain by the linearisation
                        let gain = 2.0 * step.dot(&jtr) - step.dot(&(jtj * step));
                        let (before, after) = (c, cost(&s.rn));
                        converged = self.method == Fit::Analytic
                            && (gain <= CONVERGED * before.max(1.0)
                                || (self.prior.is_none()
                                    && after > STUCK_COST * self.explaining_cost()
                                    && before - after < STUCK_GAIN * before));
                        (b, c) = (next, after);
                        lambda = (lambda / 3.0).max(1e-9);
                        improved = true;
                        break;
                    }
                    _ => lambda *= 10.0,
                }
            }
            if !improved || converged {
                break;
            }
        }
        Some((b, c))
    }

    /// The best body over `starts`.
    pub(super) fn best(&self, starts: &[Body]) -> Option<Body> {
        self.all(starts)
            .into_iter()
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(b, _)| b)
    }

    /// The body each start leads to, with its cost, in the order of `starts`. Called on a
    /// thread of rayon's pool (the arms of a vector environment, a study's runs), the starts
    /// are solved in parallel on that pool: a move that must place a hidden light costs
    /// several times one that need not, and a vector environment's step waits for its
    /// slowest arm, whose starts the other threads can take. Elsewhere (one arm, one run)
    /// they are solved in turn: handing them to the pool and waking it costs a single arm
    /// more than it gains. Each solve is independent of the others, so the result is the
    /// same bit for bit either way.
    pub(super) fn all(&self, starts: &[Body]) -> Vec<(Body, f64)> {
        if starts.len() < 2 || rayon::current_thread_index().is_none() {
            return starts.iter().filter_map(|s| self.solve(*s)).collect();
        }
        starts.par_iter().filter_map(|s| self.solve(*s)).collect()
    }

    /// The largest reading residual of `b` (pixels).
    pub(super) fn worst_px(&self, b: &Body) -> Option<f64> {
        let r = self.residuals(b)?;
        let n = 2 * self.readings.len();
        Some(r[..n].iter().fold(0.0f64, |m, v| m.max(v.abs())) * self.sigma)
    }

    /// The standard error (pixels, the larger axis) of marker `marker` seen by `cam` for
    /// the body `b` fitted to the readings alone; infinite when they do not determine it.
    pub(super) fn fill_error_px(&self, b: &Body, marker: usize, cam: usize) -> f64 {
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
        let mut s = Scratch::default();
        if data.linearise(b, &mut s).is_none() {
            return f64::INFINITY;
        }
        let eig = normal_matrix(&s.jac).symmetric_eigen();
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
        match self.method {
            Fit::Analytic => {
                let marker_at = b.markers(self.d)[marker];
                let Some((_, grad)) = self.cams[cam].project_with_gradient(&marker_at) else {
                    return f64::INFINITY;
                };
                let (t1, t2) = tangents(&b.normal);
                for (i, row) in self.marker_rows(&grad, marker, &t1, &t2).iter().enumerate() {
                    for (k, x) in row.iter().enumerate() {
                        jf[(i, k)] = *x;
                    }
                }
            }
            Fit::Differences => {
                for k in 0..5 {
                    let mut x = [0.0; 5];
                    x[k] = H;
                    let Some(uv) = project(&b.moved(&x)) else {
                        return f64::INFINITY;
                    };
                    jf[(0, k)] = (uv.0 - at.0) / H;
                    jf[(1, k)] = (uv.1 - at.1) / H;
                }
            }
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

/// `J^T J` of rows `jac`: each sum over the rows in their order, the lower triangle the
/// upper one's mirror (`j[a] * j[b]` is `j[b] * j[a]`, bit for bit).
fn normal_matrix(jac: &[[f64; 5]]) -> SMatrix<f64, 5, 5> {
    let mut m = SMatrix::<f64, 5, 5>::zeros();
    for a in 0..5 {
        for b in a..5 {
            let v: f64 = jac.iter().map(|j| j[a] * j[b]).sum();
            m[(a, b)] = v;
            m[(b, a)] = v;
        }
    }
    m
}

/// The buffers of a fit's evaluations, reused from one to the next.
#[derive(Default)]
struct Scratch {
    /// Residuals at the body, and at a body moved along one coordinate.
    r: Vec<f64>,
    rk: Vec<f64>,
    /// Residuals at a step's candidate body.
    rn: Vec<f64>,
    /// The residuals' Jacobian, one row a residual.
    jac: Vec<[f64; 5]>,
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The mirrored `J^T J` is every entry's own sum, bit for bit.
    #[test]
    fn the_normal_matrix_is_each_entrys_sum() {
        let mut x = 0.123_f64;
        let jac: Vec<[f64; 5]> = (0..17)
            .map(|_| {
                core::array::from_fn(|_| {
                    x = (x * 3.7 + 0.31).fract();
                    (x - 0.5) * 1e3
                })
            })
            .collect();
        let full =
            SMatrix::<f64, 5, 5>::from_fn(|a, b| jac.iter().map(|j| j[a] * j[b]).sum::<f64>());
        assert_eq!(
            normal_matrix(&jac).map(f64::to_bits),
            full.map(f64::to_bits)
        );
    }
}
