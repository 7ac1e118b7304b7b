//! The cameras' frames rendered from the geometry and read by the camera processor on
//! pixels ([`trn_vision`]): an option beside the geometric camera model (projection plus
//! noise of a chosen size), which stays what every run uses.
//!
//! Each light is a Gaussian spot at its projection, its electrons falling with the square of
//! its distance from the camera. The upper arm, the forearm and, on a plant that has them
//! (`occlude_hand_and_cylinder`), the hand and the cylinder are capsules on the image: each
//! link cut into pieces between points along its axis that project into the image, each
//! piece as wide as the link looks at its ends, and hiding a light when its front surface is
//! nearer the camera than the light. A cylinder that holds a light (the light within its
//! radius of the axis) hides none. The lights are still during an exposure.
//!
//! A reading takes a capture ([`trn_vision::CaptureProtocol`]): one frame per light, or
//! groups of lights per frame; the detector finds the blobs of each frame, the identifier
//! tells the lights apart. A light found is `Valid`; a light missing or ambiguous is
//! `NotDetected` (the camera processor cannot tell why), and one outside the image
//! `OutOfView`.

use trn_vision::detect::BackgroundLevel;
use trn_vision::{
    Blob, CaptureProtocol, Detection, Detector, DetectorParams, Emitter, Identifier, LightStatus,
    Occluder, Renderer, Scene, Sensor, Shape, VisionError,
};

use super::camera::Camera;
use super::config::PixelsConfig;
use super::geometry::{segment_distance, unit};
use super::{Chain, PixelReading, Plant, PointStatus, Vector3};

/// How the lights look and how the camera processor reads them.
#[derive(Debug, Clone, PartialEq)]
pub struct PixelVision {
    /// The lens's blur, a Gaussian's standard deviation (pixels).
    pub blur_px: f64,
    /// Diameter of an LED's emitting disc (mm): a disc of `diameter x focal / distance`
    /// pixels on the image, of standard deviation a quarter of that, blurred by `blur_px`.
    pub led_diameter_mm: f64,
    /// Electrons a light delivers over an exposure at `reference_mm` from the camera.
    pub electrons_at_reference: f64,
    /// The distance of `electrons_at_reference` (mm).
    pub reference_mm: f64,
    /// The sensor (its resolution is each camera's).
    pub sensor: Sensor,
    /// The detector's parameters.
    pub detector: DetectorParams,
    /// The identifier's gate (pixels).
    pub gate_px: f64,
}

impl Default for PixelVision {
    /// [`PixelsConfig::default`]: the nominal LED of `trn_vision::accuracy::Blob::nominal`
    /// at 2 m (a spot of 1.3 px, 30,000 electrons), the 8-bit sensor of
    /// `Sensor::machine_vision`, the detector's defaults, a 3 px gate.
    fn default() -> PixelVision {
        PixelVision::from_config(&PixelsConfig::default())
    }
}

impl PixelVision {
    /// The frames a configuration's `[pixels]` describes (the exposure scales the LEDs' and
    /// the stray light's electrons).
    pub fn from_config(c: &PixelsConfig) -> PixelVision {
        let mut sensor = Sensor::machine_vision(1, 1);
        sensor.read_noise_e = c.read_noise_e;
        sensor.stray_e = c.stray_electrons_per_ms * c.exposure_ms;
        PixelVision {
            blur_px: c.blur_px,
            led_diameter_mm: c.led_diameter_mm,
            electrons_at_reference: c.led_electrons_per_ms * c.exposure_ms,
            reference_mm: 2_000.0,
            sensor,
            detector: DetectorParams::default(),
            gate_px: c.gate_px,
        }
    }

    /// A light's spot at `distance_mm` through a lens of `focal_px`: standard deviation
    /// (pixels, at least 0.1) and electrons.
    pub fn spot(&self, focal_px: f64, distance_mm: f64) -> (f64, f64) {
        let disc = 0.25 * self.led_diameter_mm * focal_px / distance_mm;
        (
            self.blur_px.hypot(disc).max(0.1),
            self.electrons_at_reference * (self.reference_mm / distance_mm).powi(2),
        )
    }
}

/// Points along a link's axis for its pieces on the image.
const LINK_POINTS: usize = 16;

/// What a capture shows beyond still lights: how each light moves during an exposure, which
/// ones stay dark, and reflections of lit ones.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct CaptureExtras {
    /// Each light's displacement during an exposure (mm; empty: all still), the exposure
    /// centred on the moment of the reading.
    pub motion_mm: Vec<Vector3<f64>>,
    /// Lights that do not fire in this capture (a dropout).
    pub dark: Vec<usize>,
    /// Reflections: `(light, [x, y])`, a spot as bright as the light at a point of the
    /// image (pixels), lit in the frames its light is lit in.
    pub reflections: Vec<(usize, [f64; 2])>,
}

impl Plant {
    /// What camera `cam` sees of `lights` (mm) with the arm as it is: one emitter per light
    /// (`None` out of view) and the occluders.
    pub fn pixel_scene(
        &self,
        cam: usize,
        lights: &[Vector3<f64>],
        v: &PixelVision,
    ) -> (Vec<Option<Emitter>>, Vec<Occluder>) {
        self.pixel_scene_moving(cam, lights, &[], v)
    }

    /// [`Plant::pixel_scene`] with each light moving by `motion_mm` (mm, empty: still)
    /// during the exposure.
    fn pixel_scene_moving(
        &self,
        cam: usize,
        lights: &[Vector3<f64>],
        motion_mm: &[Vector3<f64>],
        v: &PixelVision,
    ) -> (Vec<Option<Emitter>>, Vec<Occluder>) {
        let camera = &self.cameras[cam];
        let eye = camera.position();
        let emitters = lights
            .iter()
            .enumerate()
            .map(|(i, p)| {
                let (u, w) = camera.project(p)?;
                let d = (p - eye).norm();
                let (sigma, electrons) = v.spot(camera.focal_px(), d);
                let mut e = Emitter::new([u, w], sigma, electrons);
                if let Some(m) = motion_mm.get(i) {
                    let half = m * 0.5;
                    if let (Some(a), Some(b)) =
                        (camera.project(&(p - half)), camera.project(&(p + half)))
                    {
                        e.motion_px = [b.0 - a.0, b.1 - a.1];
                    }
                }
                e.depth = d;
                Some(e)
            })
            .collect();
        let chain = self.chain();
        let mut occluders = Vec::new();
        // as the geometric model (`Plant::hidden_by`) does, a light is not hidden by what
        // lies within two link radii of it along the ray: a piece whose surface comes that
        // near a light of the capture is left out (the hand's end, by the centre light)
        let clear = 2.0 * self.cfg.link_radius_mm;
        for (a, b, r) in self.links(&chain, lights) {
            link_pieces(camera, (&a, &b, r), (lights, clear - r), &mut occluders);
        }
        (emitters, occluders)
    }

    /// The links, hand and cylinder as capsules `(a, b, radius)` (mm).
    fn links(
        &self,
        chain: &Chain,
        lights: &[Vector3<f64>],
    ) -> Vec<(Vector3<f64>, Vector3<f64>, f64)> {
        let r = self.cfg.link_radius_mm;
        let mut links = vec![
            (chain.shoulder, chain.elbow, r),
            (chain.elbow, chain.wrist, r),
        ];
        if self.cfg.realism.occlude_hand_and_cylinder {
            let c = &chain.pose;
            links.push((chain.wrist, c.centre_mm - c.approach * r, 0.8 * r));
            if let Some(cyl) = &self.cylinder {
                let half = cyl.axis * (0.5 * cyl.length);
                let (a, b) = (cyl.centre - half, cyl.centre + half);
                if lights
                    .iter()
                    .all(|p| segment_distance(p, &a, &b) > cyl.radius + 1.0)
                {
                    links.push((a, b, cyl.radius));
                }
            }
        }
        links
    }

    /// `lights` (mm) read by camera `cam` through a capture of `protocol` (as many lights):
    /// each frame rendered with the noise of `seed` and the frame's index, detected, the
    /// lights identified.
    pub fn read_by_pixels(
        &self,
        cam: usize,
        lights: &[Vector3<f64>],
        protocol: &CaptureProtocol,
        v: &PixelVision,
        seed: u64,
    ) -> Result<Vec<PixelReading>, VisionError> {
        self.read_capture(cam, lights, &CaptureExtras::default(), protocol, v, seed)
    }

    /// [`Plant::read_by_pixels`] with lights that move, stay dark or are reflected
    /// (`extras`). A light found is `Valid`; one missing or ambiguous (hidden, dark, merged
    /// with another or with a reflection, a reflection of it elsewhere) `NotDetected`; one
    /// outside the image `OutOfView`.
    pub fn read_capture(
        &self,
        cam: usize,
        lights: &[Vector3<f64>],
        extras: &CaptureExtras,
        protocol: &CaptureProtocol,
        v: &PixelVision,
        seed: u64,
    ) -> Result<Vec<PixelReading>, VisionError> {
        let [w, h] = self.cameras[cam].size;
        let renderer = self.camera_renderer(cam, v)?;
        let identifier = Identifier::new(protocol.clone(), v.gate_px)?;
        let (emitters, occluders) = self.pixel_scene_moving(cam, lights, &extras.motion_mm, v);
        let spots = spots(&emitters, &extras.dark);
        let mut scenes = protocol.scenes(&spots, &occluders)?;
        let mut reflections = vec![];
        for &(light, at) in &extras.reflections {
            let Some(Some(e)) = emitters.get(light) else {
                continue;
            };
            let mut r = Emitter::new(at, e.sigma_px, e.electrons);
            r.depth = 0.0;
            for f in (0..scenes.len()).filter(|f| protocol.code(light) & (1 << f) != 0) {
                scenes[f].emitters.push(r.clone());
            }
            reflections.push(r);
        }
        // the frames are read in windows around every place a light of the capture can be
        // (the rest of a frame is background, on which the detector finds nothing but at
        // a rate of about 1e-7 per pixel): the same windows in every frame
        let all: Vec<&Emitter> = emitters.iter().flatten().chain(&reflections).collect();
        let windows = windows(&all, w, h);
        // the background as the sensor's calibration gives it
        let (level_dn, noise_dn) = moments(&renderer.background_distribution());
        let params = DetectorParams {
            background: BackgroundLevel::Known { level_dn, noise_dn },
            ..v.detector.clone()
        };
        let mut detections = Vec::with_capacity(protocol.frames());
        for (f, scene) in scenes.iter().enumerate() {
            let mut frame_detection: Option<Detection> = None;
            for (k, win) in windows.iter().enumerate() {
                let [x0, y0, x1, y1] = *win;
                let (ww, wh) = (x1 - x0, y1 - y0);
                let shift = [-(x0 as f64), -(y0 as f64)];
                let cut = Scene {
                    emitters: scene
                        .emitters
                        .iter()
                        .map(|e| Emitter {
                            centre: [e.centre[0] + shift[0], e.centre[1] + shift[1]],
                            ..e.clone()
                        })
                        .collect(),
                    occluders: scene
                        .occluders
                        .iter()
                        .map(|o| Occluder {
                            shape: moved(&o.shape, shift),
                            depth: o.depth,
                        })
                        .collect(),
                };
                let frame_seed = seed
                    .wrapping_mul(64)
                    .wrapping_add(f as u64)
                    .wrapping_mul(1024)
                    .wrapping_add(k as u64);
                let frame = renderer.with_size(ww, wh)?.render(&cut, frame_seed)?;
                let mut d = Detector::new(ww, wh, params.clone())?.detect(&frame)?;
                let back = |b: &mut Blob| {
                    b.centre = [b.centre[0] + x0 as f64, b.centre[1] + y0 as f64];
                    b.bounds = [
                        b.bounds[0] + x0,
                        b.bounds[1] + y0,
                        b.bounds[2] + x0,
                        b.bounds[3] + y0,
                    ];
                };
                d.blobs.iter_mut().for_each(back);
                d.rejected.iter_mut().for_each(|(b, _)| back(b));
                match &mut frame_detection {
                    None => frame_detection = Some(d),
                    Some(all) => {
                        all.blobs.extend(d.blobs);
                        all.rejected.extend(d.rejected);
                    }
                }
            }
            detections.push(frame_detection.unwrap_or(Detection {
                blobs: vec![],
                rejected: vec![],
                background_dn: level_dn,
                noise_dn,
                threshold_dn: f64::NAN,
            }));
        }
        let found = identifier.identify(&detections)?;
        Ok(found
            .iter()
            .zip(&emitters)
            .map(|(id, e)| {
                let status = match (e, id.status) {
                    (None, _) => PointStatus::OutOfView,
                    (Some(_), LightStatus::Valid) => PointStatus::Valid,
                    (Some(_), _) => PointStatus::NotDetected,
                };
                let [x, y] = id
                    .centre
                    .filter(|_| status == PointStatus::Valid)
                    .unwrap_or([f64::NAN; 2]);
                PixelReading { x, y, status }
            })
            .collect())
    }
}

impl Plant {
    /// The whole frames camera `cam` takes of `lights` (mm) in a capture of `protocol` (as
    /// many lights), the arm as it is and the lights still: every pixel rendered (not only
    /// the lights' windows, as a reading renders them), frame `f` with the noise of
    /// `seed`'s `f`-th draw. What a camera's own capture tool would store, and what a
    /// learner on pixels is shown; a light outside the image lights no pixel.
    pub fn capture_frames(
        &self,
        cam: usize,
        lights: &[Vector3<f64>],
        protocol: &CaptureProtocol,
        v: &PixelVision,
        seed: u64,
    ) -> Result<Vec<trn_vision::Frame<u8>>, VisionError> {
        let renderer = self.camera_renderer(cam, v)?;
        let (emitters, occluders) = self.pixel_scene(cam, lights, v);
        protocol
            .scenes(&spots(&emitters, &[]), &occluders)?
            .iter()
            .enumerate()
            .map(|(f, scene)| {
                renderer.render(scene, seed.wrapping_mul(0x9E37_79B9_7F4A_7C15) ^ f as u64)
            })
            .collect()
    }
}

impl Plant {
    /// A renderer for camera `cam`'s frames (`v`'s sensor at the camera's resolution).
    fn camera_renderer(&self, cam: usize, v: &PixelVision) -> Result<Renderer<u8>, VisionError> {
        let [w, h] = self.cameras[cam].size;
        renderer(&Sensor {
            width: w,
            height: h,
            ..v.sensor.clone()
        })
    }
}

/// The spots of a capture's lights: each light's emitter, and for a light out of view
/// (`None`) or one of `dark` an emitter with no light, off the image.
fn spots(emitters: &[Option<Emitter>], dark: &[usize]) -> Vec<Emitter> {
    let none = Emitter::new([-1e4, -1e4], 1.0, 0.0);
    emitters
        .iter()
        .enumerate()
        .map(|(i, e)| match e {
            Some(e) if !dark.contains(&i) => e.clone(),
            _ => none.clone(),
        })
        .collect()
}

thread_local! {
    /// The renderers of the sensors last used on this thread: a renderer tabulates its
    /// background's distribution once, which costs more than reading a capture's windows.
    static RENDERERS: std::cell::RefCell<Vec<Renderer<u8>>> =
        const { std::cell::RefCell::new(Vec::new()) };
}

/// The most renderers [`RENDERERS`] keeps.
const RENDERERS_KEPT: usize = 8;

/// A renderer for `sensor`, from this thread's cache.
fn renderer(sensor: &Sensor) -> Result<Renderer<u8>, VisionError> {
    RENDERERS.with(|cache| {
        let mut cache = cache.borrow_mut();
        if let Some(r) = cache.iter().find(|r| r.sensor() == sensor) {
            return Ok(r.clone());
        }
        let r = Renderer::<u8>::new(sensor)?;
        if cache.len() >= RENDERERS_KEPT {
            cache.remove(0);
        }
        cache.push(r.clone());
        Ok(r)
    })
}

/// The windows `[x0, y0, x1, y1)` of a `w` x `h` frame that hold every spot of `spots`
/// with room around it (a spot's reach, its smear and a margin for the detector's window),
/// overlapping ones joined.
fn windows(spots: &[&Emitter], w: u32, h: u32) -> Vec<[u32; 4]> {
    let mut out: Vec<[u32; 4]> = spots
        .iter()
        .filter_map(|e| {
            let reach = 5.0 * e.sigma_px + 0.5 * e.motion_px[0].hypot(e.motion_px[1]) + 8.0;
            let [x, y] = e.centre;
            let lo = |c: f64, n: u32| (c - reach).floor().clamp(0.0, n as f64) as u32;
            let hi = |c: f64, n: u32| (c + reach).ceil().clamp(0.0, n as f64) as u32;
            let r = [lo(x, w), lo(y, h), hi(x, w), hi(y, h)];
            (r[2] > r[0] && r[3] > r[1]).then_some(r)
        })
        .collect();
    // join overlapping windows until none overlap
    let mut joined = true;
    while joined {
        joined = false;
        'outer: for i in 0..out.len() {
            for j in i + 1..out.len() {
                let (a, b) = (out[i], out[j]);
                if a[0] < b[2] && b[0] < a[2] && a[1] < b[3] && b[1] < a[3] {
                    out[i] = [
                        a[0].min(b[0]),
                        a[1].min(b[1]),
                        a[2].max(b[2]),
                        a[3].max(b[3]),
                    ];
                    out.swap_remove(j);
                    joined = true;
                    break 'outer;
                }
            }
        }
    }
    out
}

/// The mean and standard deviation of a distribution `(value, probability)`.
fn moments(dist: &[(u32, f64)]) -> (f64, f64) {
    let mean: f64 = dist.iter().map(|(v, p)| *v as f64 * p).sum();
    let var: f64 = dist
        .iter()
        .map(|(v, p)| (*v as f64 - mean).powi(2) * p)
        .sum();
    (mean, var.sqrt())
}

/// `shape` moved by `by` (pixels).
fn moved(shape: &Shape, by: [f64; 2]) -> Shape {
    let m = |p: &[f64; 2]| [p[0] + by[0], p[1] + by[1]];
    match shape {
        Shape::Capsule { a, b, radius } => Shape::Capsule {
            a: m(a),
            b: m(b),
            radius: *radius,
        },
        Shape::Polygon(v) => Shape::Polygon(v.iter().map(m).collect()),
    }
}

/// The capsule from `a` to `b` of radius `r` (mm) as image capsules, one per piece between
/// consecutive axis points that project into the image.
/// Pieces whose axis passes within `clear.1` (mm) of a light of `clear.0` are left out.
fn link_pieces(
    camera: &Camera,
    (a, b, r): (&Vector3<f64>, &Vector3<f64>, f64),
    clear: (&[Vector3<f64>], f64),
    out: &mut Vec<Occluder>,
) {
    let eye = camera.position();
    let axis = b - a;
    let at = |i: usize| a + axis * (i as f64 / LINK_POINTS as f64);
    let seen: Vec<Option<([f64; 2], f64, f64)>> = (0..=LINK_POINTS)
        .map(|i| {
            let p = at(i);
            let (u, v) = camera.project(&p)?;
            // the link's half-width on the image: a point r off the axis, across the view
            let view = p - eye;
            let mut across = view.cross(&axis);
            if across.norm() < 1e-9 {
                across = view.cross(&Vector3::new(0.0, 0.0, 1.0));
            }
            let side = p + unit(&across) * r;
            let (su, sv) = camera
                .project(&side)
                .or_else(|| camera.project(&(p - unit(&across) * r)))?;
            Some(([u, v], (su - u).hypot(sv - v), view.norm() - r))
        })
        .collect();
    for (i, pair) in seen.windows(2).enumerate() {
        let (p0, p1) = (at(i), at(i + 1));
        if clear
            .0
            .iter()
            .any(|l| segment_distance(l, &p0, &p1) < clear.1)
        {
            continue;
        }
        if let [Some((pa, ra, da)), Some((pb, rb, db))] = pair {
            out.push(Occluder {
                shape: Shape::Capsule {
                    a: *pa,
                    b: *pb,
                    radius: ra.max(*rb),
                },
                depth: da.min(*db),
            });
        }
    }
}

#[cfg(test)]
mod tests;
