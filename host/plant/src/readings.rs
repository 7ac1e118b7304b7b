//! Camera readings of the plant's lights: projection through both cameras, occlusion by the
//! links, centroid noise.

use rand_core::RngCore;
use trn_vision::CaptureProtocol;

use super::config::Vision;
use super::geometry::{segments_distance, unit};
use super::pixels::{CaptureExtras, PixelVision};
use super::random::{gaussian, uniform};
use super::{kinematics, Chain, Plant, PointStatus, Vector3};

/// Which of the plant's lights a reading is of.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Marks {
    /// The gripper's lights p and q.
    GripperLights,
    /// The gripper's centre light c.
    GripperCentre,
    /// The light at the cylinder's centre.
    CylinderCentre,
}

/// What hides a light from a camera ([`Plant::hidden_by`]): the simulator's ground truth,
/// for diagnosing failures; a camera processor only sees that the light is missing.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Occluder {
    /// The upper arm.
    UpperArm,
    /// The forearm.
    Forearm,
    /// The hand (realistic plant).
    Hand,
    /// The cylinder standing in front of the arm (realistic plant).
    Cylinder,
}

impl Occluder {
    /// Its name in reports.
    pub fn name(self) -> &'static str {
        match self {
            Occluder::UpperArm => "upper arm",
            Occluder::Forearm => "forearm",
            Occluder::Hand => "hand",
            Occluder::Cylinder => "cylinder",
        }
    }
}

/// One light in one camera (pixels); `x`, `y` are NaN unless valid.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PixelReading {
    /// Column.
    pub x: f64,
    /// Row.
    pub y: f64,
    /// Validity.
    pub status: PointStatus,
}

/// `K` readings: each light in camera 0, then camera 1.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Readings<const K: usize> {
    /// The readings.
    pub points: [PixelReading; K],
}

impl<const K: usize> Readings<K> {
    /// The readings as the controller's input vector, or `None` if any is not valid (an
    /// estimate included).
    pub fn to_vector<const D: usize>(&self) -> Option<[f32; D]> {
        if self.points.iter().any(|p| p.status != PointStatus::Valid) {
            return None;
        }
        self.reported_vector()
    }

    /// The readings as the controller gets them, estimates included (what it measured its
    /// error on), or `None` if any is missing.
    pub fn reported_vector<const D: usize>(&self) -> Option<[f32; D]> {
        let reported =
            |p: &PixelReading| matches!(p.status, PointStatus::Valid | PointStatus::Estimated);
        if D != 2 * K || !self.points.iter().all(reported) {
            return None;
        }
        let mut v = [0.0; D];
        for (i, p) in self.points.iter().enumerate() {
            v[2 * i] = p.x as f32;
            v[2 * i + 1] = p.y as f32;
        }
        Some(v)
    }
}

impl Plant {
    /// What hides the point `p` (mm) from camera `cam` with the arm in `chain` and this
    /// plant's cylinder, if anything: the upper arm or the forearm (capsules of
    /// `link_radius_mm`), and on the realistic plant (`occlude_hand_and_cylinder`) the hand
    /// up to just short of the gripper centre (the centre light sits at its end) and the
    /// cylinder, unless `p` is inside it (its own centre, a gripper light on the fingers that
    /// hold it). The first in that order.
    pub fn hidden_by(&self, cam: usize, p: &Vector3<f64>, chain: &Chain) -> Option<Occluder> {
        let eye = self.cameras.get(cam)?.position();
        let r = self.cfg.link_radius_mm;
        let along = unit(&(p - eye));
        let near = p - along * (2.0 * r); // stop short of the light itself
        let links = [
            (Occluder::UpperArm, &chain.shoulder, &chain.elbow),
            (Occluder::Forearm, &chain.elbow, &chain.wrist),
        ];
        for (who, a, b) in links {
            if segments_distance(&eye, &near, a, b) < r {
                return Some(who);
            }
        }
        if !self.cfg.realism.occlude_hand_and_cylinder {
            return None;
        }
        let c = &chain.pose;
        let hand_end = c.centre_mm - c.approach * r;
        if segments_distance(&eye, &near, &chain.wrist, &hand_end) < 0.8 * r {
            return Some(Occluder::Hand);
        }
        let cyl = self.cylinder.as_ref()?;
        let half = cyl.axis * (0.5 * cyl.length);
        let (a, b) = (cyl.centre - half, cyl.centre + half);
        (segments_distance(p, p, &a, &b) > cyl.radius + 1.0
            && segments_distance(&eye, &near, &a, &b) < cyl.radius)
            .then_some(Occluder::Cylinder)
    }

    fn read(&mut self, cam: usize, p: &Vector3<f64>, noisy: bool, chain: &Chain) -> PixelReading {
        let invalid = |status| PixelReading {
            x: f64::NAN,
            y: f64::NAN,
            status,
        };
        let camera = &self.cameras[cam];
        let Some((u, v)) = camera.project(p) else {
            return invalid(PointStatus::OutOfView);
        };
        if !noisy {
            // the ground truth: where the light projects, seen or not (for scoring)
            return PixelReading {
                x: u,
                y: v,
                status: PointStatus::Valid,
            };
        }
        if self.hidden_by(cam, p, chain).is_some() {
            return invalid(PointStatus::Occluded);
        }
        let realism = &self.cfg.realism;
        if noisy
            && realism.dropout_rate > 0.0
            && uniform(&mut self.noise, 0.0, 1.0) < realism.dropout_rate
        {
            return invalid(PointStatus::NotDetected);
        }
        if noisy
            && realism.outlier_rate > 0.0
            && uniform(&mut self.noise, 0.0, 1.0) < realism.outlier_rate
        {
            // a reflection taken for the LED: a valid-looking point anywhere in the image
            let [w, h] = camera.size;
            return PixelReading {
                x: uniform(&mut self.noise, 0.0, w as f64),
                y: uniform(&mut self.noise, 0.0, h as f64),
                status: PointStatus::Valid,
            };
        }
        let s = self.cfg.pixel_noise_px;
        let (du, dv) = if noisy {
            (s * gaussian(&mut self.noise), s * gaussian(&mut self.noise))
        } else {
            (0.0, 0.0)
        };
        PixelReading {
            x: u + du,
            y: v + dv,
            status: PointStatus::Valid,
        }
    }

    fn observe_points<const K: usize>(&mut self, marks: Marks, noisy: bool) -> Readings<K> {
        let chain = self.chain();
        let lights = self.marks(marks, &chain);
        let mut points = [PixelReading {
            x: f64::NAN,
            y: f64::NAN,
            status: PointStatus::NotDetected,
        }; K];
        if noisy && self.cfg.vision == Vision::Pixels {
            let read = self.observe_on_pixels(marks, &lights);
            for (cam, readings) in read.iter().enumerate() {
                for (i, r) in readings.iter().enumerate() {
                    if let Some(slot) = points.get_mut(2 * i + cam) {
                        *slot = *r;
                    }
                }
            }
            return Readings { points };
        }
        for (i, light) in lights.iter().enumerate() {
            for cam in 0..2 {
                if let Some(slot) = points.get_mut(2 * i + cam) {
                    *slot = self.read(cam, light, noisy, &chain);
                }
            }
        }
        Readings { points }
    }

    /// The lights of `marks` where the arm is in `chain`.
    fn marks(&self, marks: Marks, chain: &Chain) -> Vec<Vector3<f64>> {
        match marks {
            Marks::GripperLights => kinematics::lights(&self.cfg, &chain.pose).to_vec(),
            Marks::GripperCentre => vec![chain.pose.centre_mm],
            Marks::CylinderCentre => self.cylinder.iter().map(|c| c.centre).collect(),
        }
    }

    /// `lights` (those of `marks`) read on pixels by both cameras (`vision = "pixels"`): one
    /// capture per camera, the lights lit one per frame, each frame's exposure centred on
    /// this moment with the arm moving as it does now; a light fails to fire and a reflection
    /// of it appears somewhere in the image at the rates of `[realism]`. A capture the
    /// camera processor cannot read (which a valid configuration never gives) reads nothing.
    fn observe_on_pixels(
        &mut self,
        marks: Marks,
        lights: &[Vector3<f64>],
    ) -> [Vec<PixelReading>; 2] {
        let v = PixelVision::from_config(&self.cfg.pixels);
        let exposure_s = 1e-3 * self.cfg.pixels.exposure_ms;
        let q = self.joint_angles();
        let mut qa = q;
        let mut qb = q;
        for (i, j) in self.joints.iter().enumerate() {
            qa[i] -= 0.5 * exposure_s * j.velocity();
            qb[i] += 0.5 * exposure_s * j.velocity();
        }
        let before = self.marks(marks, &kinematics::forward(&self.cfg, &qa));
        let after = self.marks(marks, &kinematics::forward(&self.cfg, &qb));
        let motion_mm: Vec<Vector3<f64>> = after.iter().zip(&before).map(|(b, a)| b - a).collect();
        let nothing = || {
            vec![
                PixelReading {
                    x: f64::NAN,
                    y: f64::NAN,
                    status: PointStatus::NotDetected,
                };
                lights.len()
            ]
        };
        let Ok(protocol) = CaptureProtocol::sequential(lights.len()) else {
            return [nothing(), nothing()];
        };
        let realism = self.cfg.realism.clone();
        [0, 1].map(|cam| {
            let mut extras = CaptureExtras {
                motion_mm: motion_mm.clone(),
                ..CaptureExtras::default()
            };
            let [w, h] = self.cameras[cam].size;
            for i in 0..lights.len() {
                if realism.dropout_rate > 0.0
                    && uniform(&mut self.noise, 0.0, 1.0) < realism.dropout_rate
                {
                    extras.dark.push(i);
                }
                if realism.outlier_rate > 0.0
                    && uniform(&mut self.noise, 0.0, 1.0) < realism.outlier_rate
                {
                    let at = [
                        uniform(&mut self.noise, 0.0, w as f64),
                        uniform(&mut self.noise, 0.0, h as f64),
                    ];
                    extras.reflections.push((i, at));
                }
            }
            let seed = self.noise.next_u64();
            self.read_capture(cam, lights, &extras, &protocol, &v, seed)
                .unwrap_or_else(|_| nothing())
        })
    }

    /// The gripper lights p and q in both cameras (stage 1's 8-D input), with pixel noise.
    pub fn observe_gripper_lights(&mut self) -> Readings<4> {
        self.observe_points(Marks::GripperLights, true)
    }

    /// The same without noise (ground truth).
    pub fn observe_gripper_lights_true(&mut self) -> Readings<4> {
        self.observe_points(Marks::GripperLights, false)
    }

    /// The gripper-centre light in both cameras (stage 2's 4-D input), with pixel noise.
    pub fn observe_gripper_centre(&mut self) -> Readings<2> {
        self.observe_points(Marks::GripperCentre, true)
    }

    /// The same without noise.
    pub fn observe_gripper_centre_true(&mut self) -> Readings<2> {
        self.observe_points(Marks::GripperCentre, false)
    }

    /// The centre of the cylinder (the middle of its axis ab) in both cameras, with noise.
    pub fn observe_cylinder_centre(&mut self) -> Readings<2> {
        self.observe_cylinder(true)
    }

    /// The same without noise.
    pub fn observe_cylinder_centre_true(&mut self) -> Readings<2> {
        self.observe_cylinder(false)
    }

    fn observe_cylinder(&mut self, noisy: bool) -> Readings<2> {
        match self.cylinder {
            Some(_) => self.observe_points(Marks::CylinderCentre, noisy),
            None => {
                let none = PixelReading {
                    x: f64::NAN,
                    y: f64::NAN,
                    status: PointStatus::NotDetected,
                };
                Readings { points: [none; 2] }
            }
        }
    }
}
