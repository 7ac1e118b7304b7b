//! Both camera images as an RGB array: what each camera sees of the arm (its links
//! projected), the lights as read (filled discs; a light not read is not drawn) and the
//! target (rings). A small software rasteriser: the binding carries no plotting library.

use trn_plant::camera::Camera;
use trn_plant::{Chain, SimConfig};

/// What a picture shows.
pub struct Scene<'a> {
    /// The plant's configuration (cameras).
    pub cfg: &'a SimConfig,
    /// The arm now.
    pub chain: Chain,
    /// The lights as read: x, y of each light in camera 0 then camera 1 (pixels).
    pub lights: &'a [f64],
    /// Their status codes (0 valid).
    pub status: &'a [u8],
    /// The target, in the same order.
    pub target: &'a [f64],
}

const BACKGROUND: [u8; 3] = [236, 236, 232];
const ARM: [u8; 3] = [40, 40, 48];
const JOINT: [u8; 3] = [110, 110, 120];
const LIGHT: [u8; 3] = [214, 39, 40];
const TARGET: [u8; 3] = [44, 160, 44];
const SEPARATOR: [u8; 3] = [255, 255, 255];

/// One RGB image.
struct Image {
    w: usize,
    h: usize,
    px: Vec<u8>,
}

impl Image {
    fn new(w: usize, h: usize) -> Image {
        let mut px = Vec::with_capacity(w * h * 3);
        for _ in 0..w * h {
            px.extend(BACKGROUND);
        }
        Image { w, h, px }
    }

    fn put(&mut self, x: i64, y: i64, c: [u8; 3]) {
        if x >= 0 && y >= 0 && (x as usize) < self.w && (y as usize) < self.h {
            let i = 3 * (y as usize * self.w + x as usize);
            self.px[i..i + 3].copy_from_slice(&c);
        }
    }

    /// A disc of radius `r` (pixels), or a ring `width` wide when `ring`.
    fn disc(&mut self, cx: f64, cy: f64, r: f64, c: [u8; 3], ring: Option<f64>) {
        let (x0, x1) = ((cx - r).floor() as i64, (cx + r).ceil() as i64);
        let (y0, y1) = ((cy - r).floor() as i64, (cy + r).ceil() as i64);
        for y in y0..=y1 {
            for x in x0..=x1 {
                let d = ((x as f64 - cx).powi(2) + (y as f64 - cy).powi(2)).sqrt();
                let inside = d <= r && ring.is_none_or(|w| d >= r - w);
                if inside {
                    self.put(x, y, c);
                }
            }
        }
    }
}

/// Both cameras side by side at `1 / scale` of their resolution, a white bar between them:
/// (width, height, rgb bytes).
pub fn cameras(scene: &Scene, scale_down: u32) -> (u32, u32, Vec<u8>) {
    let s = scale_down as f64;
    let images: Vec<Image> = (0..2).map(|cam| camera(scene, cam, s)).collect();
    let gap = 4;
    let h = images.iter().map(|i| i.h).max().unwrap_or(0);
    let w = images.iter().map(|i| i.w).sum::<usize>() + gap;
    let mut out = Vec::with_capacity(w * h * 3);
    for y in 0..h {
        for (k, img) in images.iter().enumerate() {
            if k > 0 {
                for _ in 0..gap {
                    out.extend(SEPARATOR);
                }
            }
            if y < img.h {
                out.extend_from_slice(&img.px[3 * y * img.w..3 * (y + 1) * img.w]);
            } else {
                for _ in 0..img.w {
                    out.extend(SEPARATOR);
                }
            }
        }
    }
    (w as u32, h as u32, out)
}

/// Camera `cam`'s image at `1 / s` of its resolution.
fn camera(scene: &Scene, cam: usize, s: f64) -> Image {
    let c = &scene.cfg.cameras[cam];
    let camera = Camera::new(c);
    let mut img = Image::new(
        (c.resolution[0] as f64 / s).ceil() as usize,
        (c.resolution[1] as f64 / s).ceil() as usize,
    );
    let ch = &scene.chain;
    let joints = ch.links();
    // each link sampled along its length: what is in view is drawn, the rest clipped
    let radius = (scene.cfg.link_radius_mm / 4.0).clamp(2.0, 8.0) / s.sqrt();
    for pair in joints.windows(2) {
        let d = pair[1] - pair[0];
        let n = 400;
        for i in 0..=n {
            let p = pair[0] + d * (i as f64 / n as f64);
            if let Some((u, v)) = camera.project(&p) {
                img.disc(u / s, v / s, radius, ARM, None);
            }
        }
    }
    for p in &joints {
        if let Some((u, v)) = camera.project(p) {
            img.disc(u / s, v / s, 2.0 * radius, JOINT, None);
        }
    }
    // this camera's entries: light i at 2 * (2 i + cam)
    let lights = scene.status.len() / 2;
    let r = 12.0 / s.sqrt();
    for i in 0..lights {
        let k = 2 * i + cam;
        if let (Some(tx), Some(ty)) = (scene.target.get(2 * k), scene.target.get(2 * k + 1)) {
            if tx.is_finite() && ty.is_finite() {
                img.disc(tx / s, ty / s, r, TARGET, Some(3.0));
            }
        }
        if scene.status.get(k) == Some(&0) {
            img.disc(
                scene.lights[2 * k] / s,
                scene.lights[2 * k + 1] / s,
                0.6 * r,
                LIGHT,
                None,
            );
        }
    }
    img
}
