//! How well the detector measures a light: its centroid error on rendered frames against the
//! Cramér-Rao bound of the blob.
//!
//! **The bound.** A pixel `i` of a blob of total `N` electrons, Gaussian of deviation `s`
//! centred at `(x0, y0)`, collects a mean `mu_i = N a_i(x0) b_i(y0) + B` electrons, `a_i` and
//! `b_i` the Gaussian's mass over the pixel's column and row and `B` the stray light. Its
//! reading has variance `v_i = mu_i + r^2 + 1/(12 g^2)` (shot noise, read noise `r`, the
//! rounding to digital numbers at gain `g`), and the Fisher information of the parameters
//! `(x0, y0, N, B)` is `I_jk = sum_i (d mu_i / d p_j)(d mu_i / d p_k) / v_i`. No unbiased
//! estimator of `x0` has a variance below `(I^-1)_00`; [`cramer_rao_px`] averages that over
//! the blob's position within a pixel and returns its square root (pixels, per axis). Without
//! background and read noise, and for a large blob, it tends to `sqrt((s^2 + 1/12) / N)`.
//!
//! **The measurement.** [`measure`] renders `frames` frames, each with one blob at a random
//! sub-pixel position (seeded), detects it and records the distance from the true centre.
//! An estimator at the bound has Gaussian errors of deviation `sigma` per axis, so its
//! distance errors have the median `sigma sqrt(2 ln 2) = 1.177 sigma`, to which the measured
//! median is compared.

use rand_core::{RngCore, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;

use crate::detect::{Centroid, Detector, DetectorParams};
use crate::error::{check, VisionError};
use crate::random::{normal_cdf, normal_pdf, uniform};
use crate::render::{Emitter, Renderer, Scene, Sensor};

/// The median distance error of an estimator at the bound, in units of the per-axis bound.
pub const MEDIAN_DISTANCE_PER_SIGMA: f64 = 1.177_410_022_515_474_7;

/// The nominal blob: an LED of the plant's gripper at about 2 m, imaged by the plant's
/// cameras ([`Sensor::machine_vision`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Blob {
    /// Gaussian standard deviation (pixels).
    pub sigma_px: f64,
    /// Electrons over the exposure.
    pub electrons: f64,
}

impl Blob {
    /// Deviation 1.3 px, 30,000 electrons: its brightest pixel about 2,700 electrons, 145 of
    /// the 8-bit sensor's 255 digital numbers, unsaturated.
    pub fn nominal() -> Blob {
        Blob {
            sigma_px: 1.3,
            electrons: 30_000.0,
        }
    }
}

/// The Cramér-Rao bound (pixels, per axis) on the centre of `blob` on `sensor`, with its
/// electrons and the background unknown, averaged over the blob's position within a pixel.
pub fn cramer_rao_px(sensor: &Sensor, blob: &Blob) -> Result<f64, VisionError> {
    sensor.validate()?;
    check("blob sigma_px", blob.sigma_px, "in [0.1, 100]", |v| {
        (0.1..=100.0).contains(&v)
    })?;
    check("blob electrons", blob.electrons, "> 0", |v| v > 0.0)?;
    const GRID: usize = 8;
    let mut var = 0.0;
    for gx in 0..GRID {
        for gy in 0..GRID {
            let c = [
                (gx as f64 + 0.5) / GRID as f64,
                (gy as f64 + 0.5) / GRID as f64,
            ];
            var += fisher_inverse_00(sensor, blob, c);
        }
    }
    Ok((var / (GRID * GRID) as f64).sqrt())
}

/// `(I^-1)_00` for a blob centred at `c` within pixel (0, 0).
fn fisher_inverse_00(sensor: &Sensor, blob: &Blob, c: [f64; 2]) -> f64 {
    let s = blob.sigma_px;
    let reach = (6.0 * s).ceil() as i64 + 3;
    let axis = |c: f64| -> Vec<(f64, f64)> {
        // (mass over the pixel, its derivative by the centre)
        (-reach..=reach)
            .map(|i| {
                let (a, b) = ((i as f64 - c) / s, (i as f64 + 1.0 - c) / s);
                (
                    normal_cdf(b) - normal_cdf(a),
                    (normal_pdf(a) - normal_pdf(b)) / s,
                )
            })
            .collect()
    };
    let (ax, ay) = (axis(c[0]), axis(c[1]));
    let extra = sensor.read_noise_e.powi(2) + 1.0 / (12.0 * sensor.gain_dn_per_e.powi(2));
    let n = blob.electrons;
    let mut fisher = [[0.0; 4]; 4];
    for (mx, dx) in &ax {
        for (my, dy) in &ay {
            let mu = n * mx * my + sensor.stray_e;
            let grad = [n * dx * my, n * mx * dy, mx * my, 1.0];
            let v = mu + extra;
            for j in 0..4 {
                for k in 0..4 {
                    fisher[j][k] += grad[j] * grad[k] / v;
                }
            }
        }
    }
    invert_00(fisher)
}

/// The (0, 0) entry of the inverse of a symmetric positive definite 4 x 4 matrix: Gauss-Jordan
/// elimination with partial pivoting.
fn invert_00(mut a: [[f64; 4]; 4]) -> f64 {
    let mut inv = [[0.0; 4]; 4];
    for (i, row) in inv.iter_mut().enumerate() {
        row[i] = 1.0;
    }
    for col in 0..4 {
        let pivot = (col..4)
            .max_by(|&i, &j| a[i][col].abs().total_cmp(&a[j][col].abs()))
            .unwrap_or(col);
        a.swap(col, pivot);
        inv.swap(col, pivot);
        let p = a[col][col];
        for k in 0..4 {
            a[col][k] /= p;
            inv[col][k] /= p;
        }
        for r in 0..4 {
            if r != col {
                let f = a[r][col];
                for k in 0..4 {
                    a[r][k] -= f * a[col][k];
                    inv[r][k] -= f * inv[col][k];
                }
            }
        }
    }
    inv[0][0]
}

/// What [`measure`] found.
#[derive(Debug, Clone, PartialEq)]
pub struct Accuracy {
    /// Frames rendered.
    pub frames: usize,
    /// Frames in which the blob was not found (no blob or more than one).
    pub missed: usize,
    /// Median distance error (pixels).
    pub p50_px: f64,
    /// 95th percentile of the distance error (pixels).
    pub p95_px: f64,
    /// Root mean square error per axis (pixels).
    pub rms_axis_px: f64,
    /// The Cramér-Rao bound per axis (pixels).
    pub bound_px: f64,
    /// The median distance error of an estimator at the bound (pixels).
    pub bound_p50_px: f64,
}

impl Accuracy {
    /// Measured median over the bound's median.
    pub fn p50_ratio(&self) -> f64 {
        self.p50_px / self.bound_p50_px
    }
}

/// The frame the measurement renders on: 48 x 48 pixels of `sensor`'s noise (the blob's
/// neighbourhood; the rest of a large frame does not change the centroid).
pub const MEASURE_FRAME_PX: u32 = 48;

/// Centroid errors of the detector with `centroid` over `frames` frames (seeded by `seed`),
/// each with `blob` at a uniformly random position within the central pixel's area.
pub fn measure(
    sensor: &Sensor,
    blob: &Blob,
    centroid: Centroid,
    frames: usize,
    seed: u64,
) -> Result<Accuracy, VisionError> {
    check("frames", frames as f64, ">= 1", |v| v >= 1.0)?;
    let bound_px = cramer_rao_px(sensor, blob)?;
    let small = Sensor {
        width: MEASURE_FRAME_PX,
        height: MEASURE_FRAME_PX,
        ..sensor.clone()
    };
    let renderer = Renderer::<u8>::new(&small)?;
    let detector = Detector::new(
        small.width,
        small.height,
        DetectorParams {
            centroid,
            ..DetectorParams::default()
        },
    )?;
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
    let mid = (MEASURE_FRAME_PX / 2) as f64;
    let mut distances = Vec::with_capacity(frames);
    let mut square = 0.0;
    let mut missed = 0;
    for _ in 0..frames {
        let truth = [mid + uniform(&mut rng), mid + uniform(&mut rng)];
        let scene = Scene {
            emitters: vec![Emitter::new(truth, blob.sigma_px, blob.electrons)],
            occluders: Vec::new(),
        };
        let frame = renderer.render(&scene, rng.next_u64())?;
        let d = detector.detect(&frame)?;
        match d.blobs.as_slice() {
            [b] => {
                let (ex, ey) = (b.centre[0] - truth[0], b.centre[1] - truth[1]);
                square += ex * ex + ey * ey;
                distances.push(ex.hypot(ey));
            }
            _ => missed += 1,
        }
    }
    if distances.is_empty() {
        return Err(VisionError::Parameter {
            name: "blob electrons",
            value: blob.electrons,
            rule: "bright enough to be detected in some frame",
        });
    }
    distances.sort_by(f64::total_cmp);
    let q = |p: f64| distances[((distances.len() - 1) as f64 * p).round() as usize];
    Ok(Accuracy {
        frames,
        missed,
        p50_px: q(0.5),
        p95_px: q(0.95),
        rms_axis_px: (square / (2.0 * distances.len() as f64)).sqrt(),
        bound_px,
        bound_p50_px: bound_px * MEDIAN_DISTANCE_PER_SIGMA,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_bound_tends_to_the_photon_limit_without_background() {
        // no stray light, no read noise, a fine ADC: (s^2 + 1/12) / N for a large blob
        let sensor = Sensor {
            read_noise_e: 0.0,
            stray_e: 0.0,
            gain_dn_per_e: 1e3,
            ..Sensor::machine_vision(64, 64)
        };
        let blob = Blob {
            sigma_px: 3.0,
            electrons: 1e4,
        };
        let want = ((9.0 + 1.0 / 12.0) / 1e4f64).sqrt();
        let got = cramer_rao_px(&sensor, &blob).unwrap();
        assert!((got / want - 1.0).abs() < 0.01, "{got} {want}");
        // background noise can only raise it, as can fewer electrons
        let noisy = cramer_rao_px(&Sensor::machine_vision(64, 64), &blob).unwrap();
        assert!(noisy > got * 1.05, "{noisy} {got}");
        let dim = Blob {
            electrons: 2.5e3,
            ..blob
        };
        assert!((cramer_rao_px(&sensor, &dim).unwrap() / got - 2.0).abs() < 0.02);
    }

    #[test]
    fn bad_blobs_are_refused() {
        let s = Sensor::machine_vision(64, 64);
        for b in [
            Blob {
                sigma_px: f64::NAN,
                electrons: 1.0,
            },
            Blob {
                sigma_px: 1.0,
                electrons: 0.0,
            },
        ] {
            assert!(matches!(
                cramer_rao_px(&s, &b),
                Err(VisionError::Parameter { .. })
            ));
        }
        assert!(measure(&s, &Blob::nominal(), Centroid::Weighted, 0, 1).is_err());
    }
}
