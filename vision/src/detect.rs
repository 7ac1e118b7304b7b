//! The detector: lights found on pixels.
//!
//! 1. **Background**: its level and noise are estimated from a sparse grid of the frame (one
//!    pixel in 3 of one row in 4): the median and the median absolute deviation, then the
//!    mean and standard deviation of the samples within 4 deviations of the median (at least
//!    2 digital numbers); or they are given ([`BackgroundLevel::Known`]).
//! 2. **Threshold**: a pixel is lit above `level + max(threshold_sigmas x noise,
//!    min_threshold_dn)`.
//! 3. **Connected components** of lit pixels (8-connected), found row by row as runs joined
//!    by a union-find; rows are skipped 32 samples at a time where none is lit.
//! 4. **Centroid**: the intensity-weighted mean of the pixel centres over the component's
//!    bounding box grown by `window_margin_px`, each pixel weighted by its digital number
//!    less the background level (unclipped, so that noise averages out instead of biasing).
//! 5. **Rejection**: a component smaller than `min_area_px` (noise) or larger than
//!    `max_area_px` (a reflection, a lamp), whose window meets another component's (two
//!    lights whose blobs touch: which centre is which cannot be told), with no signal left
//!    after the background, or elongated: the ratio of the principal standard deviations of
//!    its lit pixels' intensity-weighted second moments above `max_elongation` (a light
//!    smeared by motion, two merged lights, a light cut by an edge).

use crate::error::{check, VisionError};
use crate::frame::{Frame, Sample};
use crate::render::MAX_PIXELS;

/// How a blob's centre is computed. Only [`Centroid::Weighted`] is the detector's method; the
/// two others are there to measure what its parts are worth (see `examples/accuracy.rs`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Centroid {
    /// Background-subtracted intensity-weighted mean over the window (the default).
    #[default]
    Weighted,
    /// The mean of the lit pixels' centres, every lit pixel weighing the same.
    Unweighted,
    /// Intensity-weighted without subtracting the background first.
    WeightedRaw,
}

/// The background's level and noise.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum BackgroundLevel {
    /// Estimated from each frame (the default).
    #[default]
    Estimate,
    /// Known from the sensor's calibration (digital numbers).
    Known {
        /// Mean background (digital numbers).
        level_dn: f64,
        /// Its standard deviation (digital numbers).
        noise_dn: f64,
    },
}

/// The detector's parameters.
#[derive(Debug, Clone, PartialEq)]
pub struct DetectorParams {
    /// Lit above this many background standard deviations, > 0.
    pub threshold_sigmas: f64,
    /// ... and at least this many digital numbers above the background, >= 0.
    pub min_threshold_dn: f64,
    /// Components with fewer lit pixels are noise.
    pub min_area_px: usize,
    /// Components with more lit pixels are not a light.
    pub max_area_px: usize,
    /// Largest ratio of the principal standard deviations, >= 1.
    pub max_elongation: f64,
    /// The centroid's window: the bounding box grown by this many pixels.
    pub window_margin_px: u32,
    /// The centroid's method.
    pub centroid: Centroid,
    /// The background.
    pub background: BackgroundLevel,
}

impl Default for DetectorParams {
    fn default() -> DetectorParams {
        DetectorParams {
            threshold_sigmas: 5.0,
            min_threshold_dn: 2.0,
            min_area_px: 3,
            max_area_px: 2_000,
            max_elongation: 2.0,
            window_margin_px: 1,
            centroid: Centroid::Weighted,
            background: BackgroundLevel::Estimate,
        }
    }
}

impl DetectorParams {
    fn validate(&self) -> Result<(), VisionError> {
        check("threshold_sigmas", self.threshold_sigmas, "> 0", |v| {
            v > 0.0
        })?;
        check("min_threshold_dn", self.min_threshold_dn, ">= 0", |v| {
            v >= 0.0
        })?;
        check("min_area_px", self.min_area_px as f64, ">= 1", |v| v >= 1.0)?;
        check(
            "max_area_px",
            self.max_area_px as f64,
            ">= min_area_px",
            |v| v >= self.min_area_px as f64,
        )?;
        check("max_elongation", self.max_elongation, ">= 1", |v| v >= 1.0)?;
        check(
            "window_margin_px",
            self.window_margin_px as f64,
            "<= 64",
            |v| v <= 64.0,
        )?;
        if let BackgroundLevel::Known { level_dn, noise_dn } = self.background {
            check("background level_dn", level_dn, ">= 0", |v| v >= 0.0)?;
            check("background noise_dn", noise_dn, ">= 0", |v| v >= 0.0)?;
        }
        Ok(())
    }
}

/// A component of lit pixels and what was measured on it.
#[derive(Debug, Clone, PartialEq)]
pub struct Blob {
    /// Its centre (pixels, image coordinates: pixel `(i, j)` covers `[i, i+1) x [j, j+1)`).
    pub centre: [f64; 2],
    /// Lit pixels.
    pub area_px: usize,
    /// Digital numbers above the background over the window.
    pub signal_dn: f64,
    /// The brightest pixel (digital number).
    pub peak_dn: u32,
    /// Whether a pixel reached the sample's largest value (the centre is then less sure).
    pub saturated: bool,
    /// Ratio of the principal standard deviations of the lit pixels (1 for a round blob).
    pub elongation: f64,
    /// Bounding box of the lit pixels: `[x0, y0, x1, y1)`.
    pub bounds: [u32; 4],
}

/// Why a component is not taken for a light.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Rejection {
    /// Fewer lit pixels than `min_area_px`.
    TooSmall,
    /// More lit pixels than `max_area_px`.
    TooLarge,
    /// Its window meets another component's.
    Crowded,
    /// Nothing above the background over its window.
    NoSignal,
    /// Elongated beyond `max_elongation`.
    Elongated,
}

/// What the detector found in one frame.
#[derive(Debug, Clone, PartialEq)]
pub struct Detection {
    /// The lights, in the order of their first lit pixel (row by row).
    pub blobs: Vec<Blob>,
    /// Components that are not lights, and why.
    pub rejected: Vec<(Blob, Rejection)>,
    /// Background level (digital numbers).
    pub background_dn: f64,
    /// Background standard deviation (digital numbers).
    pub noise_dn: f64,
    /// A pixel is lit above this (digital numbers).
    pub threshold_dn: f64,
}

/// The detector for frames of one size.
#[derive(Debug, Clone, PartialEq)]
pub struct Detector {
    params: DetectorParams,
    width: u32,
    height: u32,
}

#[derive(Debug, Clone, Copy)]
struct Run {
    y: u32,
    x0: u32,
    x1: u32,
}

#[derive(Debug, Clone)]
struct Component {
    area: usize,
    bounds: [u32; 4],
    runs: Vec<usize>,
}

impl Detector {
    /// A detector for `width` x `height` frames (checked, as are the parameters).
    pub fn new(width: u32, height: u32, params: DetectorParams) -> Result<Detector, VisionError> {
        if width == 0 || height == 0 {
            return Err(VisionError::EmptyFrame { width, height });
        }
        check(
            "frame pixels",
            width as f64 * height as f64,
            "at most 2^28",
            |v| v <= MAX_PIXELS as f64,
        )?;
        params.validate()?;
        Ok(Detector {
            params,
            width,
            height,
        })
    }

    /// The parameters.
    pub fn params(&self) -> &DetectorParams {
        &self.params
    }

    /// The lights in `frame`.
    pub fn detect<P: Sample>(&self, frame: &Frame<P>) -> Result<Detection, VisionError> {
        self.detect_samples(frame.width(), frame.height(), frame.as_raw())
    }

    /// The lights in a frame given as `width` x `height` samples, row by row.
    pub fn detect_samples<P: Sample>(
        &self,
        width: u32,
        height: u32,
        samples: &[P],
    ) -> Result<Detection, VisionError> {
        if width == 0 || height == 0 || samples.is_empty() {
            return Err(VisionError::EmptyFrame { width, height });
        }
        if (width, height) != (self.width, self.height)
            || samples.len() as u64 != width as u64 * height as u64
        {
            return Err(VisionError::WrongSize {
                width: self.width,
                height: self.height,
                got_width: width,
                got_height: height,
                got_len: samples.len(),
            });
        }
        let p = &self.params;
        let (level, noise) = match p.background {
            BackgroundLevel::Known { level_dn, noise_dn } => (level_dn, noise_dn),
            BackgroundLevel::Estimate => estimate_background(width, height, samples),
        };
        let threshold = level + (p.threshold_sigmas * noise).max(p.min_threshold_dn);
        let runs = find_runs(width, samples, threshold);
        let components = join(&runs);
        let mut detection = Detection {
            blobs: Vec::new(),
            rejected: Vec::new(),
            background_dn: level,
            noise_dn: noise,
            threshold_dn: threshold,
        };
        let windows: Vec<[u32; 4]> = components.iter().map(|c| self.window(c)).collect();
        for (n, c) in components.iter().enumerate() {
            let blob = self.measure(c, &windows[n], &runs, samples, level);
            let crowded = components.iter().enumerate().any(|(m, o)| {
                m != n && o.area >= p.min_area_px && overlaps(&windows[n], &windows[m])
            });
            let rejection = if c.area < p.min_area_px {
                Some(Rejection::TooSmall)
            } else if c.area > p.max_area_px {
                Some(Rejection::TooLarge)
            } else if crowded {
                Some(Rejection::Crowded)
            } else if blob.signal_dn <= 0.0 || !blob.centre.iter().all(|v| v.is_finite()) {
                Some(Rejection::NoSignal)
            } else if blob.elongation > p.max_elongation {
                Some(Rejection::Elongated)
            } else {
                None
            };
            match rejection {
                Some(r) => detection.rejected.push((blob, r)),
                None => detection.blobs.push(blob),
            }
        }
        Ok(detection)
    }

    /// The component's bounding box grown by the margin, clipped to the frame.
    fn window(&self, c: &Component) -> [u32; 4] {
        let m = self.params.window_margin_px;
        [
            c.bounds[0].saturating_sub(m),
            c.bounds[1].saturating_sub(m),
            (c.bounds[2] + m).min(self.width),
            (c.bounds[3] + m).min(self.height),
        ]
    }

    fn measure<P: Sample>(
        &self,
        c: &Component,
        window: &[u32; 4],
        runs: &[Run],
        samples: &[P],
        level: f64,
    ) -> Blob {
        let w = self.width as usize;
        let at = |x: u32, y: u32| samples[y as usize * w + x as usize].dn() as f64;
        // the lit pixels: unweighted centre and the weighted second moments
        let (mut n, mut sx, mut sy, mut peak) = (0.0, 0.0, 0.0, 0);
        let (mut m0, mut mx, mut my, mut mxx, mut myy, mut mxy) = (0.0, 0.0, 0.0, 0.0, 0.0, 0.0);
        for r in c.runs.iter().map(|&i| runs[i]) {
            let y = r.y as f64 + 0.5;
            for x in r.x0..r.x1 {
                peak = peak.max(samples[r.y as usize * w + x as usize].dn());
                let v = (at(x, r.y) - level).max(0.0);
                let xc = x as f64 + 0.5;
                n += 1.0;
                sx += xc;
                sy += y;
                m0 += v;
                mx += v * xc;
                my += v * y;
                mxx += v * xc * xc;
                myy += v * y * y;
                mxy += v * xc * y;
            }
        }
        let elongation = if m0 > 0.0 {
            let (cx, cy) = (mx / m0, my / m0);
            // a pixel's own extent adds 1/12 to each variance
            let vxx = mxx / m0 - cx * cx + 1.0 / 12.0;
            let vyy = myy / m0 - cy * cy + 1.0 / 12.0;
            let vxy = mxy / m0 - cx * cy;
            let mean = (vxx + vyy) / 2.0;
            let d = (((vxx - vyy) / 2.0).powi(2) + vxy * vxy).sqrt();
            ((mean + d) / (mean - d).max(1e-12)).sqrt()
        } else {
            f64::INFINITY
        };
        // the window: background-subtracted (or raw) intensity-weighted centre
        let raw = self.params.centroid == Centroid::WeightedRaw;
        let (mut s0, mut s0_signal, mut s1x, mut s1y) = (0.0, 0.0, 0.0, 0.0);
        for y in window[1]..window[3] {
            for x in window[0]..window[2] {
                let v = at(x, y);
                let wgt = if raw { v } else { v - level };
                s0 += wgt;
                s0_signal += v - level;
                s1x += wgt * (x as f64 + 0.5);
                s1y += wgt * (y as f64 + 0.5);
            }
        }
        let centre = match self.params.centroid {
            Centroid::Unweighted => [sx / n, sy / n],
            Centroid::Weighted | Centroid::WeightedRaw => [s1x / s0, s1y / s0],
        };
        Blob {
            centre,
            area_px: c.area,
            signal_dn: s0_signal,
            peak_dn: peak,
            saturated: peak >= P::MAX_DN,
            elongation,
            bounds: c.bounds,
        }
    }
}

fn overlaps(a: &[u32; 4], b: &[u32; 4]) -> bool {
    a[0] < b[2] && b[0] < a[2] && a[1] < b[3] && b[1] < a[3]
}

/// Background level and standard deviation (digital numbers) from a sparse grid.
fn estimate_background<P: Sample>(width: u32, height: u32, samples: &[P]) -> (f64, f64) {
    let mut hist = vec![0u32; P::MAX_DN as usize + 1];
    let mut count = 0u64;
    let (w, h) = (width as usize, height as usize);
    let row_step = if h >= 16 { 4 } else { 1 };
    let col_step = if w >= 12 { 3 } else { 1 };
    for y in (0..h).step_by(row_step) {
        for v in samples[y * w..(y + 1) * w].iter().step_by(col_step) {
            hist[v.dn() as usize] += 1;
            count += 1;
        }
    }
    // the median, then the median absolute deviation
    let half = count.div_ceil(2);
    let mut acc = 0u64;
    let median = hist
        .iter()
        .position(|&c| {
            acc += c as u64;
            acc >= half
        })
        .unwrap_or(0);
    let mut mad = 0usize;
    loop {
        let lo = median.saturating_sub(mad);
        let hi = (median + mad).min(hist.len() - 1);
        let within: u64 = hist[lo..=hi].iter().map(|&c| c as u64).sum();
        if within >= half || (lo == 0 && hi == hist.len() - 1) {
            break;
        }
        mad += 1;
    }
    let reach = ((4.0 * 1.4826 * mad as f64).ceil() as usize).max(2);
    let lo = median.saturating_sub(reach);
    let hi = (median + reach).min(hist.len() - 1);
    let (mut n, mut s, mut ss) = (0.0, 0.0, 0.0);
    for (d, &c) in hist.iter().enumerate().take(hi + 1).skip(lo) {
        let (d, c) = (d as f64, c as f64);
        n += c;
        s += c * d;
        ss += c * d * d;
    }
    let mean = s / n;
    (mean, (ss / n - mean * mean).max(0.0).sqrt())
}

/// The runs of samples above `threshold`, row by row, left to right.
fn find_runs<P: Sample>(width: u32, samples: &[P], threshold: f64) -> Vec<Run> {
    const CHUNK: usize = 32;
    // lit: dn > threshold (>= 0), that is dn > t for the integer t below
    let t = P::from_dn(threshold.floor().clamp(0.0, P::MAX_DN as f64) as u32);
    let mut runs = Vec::new();
    for (y, row) in samples.chunks_exact(width as usize).enumerate() {
        let lit = |v: &P| *v > t;
        let mut x = 0;
        while x < row.len() {
            let end = (x + CHUNK).min(row.len());
            // no early exit, so that the comparison vectorises
            if !row[x..end].iter().fold(false, |any, v| any | (*v > t)) {
                x = end;
                continue;
            }
            if !lit(&row[x]) {
                x += 1;
                continue;
            }
            let start = x;
            while x < row.len() && lit(&row[x]) {
                x += 1;
            }
            runs.push(Run {
                y: y as u32,
                x0: start as u32,
                x1: x as u32,
            });
        }
    }
    runs
}

fn find(parent: &mut [usize], mut i: usize) -> usize {
    while parent[i] != i {
        parent[i] = parent[parent[i]];
        i = parent[i];
    }
    i
}

/// The 8-connected components of the runs.
fn join(runs: &[Run]) -> Vec<Component> {
    let mut parent: Vec<usize> = (0..runs.len()).collect();
    let mut prev = 0..0;
    let mut i = 0;
    while i < runs.len() {
        let y = runs[i].y;
        let start = i;
        while i < runs.len() && runs[i].y == y {
            i += 1;
        }
        let cur = start..i;
        if prev.end > prev.start && runs[prev.start].y + 1 == y {
            let mut j = prev.start;
            for c in cur.clone() {
                while j < prev.end && runs[j].x1 < runs[c].x0 {
                    j += 1;
                }
                let mut k = j;
                while k < prev.end && runs[k].x0 <= runs[c].x1 {
                    let (a, b) = (find(&mut parent, c), find(&mut parent, k));
                    if a != b {
                        parent[a.max(b)] = a.min(b);
                    }
                    k += 1;
                }
            }
        }
        prev = cur;
    }
    let mut index = vec![usize::MAX; runs.len()];
    let mut components: Vec<Component> = Vec::new();
    for (n, r) in runs.iter().enumerate() {
        let root = find(&mut parent, n);
        if index[root] == usize::MAX {
            index[root] = components.len();
            components.push(Component {
                area: 0,
                bounds: [r.x0, r.y, r.x1, r.y + 1],
                runs: Vec::new(),
            });
        }
        let c = &mut components[index[root]];
        c.area += (r.x1 - r.x0) as usize;
        c.bounds = [
            c.bounds[0].min(r.x0),
            c.bounds[1].min(r.y),
            c.bounds[2].max(r.x1),
            c.bounds[3].max(r.y + 1),
        ];
        c.runs.push(n);
    }
    components
}

#[cfg(test)]
mod tests;
