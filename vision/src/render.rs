//! The frame renderer: LEDs as small emitters on a dark sensor.
//!
//! Each [`Emitter`] is a Gaussian spot (the LED through a lens: its disc, the lens' blur and
//! the pixel's aperture together) of standard deviation `sigma_px` holding `electrons`
//! photo-electrons over the exposure, moving uniformly by `motion_px` during it (the arm's
//! residual oscillation). Each pixel collects the spot's integral over its area, minus what
//! [`Occluder`]s nearer than the emitter hide, plus a uniform stray light `stray_e`; the
//! electrons are a Poisson draw of that mean (shot noise), clipped at the full well
//! (saturation), read out with Gaussian read noise, then converted at `gain_dn_per_e` plus
//! a black level `offset_dn` and rounded to the frame's digital numbers (clamped to the
//! sample's range).
//!
//! Only the emitters' neighbourhoods (5 sigma around the path, plus a pixel) are computed
//! pixel by pixel; the rest of the frame, where a pixel holds stray light only, is drawn from
//! that pixel's exact distribution of digital numbers, tabulated once per [`Renderer`]: one
//! 32-bit uniform and a table look-up per pixel. A frame is a function of its scene and seed.

use std::marker::PhantomData;

use rand_core::{RngCore, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;

use crate::error::{check, VisionError};
use crate::frame::{Frame, Sample};
use crate::random::{gaussian, ln_gamma, normal_cdf, poisson};

/// The largest frame the renderer and the detector accept (pixels).
pub const MAX_PIXELS: u64 = 1 << 28;

/// Spots are computed within this many standard deviations of their path.
const SPOT_REACH_SIGMAS: f64 = 5.0;

/// A moving spot is integrated at sub-positions this far apart along its path (px, times its
/// deviation when that is above 1 px), each over its own reach.
const MOTION_STEP_PX: f64 = 0.2;

/// The image sensor and its exposure.
#[derive(Debug, Clone, PartialEq)]
pub struct Sensor {
    /// Frame width (pixels).
    pub width: u32,
    /// Frame height (pixels).
    pub height: u32,
    /// Conversion gain (digital numbers per electron), > 0.
    pub gain_dn_per_e: f64,
    /// Black level (digital numbers), >= 0.
    pub offset_dn: f64,
    /// Read noise, standard deviation (electrons), >= 0.
    pub read_noise_e: f64,
    /// Stray light and dark current: mean electrons per pixel over the exposure, >= 0.
    pub stray_e: f64,
    /// Full-well capacity (electrons), > 0: a pixel's charge saturates there.
    pub full_well_e: f64,
}

impl Sensor {
    /// The plant's cameras at their resolution (1024 x 768 by default): an 8-bit machine
    /// vision sensor in a darkened room, 20 electrons per digital number, a black level of
    /// 10, 5 electrons of read noise, 50 electrons of stray light, 12,000 electrons of full
    /// well. Its background noise is 0.52 DN (with the ADC's rounding).
    pub fn machine_vision(width: u32, height: u32) -> Sensor {
        Sensor {
            width,
            height,
            gain_dn_per_e: 0.05,
            offset_dn: 10.0,
            read_noise_e: 5.0,
            stray_e: 50.0,
            full_well_e: 12_000.0,
        }
    }

    /// Checks every field.
    pub fn validate(&self) -> Result<(), VisionError> {
        if self.width == 0 || self.height == 0 {
            return Err(VisionError::EmptyFrame {
                width: self.width,
                height: self.height,
            });
        }
        let pixels = self.width as u64 * self.height as u64;
        check("sensor pixels", pixels as f64, "at most 2^28", |v| {
            v <= MAX_PIXELS as f64
        })?;
        check("gain_dn_per_e", self.gain_dn_per_e, "> 0", |v| v > 0.0)?;
        check("offset_dn", self.offset_dn, ">= 0", |v| v >= 0.0)?;
        check("read_noise_e", self.read_noise_e, ">= 0", |v| v >= 0.0)?;
        check("stray_e", self.stray_e, ">= 0 and <= 1e7", |v| {
            (0.0..=1e7).contains(&v)
        })?;
        check("full_well_e", self.full_well_e, "> 0 and <= 1e9", |v| {
            v > 0.0 && v <= 1e9
        })?;
        Ok(())
    }

    /// The mean digital number of a pixel holding `electrons` (no noise, no clamp).
    pub fn mean_dn(&self, electrons: f64) -> f64 {
        self.offset_dn + self.gain_dn_per_e * electrons
    }
}

/// A light on the image: a Gaussian spot, possibly moving during the exposure.
#[derive(Debug, Clone, PartialEq)]
pub struct Emitter {
    /// The spot's centre at mid-exposure (pixels, image coordinates).
    pub centre: [f64; 2],
    /// The spot's standard deviation (pixels), in [0.1, 100].
    pub sigma_px: f64,
    /// Photo-electrons the spot delivers over the exposure (all pixels together), >= 0.
    pub electrons: f64,
    /// Displacement during the exposure (pixels): the spot moves uniformly from
    /// `centre - motion / 2` to `centre + motion / 2`.
    pub motion_px: [f64; 2],
    /// Distance from the camera (any unit shared with the occluders): an occluder hides the
    /// spot only when it is nearer. `f64::INFINITY` (the default) puts the light behind
    /// every occluder.
    pub depth: f64,
}

impl Emitter {
    /// A still spot behind every occluder.
    pub fn new(centre: [f64; 2], sigma_px: f64, electrons: f64) -> Emitter {
        Emitter {
            centre,
            sigma_px,
            electrons,
            motion_px: [0.0, 0.0],
            depth: f64::INFINITY,
        }
    }

    /// The spot with its electrons chosen so that its brightest pixel (spot centred on a
    /// pixel, still) collects `peak_e` electrons.
    pub fn with_peak(centre: [f64; 2], sigma_px: f64, peak_e: f64) -> Emitter {
        let f = normal_cdf(0.5 / sigma_px) - normal_cdf(-0.5 / sigma_px);
        Emitter::new(centre, sigma_px, peak_e / (f * f))
    }

    fn validate(&self) -> Result<(), VisionError> {
        check("emitter centre x", self.centre[0], "finite", |_| true)?;
        check("emitter centre y", self.centre[1], "finite", |_| true)?;
        check("emitter sigma_px", self.sigma_px, "in [0.1, 100]", |v| {
            (0.1..=100.0).contains(&v)
        })?;
        check(
            "emitter electrons",
            self.electrons,
            ">= 0 and <= 1e12",
            |v| (0.0..=1e12).contains(&v),
        )?;
        check("emitter motion x", self.motion_px[0], "within +-1e3", |v| {
            v.abs() <= 1e3
        })?;
        check("emitter motion y", self.motion_px[1], "within +-1e3", |v| {
            v.abs() <= 1e3
        })?;
        if self.depth.is_nan() {
            return Err(VisionError::Parameter {
                name: "emitter depth",
                value: self.depth,
                rule: "a number (infinity allowed)",
            });
        }
        Ok(())
    }

    /// The pixel rectangle `[x0, x1) x [y0, y1)` the spot reaches, clipped to the frame.
    fn reach(&self, width: u32, height: u32) -> Option<Rect> {
        let r = SPOT_REACH_SIGMAS * self.sigma_px + 1.0;
        let (mx, my) = (self.motion_px[0].abs() / 2.0, self.motion_px[1].abs() / 2.0);
        Rect::clipped(
            [self.centre[0] - mx - r, self.centre[1] - my - r],
            [self.centre[0] + mx + r, self.centre[1] + my + r],
            width,
            height,
        )
    }
}

/// An image-space shape.
#[derive(Debug, Clone, PartialEq)]
pub enum Shape {
    /// The points within `radius` of the segment from `a` to `b` (a link seen from the
    /// side).
    Capsule {
        /// One end of the axis (pixels).
        a: [f64; 2],
        /// The other end (pixels).
        b: [f64; 2],
        /// Half the width (pixels), >= 0.
        radius: f64,
    },
    /// A simple polygon's inside (even-odd rule), at least 3 vertices (pixels).
    Polygon(Vec<[f64; 2]>),
}

impl Shape {
    fn validate(&self) -> Result<(), VisionError> {
        let finite = |p: &[f64; 2]| {
            check("occluder vertex", p[0], "finite", |_| true)?;
            check("occluder vertex", p[1], "finite", |_| true).map(|_| ())
        };
        match self {
            Shape::Capsule { a, b, radius } => {
                finite(a)?;
                finite(b)?;
                check("capsule radius", *radius, ">= 0", |v| v >= 0.0)?;
            }
            Shape::Polygon(v) => {
                check("polygon vertices", v.len() as f64, ">= 3", |n| n >= 3.0)?;
                v.iter().try_for_each(finite)?;
            }
        }
        Ok(())
    }

    /// The shape's bounding box `(min, max)`.
    fn bounds(&self) -> ([f64; 2], [f64; 2]) {
        match self {
            Shape::Capsule { a, b, radius } => (
                [a[0].min(b[0]) - radius, a[1].min(b[1]) - radius],
                [a[0].max(b[0]) + radius, a[1].max(b[1]) + radius],
            ),
            Shape::Polygon(v) => v.iter().fold(
                ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]),
                |(lo, hi), p| {
                    (
                        [lo[0].min(p[0]), lo[1].min(p[1])],
                        [hi[0].max(p[0]), hi[1].max(p[1])],
                    )
                },
            ),
        }
    }

    /// Whether the point `p` lies inside.
    pub fn contains(&self, p: [f64; 2]) -> bool {
        match self {
            Shape::Capsule { a, b, radius } => {
                let (dx, dy) = (b[0] - a[0], b[1] - a[1]);
                let len2 = dx * dx + dy * dy;
                let t = if len2 > 0.0 {
                    (((p[0] - a[0]) * dx + (p[1] - a[1]) * dy) / len2).clamp(0.0, 1.0)
                } else {
                    0.0
                };
                let (ex, ey) = (p[0] - a[0] - t * dx, p[1] - a[1] - t * dy);
                ex * ex + ey * ey <= radius * radius
            }
            Shape::Polygon(v) => {
                let mut inside = false;
                let mut j = v.len() - 1;
                for i in 0..v.len() {
                    let (pi, pj) = (v[i], v[j]);
                    if (pi[1] > p[1]) != (pj[1] > p[1])
                        && p[0] < (pj[0] - pi[0]) * (p[1] - pi[1]) / (pj[1] - pi[1]) + pi[0]
                    {
                        inside = !inside;
                    }
                    j = i;
                }
                inside
            }
        }
    }
}

/// Something opaque between the camera and some lights: it hides the part of each spot
/// behind it (pixels sampled at 2 x 2 points) but not the stray light.
#[derive(Debug, Clone, PartialEq)]
pub struct Occluder {
    /// Its outline on the image.
    pub shape: Shape,
    /// Its distance from the camera: it hides emitters whose depth is larger.
    pub depth: f64,
}

impl Occluder {
    /// An occluder in front of every light.
    pub fn in_front(shape: Shape) -> Occluder {
        Occluder { shape, depth: 0.0 }
    }
}

/// What one exposure sees.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Scene {
    /// The lights on the image.
    pub emitters: Vec<Emitter>,
    /// What hides them.
    pub occluders: Vec<Occluder>,
}

/// A pixel rectangle `[x0, x1) x [y0, y1)`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Rect {
    x0: u32,
    y0: u32,
    x1: u32,
    y1: u32,
}

impl Rect {
    fn clipped(lo: [f64; 2], hi: [f64; 2], width: u32, height: u32) -> Option<Rect> {
        let x0 = lo[0].floor().max(0.0);
        let y0 = lo[1].floor().max(0.0);
        let x1 = hi[0].ceil().min(width as f64);
        let y1 = hi[1].ceil().min(height as f64);
        (x0 < x1 && y0 < y1).then_some(Rect {
            x0: x0 as u32,
            y0: y0 as u32,
            x1: x1 as u32,
            y1: y1 as u32,
        })
    }

    fn overlaps(&self, o: &Rect) -> bool {
        self.x0 < o.x1 && o.x0 < self.x1 && self.y0 < o.y1 && o.y0 < self.y1
    }

    fn union(&self, o: &Rect) -> Rect {
        Rect {
            x0: self.x0.min(o.x0),
            y0: self.y0.min(o.y0),
            x1: self.x1.max(o.x1),
            y1: self.y1.max(o.y1),
        }
    }

    fn width(&self) -> usize {
        (self.x1 - self.x0) as usize
    }
}

/// Merges overlapping rectangles until none overlap.
fn merge(mut rects: Vec<Rect>) -> Vec<Rect> {
    let mut merged = true;
    while merged {
        merged = false;
        'outer: for i in 0..rects.len() {
            for j in i + 1..rects.len() {
                if rects[i].overlaps(&rects[j]) {
                    let r = rects.swap_remove(j);
                    rects[i] = rects[i].union(&r);
                    merged = true;
                    break 'outer;
                }
            }
        }
    }
    rects
}

/// Renders frames of samples `P` for one sensor.
#[derive(Debug, Clone)]
pub struct Renderer<P: Sample> {
    sensor: Sensor,
    /// The background pixel's distribution function over digital numbers `lo..`:
    /// `cdf[i] = P(dn <= lo + i)`, the last entry 1.
    cdf: Vec<f64>,
    /// `cdf` in units of 2^-32, rounded (the last entry 2^32, above every 32-bit draw).
    cut: Vec<u64>,
    /// The sample of each entry.
    value: Vec<P>,
    lo: u32,
    /// `guide[g]` = the first index whose `cdf` exceeds `g / GUIDE`.
    guide: Vec<u32>,
    sample: PhantomData<P>,
}

const GUIDE: usize = 4096;

impl<P: Sample> Renderer<P> {
    /// A renderer for `sensor` (checked), its background distribution tabulated.
    pub fn new(sensor: &Sensor) -> Result<Renderer<P>, VisionError> {
        sensor.validate()?;
        let (cdf, lo) = background_cdf(sensor, P::MAX_DN);
        let scale = 4_294_967_296.0;
        let cut: Vec<u64> = cdf.iter().map(|c| (c * scale).round() as u64).collect();
        let mut guide = Vec::with_capacity(GUIDE);
        let mut i = 0;
        for g in 0..GUIDE as u64 {
            while cut[i] <= g << 20 {
                i += 1;
            }
            guide.push(i as u32);
        }
        Ok(Renderer {
            sensor: sensor.clone(),
            value: (0..cdf.len() as u32).map(|i| P::from_dn(lo + i)).collect(),
            cdf,
            cut,
            lo,
            guide,
            sample: PhantomData,
        })
    }

    /// The same sensor cut to a `width` x `height` window (a region of interest), its
    /// background's table kept.
    pub fn with_size(&self, width: u32, height: u32) -> Result<Renderer<P>, VisionError> {
        let sensor = Sensor {
            width,
            height,
            ..self.sensor.clone()
        };
        sensor.validate()?;
        Ok(Renderer {
            sensor,
            ..self.clone()
        })
    }

    /// The sensor.
    pub fn sensor(&self) -> &Sensor {
        &self.sensor
    }

    /// The distribution of a background pixel's digital number: `(dn, probability)` for
    /// each number it takes with a probability above about 1e-18, in increasing order.
    pub fn background_distribution(&self) -> Vec<(u32, f64)> {
        let mut below = 0.0;
        (self.lo..)
            .zip(&self.cdf)
            .map(|(dn, c)| {
                let p = c - below;
                below = *c;
                (dn, p)
            })
            .collect()
    }

    /// The frame of `scene` with the noise of seed `seed`.
    pub fn render(&self, scene: &Scene, seed: u64) -> Result<Frame<P>, VisionError> {
        let mut frame = Frame::new(self.sensor.width, self.sensor.height);
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
        self.render_into(scene, &mut rng, &mut frame)?;
        Ok(frame)
    }

    /// Renders `scene` into `frame` (which must have the sensor's size), drawing the noise
    /// from `rng`; no allocation for the background.
    pub fn render_into(
        &self,
        scene: &Scene,
        rng: &mut impl RngCore,
        frame: &mut Frame<P>,
    ) -> Result<(), VisionError> {
        let (w, h) = (self.sensor.width, self.sensor.height);
        if frame.dimensions() != (w, h) {
            return Err(VisionError::WrongSize {
                width: w,
                height: h,
                got_width: frame.width(),
                got_height: frame.height(),
                got_len: frame.as_raw().len(),
            });
        }
        scene.emitters.iter().try_for_each(Emitter::validate)?;
        for o in &scene.occluders {
            o.shape.validate()?;
            if o.depth.is_nan() {
                return Err(VisionError::Parameter {
                    name: "occluder depth",
                    value: o.depth,
                    rule: "a number (infinity allowed)",
                });
            }
        }
        self.fill_background(rng, frame);
        let rects = merge(
            scene
                .emitters
                .iter()
                .filter_map(|e| e.reach(w, h))
                .collect(),
        );
        let mut light = Vec::new();
        for r in rects {
            light.clear();
            light.resize(r.width() * (r.y1 - r.y0) as usize, 0.0);
            for e in &scene.emitters {
                if e.reach(w, h).is_some_and(|er| er.overlaps(&r)) {
                    add_spot(e, &scene.occluders, &r, &mut light);
                }
            }
            self.expose(&r, &light, rng, frame);
        }
        Ok(())
    }

    /// Every pixel a draw of the background's digital number.
    fn fill_background(&self, rng: &mut impl RngCore, frame: &mut Frame<P>) {
        // a draw u of 32 bits falls on the first entry whose cut exceeds it
        let draw = |u: u32| -> P {
            let mut i = self.guide[(u >> 20) as usize] as usize;
            while self.cut[i] <= u as u64 {
                i += 1;
            }
            self.value[i]
        };
        let mut pairs = frame.as_mut().chunks_exact_mut(2);
        for pair in &mut pairs {
            let r = rng.next_u64();
            pair[0] = draw(r as u32);
            pair[1] = draw((r >> 32) as u32);
        }
        for p in pairs.into_remainder() {
            *p = draw(rng.next_u64() as u32);
        }
    }

    /// Draws the pixels of `r` whose mean spot electrons are `light`.
    fn expose(&self, r: &Rect, light: &[f64], rng: &mut impl RngCore, frame: &mut Frame<P>) {
        let s = &self.sensor;
        let max = P::MAX_DN as f64;
        for (j, row) in light.chunks_exact(r.width()).enumerate() {
            for (i, mu) in row.iter().enumerate() {
                let k = poisson(rng, s.stray_e + mu).min(s.full_well_e);
                let e = k + s.read_noise_e * gaussian(rng);
                let dn = s.mean_dn(e).round().clamp(0.0, max);
                frame.put_pixel(
                    r.x0 + i as u32,
                    r.y0 + j as u32,
                    image::Luma([P::from_dn(dn as u32)]),
                );
            }
        }
    }
}

/// Adds the mean electrons of spot `e` to `light` over `r`, less what nearer occluders hide.
fn add_spot(e: &Emitter, occluders: &[Occluder], r: &Rect, light: &mut [f64]) {
    let (nx, ny) = (r.width(), (r.y1 - r.y0) as usize);
    let step = MOTION_STEP_PX * e.sigma_px.max(1.0);
    let steps = ((e.motion_px[0].hypot(e.motion_px[1]) / step).ceil() as usize).max(1);
    let per_step = e.electrons / steps as f64;
    let reach = SPOT_REACH_SIGMAS * e.sigma_px + 1.0;
    let mut ax = Vec::new();
    let mut ay = Vec::new();
    let mut spot = vec![0.0; nx * ny];
    for k in 0..steps {
        let t = (k as f64 + 0.5) / steps as f64 - 0.5;
        let c = [
            e.centre[0] + t * e.motion_px[0],
            e.centre[1] + t * e.motion_px[1],
        ];
        // this position's reach within the patch
        let Some(sub) = Rect::clipped(
            [c[0] - reach, c[1] - reach],
            [c[0] + reach, c[1] + reach],
            r.x1,
            r.y1,
        )
        .filter(|q| q.x1 > r.x0 && q.y1 > r.y0) else {
            continue;
        };
        let (x0, y0) = (sub.x0.max(r.x0), sub.y0.max(r.y0));
        ax.resize((sub.x1 - x0) as usize, 0.0);
        ay.resize((sub.y1 - y0) as usize, 0.0);
        integrate(&mut ax, x0, c[0], e.sigma_px);
        integrate(&mut ay, y0, c[1], e.sigma_px);
        let (dx, dy) = ((x0 - r.x0) as usize, (y0 - r.y0) as usize);
        for (j, y) in ay.iter().enumerate() {
            let row = &mut spot[(dy + j) * nx + dx..][..ax.len()];
            for (p, x) in row.iter_mut().zip(&ax) {
                *p += per_step * x * y;
            }
        }
    }
    let hiding: Vec<&Occluder> = occluders
        .iter()
        .filter(|o| o.depth < e.depth)
        .filter(|o| {
            let (lo, hi) = o.shape.bounds();
            lo[0] < r.x1 as f64 && hi[0] > r.x0 as f64 && lo[1] < r.y1 as f64 && hi[1] > r.y0 as f64
        })
        .collect();
    for (j, row) in spot.chunks_exact(nx).enumerate() {
        for (i, p) in row.iter().enumerate() {
            let mut seen = 1.0;
            if !hiding.is_empty() {
                let (x, y) = ((r.x0 as usize + i) as f64, (r.y0 as usize + j) as f64);
                let hidden = [[0.25, 0.25], [0.75, 0.25], [0.25, 0.75], [0.75, 0.75]]
                    .iter()
                    .filter(|d| {
                        hiding
                            .iter()
                            .any(|o| o.shape.contains([x + d[0], y + d[1]]))
                    })
                    .count();
                seen = 1.0 - hidden as f64 / 4.0;
            }
            light[j * nx + i] += seen * p;
        }
    }
}

/// `a[i]` = the mass of a unit Gaussian of centre `c`, deviation `s` over `[x0 + i, x0 + i + 1)`.
fn integrate(a: &mut [f64], x0: u32, c: f64, s: f64) {
    let mut below = normal_cdf((x0 as f64 - c) / s);
    for (i, v) in a.iter_mut().enumerate() {
        let above = normal_cdf((x0 as f64 + i as f64 + 1.0 - c) / s);
        *v = above - below;
        below = above;
    }
}

/// The distribution function of a background pixel's digital number over `lo..=hi`, and
/// `lo`: Poisson stray electrons (clipped at the full well), Gaussian read noise, gain,
/// offset, rounding, clamping to `0..=max_dn`.
fn background_cdf(s: &Sensor, max_dn: u32) -> (Vec<f64>, u32) {
    let lambda = s.stray_e;
    let spread = 12.0 * lambda.sqrt() + 12.0;
    let k_lo = (lambda - spread).floor().max(0.0) as u64;
    let k_hi = (lambda + spread).ceil() as u64;
    let pmf: Vec<(f64, f64)> = (k_lo..=k_hi)
        .map(|k| {
            let k = k as f64;
            let p = if lambda > 0.0 {
                (k * lambda.ln() - lambda - ln_gamma(k + 1.0)).exp()
            } else if k == 0.0 {
                1.0
            } else {
                0.0
            };
            (k.min(s.full_well_e), p)
        })
        .filter(|(_, p)| *p > 0.0)
        .collect();
    let total: f64 = pmf.iter().map(|(_, p)| p).sum();
    let reach = 12.0 * s.read_noise_e;
    let e_lo = pmf.first().map_or(0.0, |(k, _)| *k) - reach;
    let e_hi = pmf.last().map_or(0.0, |(k, _)| *k) + reach;
    let lo = s.mean_dn(e_lo).floor().clamp(0.0, max_dn as f64) as u32;
    let hi = s.mean_dn(e_hi).ceil().clamp(0.0, max_dn as f64) as u32;
    let mut cdf: Vec<f64> = (lo..=hi)
        .map(|d| {
            if d >= max_dn {
                return 1.0;
            }
            // dn <= d  <=>  offset + g e < d + 0.5  (round half up)
            let e_max = (d as f64 + 0.5 - s.offset_dn) / s.gain_dn_per_e;
            pmf.iter()
                .map(|(k, p)| {
                    let below = if s.read_noise_e > 0.0 {
                        normal_cdf((e_max - k) / s.read_noise_e)
                    } else if *k < e_max {
                        1.0
                    } else {
                        0.0
                    };
                    p * below
                })
                .sum::<f64>()
                / total
        })
        .collect();
    if let Some(last) = cdf.last_mut() {
        *last = 1.0;
    }
    (cdf, lo)
}

#[cfg(test)]
mod tests;
