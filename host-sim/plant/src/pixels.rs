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

use trn_vision::{
    CaptureProtocol, Detector, DetectorParams, Emitter, Identifier, LightStatus, Occluder,
    Renderer, Sensor, Shape, VisionError,
};

use super::camera::Camera;
use super::vec3::{add, cross, norm, scale, segment_distance, sub, unit, V3};
use super::{Chain, PixelReading, Plant, PointStatus};

/// How the lights look and how the camera processor reads them.
#[derive(Debug, Clone, PartialEq)]
pub struct PixelVision {
    /// A light's spot, standard deviation (pixels).
    pub sigma_px: f64,
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
    /// The nominal LED of `trn_vision::accuracy::Blob::nominal` at 2 m, the 8-bit sensor of
    /// `Sensor::machine_vision`, the detector's defaults, a 3 px gate.
    fn default() -> PixelVision {
        PixelVision {
            sigma_px: 1.3,
            electrons_at_reference: 30_000.0,
            reference_mm: 2_000.0,
            sensor: Sensor::machine_vision(1, 1),
            detector: DetectorParams::default(),
            gate_px: 3.0,
        }
    }
}

/// Points along a link's axis for its pieces on the image.
const LINK_POINTS: usize = 16;

impl Plant {
    /// What camera `cam` sees of `lights` (mm) with the arm as it is: one emitter per light
    /// (`None` out of view) and the occluders.
    pub fn pixel_scene(
        &self,
        cam: usize,
        lights: &[V3],
        v: &PixelVision,
    ) -> (Vec<Option<Emitter>>, Vec<Occluder>) {
        let camera = &self.cameras[cam];
        let eye = camera.position();
        let emitters = lights
            .iter()
            .map(|p| {
                let (u, w) = camera.project(p)?;
                let d = norm(&sub(p, &eye));
                let mut e = Emitter::new(
                    [u, w],
                    v.sigma_px,
                    v.electrons_at_reference * (v.reference_mm / d).powi(2),
                );
                e.depth = d;
                Some(e)
            })
            .collect();
        let chain = self.chain();
        let mut occluders = Vec::new();
        for (a, b, r) in self.links(&chain, lights) {
            link_pieces(camera, &a, &b, r, &mut occluders);
        }
        (emitters, occluders)
    }

    /// The links, hand and cylinder as capsules `(a, b, radius)` (mm).
    fn links(&self, chain: &Chain, lights: &[V3]) -> Vec<(V3, V3, f64)> {
        let r = self.cfg.link_radius_mm;
        let mut links = vec![
            (chain.shoulder, chain.elbow, r),
            (chain.elbow, chain.wrist, r),
        ];
        if self.cfg.realism.occlude_hand_and_cylinder {
            let c = &chain.pose;
            links.push((
                chain.wrist,
                sub(&c.centre_mm, &scale(&c.approach, r)),
                0.8 * r,
            ));
            if let Some(cyl) = &self.cylinder {
                let half = scale(&cyl.axis, 0.5 * cyl.length);
                let (a, b) = (sub(&cyl.centre, &half), add(&cyl.centre, &half));
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
        lights: &[V3],
        protocol: &CaptureProtocol,
        v: &PixelVision,
        seed: u64,
    ) -> Result<Vec<PixelReading>, VisionError> {
        let [w, h] = self.cameras[cam].size;
        let sensor = Sensor {
            width: w,
            height: h,
            ..v.sensor.clone()
        };
        let renderer = Renderer::<u8>::new(&sensor)?;
        let detector = Detector::new(w, h, v.detector.clone())?;
        let identifier = Identifier::new(protocol.clone(), v.gate_px)?;
        let (emitters, occluders) = self.pixel_scene(cam, lights, v);
        // a light out of view: an emitter with no light, off the image
        let dark = Emitter::new([-1e4, -1e4], v.sigma_px, 0.0);
        let spots: Vec<Emitter> = emitters
            .iter()
            .map(|e| e.clone().unwrap_or_else(|| dark.clone()))
            .collect();
        let mut detections = Vec::with_capacity(protocol.frames());
        for (f, scene) in protocol.scenes(&spots, &occluders)?.iter().enumerate() {
            let frame = renderer.render(scene, seed.wrapping_mul(64).wrapping_add(f as u64))?;
            detections.push(detector.detect(&frame)?);
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

/// The capsule from `a` to `b` of radius `r` (mm) as image capsules, one per piece between
/// consecutive axis points that project into the image.
fn link_pieces(camera: &Camera, a: &V3, b: &V3, r: f64, out: &mut Vec<Occluder>) {
    let eye = camera.position();
    let axis = sub(b, a);
    let seen: Vec<Option<([f64; 2], f64, f64)>> = (0..=LINK_POINTS)
        .map(|i| {
            let p = add(a, &scale(&axis, i as f64 / LINK_POINTS as f64));
            let (u, v) = camera.project(&p)?;
            // the link's half-width on the image: a point r off the axis, across the view
            let view = sub(&p, &eye);
            let mut across = cross(&view, &axis);
            if norm(&across) < 1e-9 {
                across = cross(&view, &[0.0, 0.0, 1.0]);
            }
            let side = add(&p, &scale(&unit(&across), r));
            let (su, sv) = camera
                .project(&side)
                .or_else(|| camera.project(&sub(&p, &scale(&unit(&across), r))))?;
            Some(([u, v], (su - u).hypot(sv - v), norm(&view) - r))
        })
        .collect();
    for pair in seen.windows(2) {
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
