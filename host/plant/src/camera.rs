//! Calibrated pinhole cameras with optional radial distortion.

use super::config::CameraConfig;
use super::geometry::unit;
use super::Vector3;

/// A pinhole camera: optical axis from its position towards `look_at`, image x to the
/// right, image y down, principal point at the image centre.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Camera {
    pos: Vector3<f64>,
    forward: Vector3<f64>,
    right: Vector3<f64>,
    down: Vector3<f64>,
    f: f64,
    cx: f64,
    cy: f64,
    k: [f64; 2],
    /// Image width and height (pixels).
    pub size: [u32; 2],
}

/// A camera as an ideal pinhole a viewer can place (lens distortion left out): its centre,
/// its axes and its intrinsics, as [`Camera::new`] builds them.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
pub struct Pinhole {
    /// The camera centre (mm, base frame).
    pub position_mm: [f64; 3],
    /// The image's x (right), its y (down) and the optical axis, unit vectors in the base
    /// frame: the columns of the rotation from camera to base coordinates.
    pub axes: [[f64; 3]; 3],
    /// The focal length (pixels).
    pub focal_px: f64,
    /// Image width and height (pixels); the principal point is the image centre.
    pub resolution: [u32; 2],
}

/// The gradients of a pixel's `u` and `v` in the point it projects (per mm, base frame).
pub type PixelGradient = [Vector3<f64>; 2];

/// A point's projection ([`Camera::project`]) with the terms of its gradient: the depth, the
/// normalised image coordinates, their squared radius and the distortion's factor.
struct Projected {
    uv: (f64, f64),
    z: f64,
    xn: f64,
    yn: f64,
    r2: f64,
    g: f64,
}

impl Camera {
    /// A camera from its configuration.
    pub fn new(c: &CameraConfig) -> Camera {
        let pos = Vector3::from(c.position_mm);
        let forward = unit(&(Vector3::from(c.look_at_mm) - pos));
        let up = Vector3::new(0.0, 0.0, 1.0);
        let mut right = forward.cross(&up);
        if right.norm() < 1e-9 {
            right = Vector3::new(0.0, -1.0, 0.0);
        }
        let right = unit(&right);
        let down = forward.cross(&right);
        Camera {
            pos,
            forward,
            right,
            down,
            f: c.focal_px,
            cx: c.resolution[0] as f64 / 2.0,
            cy: c.resolution[1] as f64 / 2.0,
            k: c.distortion,
            size: c.resolution,
        }
    }

    /// The camera as an ideal pinhole ([`Pinhole`]).
    pub fn pinhole(&self) -> Pinhole {
        let xyz = |v: &Vector3<f64>| [v.x, v.y, v.z];
        Pinhole {
            position_mm: xyz(&self.pos),
            axes: [xyz(&self.right), xyz(&self.down), xyz(&self.forward)],
            focal_px: self.f,
            resolution: self.size,
        }
    }

    /// The focal length (pixels).
    pub fn focal_px(&self) -> f64 {
        self.f
    }

    /// The camera centre (mm).
    pub fn position(&self) -> Vector3<f64> {
        self.pos
    }

    /// The image's x (right) and y (down) directions in the base frame (unit vectors; the
    /// optical axis is right x down).
    pub fn image_axes(&self) -> (Vector3<f64>, Vector3<f64>) {
        (self.right, self.down)
    }

    /// The direction (unit, base frame) of the pinhole ray through pixel `(u, v)`, lens
    /// distortion ignored: a starting point for [`super::stereo::reprojection_error`].
    pub fn ray(&self, u: f64, v: f64) -> Vector3<f64> {
        let (xn, yn) = ((u - self.cx) / self.f, (v - self.cy) / self.f);
        let d = self.forward + self.right * xn + self.down * yn;
        d / d.norm()
    }

    /// Projects a point (mm) to pixels; `None` when it is behind the camera or outside the
    /// image.
    pub fn project(&self, p: &Vector3<f64>) -> Option<(f64, f64)> {
        self.projected(p).map(|x| x.uv)
    }

    /// [`Camera::project`] with the terms its gradient takes.
    #[inline(always)]
    fn projected(&self, p: &Vector3<f64>) -> Option<Projected> {
        let d = p - self.pos;
        let z = d.dot(&self.forward);
        if z <= 1.0 {
            return None;
        }
        let (xn, yn) = (d.dot(&self.right) / z, d.dot(&self.down) / z);
        let r2 = xn * xn + yn * yn;
        let g = 1.0 + self.k[0] * r2 + self.k[1] * r2 * r2;
        let (u, v) = (self.cx + self.f * xn * g, self.cy + self.f * yn * g);
        if u < 0.0 || v < 0.0 || u >= self.size[0] as f64 || v >= self.size[1] as f64 {
            None
        } else {
            Some(Projected {
                uv: (u, v),
                z,
                xn,
                yn,
                r2,
                g,
            })
        }
    }

    /// [`Camera::project`] with the pixel's gradient: `u` and `v` each as a function of the
    /// point (per mm, base frame), differentiated through the pinhole and the radial
    /// distortion; `None` where [`Camera::project`] gives none.
    pub fn project_with_gradient(&self, p: &Vector3<f64>) -> Option<((f64, f64), PixelGradient)> {
        let Projected {
            uv,
            z,
            xn,
            yn,
            r2,
            g,
        } = self.projected(p)?;
        let dxn = (self.right - self.forward * xn) / z;
        let dyn_ = (self.down - self.forward * yn) / z;
        let dg = (dxn * (2.0 * xn) + dyn_ * (2.0 * yn)) * (self.k[0] + 2.0 * self.k[1] * r2);
        Some((
            uv,
            [(dxn * g + dg * xn) * self.f, (dyn_ * g + dg * yn) * self.f],
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn projection_matches_hand_computed_pinhole_points() {
        // camera at the origin looking along +x: right is -y, down is -z
        let c = Camera::new(&CameraConfig {
            resolution: [640, 480],
            focal_px: 500.0,
            position_mm: [0.0, 0.0, 0.0],
            look_at_mm: [1000.0, 0.0, 0.0],
            distortion: [0.0, 0.0],
        });
        assert_eq!(
            c.project(&Vector3::new(1000.0, 0.0, 0.0)),
            Some((320.0, 240.0))
        );
        // 100 mm to the left and 50 mm up at 1 m: u = 320 - 500 * 0.1, v = 240 - 500 * 0.05
        let (u, v) = c.project(&Vector3::new(1000.0, 100.0, 50.0)).unwrap();
        assert!(
            (u - 270.0).abs() < 1e-9 && (v - 215.0).abs() < 1e-9,
            "{u} {v}"
        );
        assert_eq!(c.project(&Vector3::new(-1000.0, 0.0, 0.0)), None, "behind");
        assert_eq!(
            c.project(&Vector3::new(1000.0, 1000.0, 0.0)),
            None,
            "outside the image"
        );
    }

    #[test]
    fn the_pinhole_projects_as_the_camera_without_distortion() {
        // a camera placed off every axis, its pinhole's axes and intrinsics applied by hand
        let c = Camera::new(&CameraConfig {
            resolution: [1024, 768],
            focal_px: 800.0,
            position_mm: [2100.0, -650.0, 650.0],
            look_at_mm: [550.0, 0.0, 450.0],
            distortion: [0.0, 0.0],
        });
        let h = c.pinhole();
        assert_eq!(
            (h.position_mm, h.focal_px, h.resolution),
            ([2100.0, -650.0, 650.0], 800.0, [1024, 768])
        );
        for p in [
            [500.0, 0.0, 400.0],
            [700.0, -200.0, 100.0],
            [300.0, 150.0, 600.0],
        ] {
            let d: Vec<f64> = (0..3).map(|i| p[i] - h.position_mm[i]).collect();
            let along = |a: [f64; 3]| a[0] * d[0] + a[1] * d[1] + a[2] * d[2];
            let z = along(h.axes[2]);
            let u = h.focal_px * along(h.axes[0]) / z + h.resolution[0] as f64 / 2.0;
            let v = h.focal_px * along(h.axes[1]) / z + h.resolution[1] as f64 / 2.0;
            let (cu, cv) = c.project(&Vector3::from(p)).unwrap();
            assert!(
                (u - cu).abs() < 1e-9 && (v - cv).abs() < 1e-9,
                "{p:?}: {u} {v} against {cu} {cv}"
            );
        }
    }

    #[test]
    fn radial_distortion_moves_points_outwards() {
        let mut cfg = CameraConfig {
            resolution: [640, 480],
            focal_px: 500.0,
            position_mm: [0.0, 0.0, 0.0],
            look_at_mm: [1000.0, 0.0, 0.0],
            distortion: [0.1, 0.0],
        };
        let (u, _) = Camera::new(&cfg)
            .project(&Vector3::new(1000.0, 200.0, 0.0))
            .unwrap();
        // xn = -0.2, r2 = 0.04, g = 1.004: u = 320 - 500 * 0.2 * 1.004
        assert!((u - (320.0 - 100.4)).abs() < 1e-9);
        cfg.distortion = [0.0, 0.0];
        let (u0, _) = Camera::new(&cfg)
            .project(&Vector3::new(1000.0, 200.0, 0.0))
            .unwrap();
        assert!(u < u0);
    }

    /// The analytic gradient of [`Camera::project_with_gradient`] is the projection's
    /// central difference, with the realistic lenses' distortion, at points across the
    /// image and depths: fails on any wrong term (the distortion's, the perspective's).
    #[test]
    fn the_projections_gradient_is_its_central_difference() {
        let c = Camera::new(&CameraConfig {
            resolution: [1024, 768],
            focal_px: 800.0,
            position_mm: [2100.0, -650.0, 650.0],
            look_at_mm: [550.0, 0.0, 450.0],
            distortion: [-0.12, 0.03],
        });
        let h = 1e-4;
        let mut checked = 0;
        for i in 0..200 {
            let t = i as f64;
            let p = Vector3::new(
                550.0 + 400.0 * (0.7 * t).sin(),
                300.0 * (1.3 * t).cos(),
                450.0 + 300.0 * (2.1 * t).sin(),
            );
            let Some((uv, grad)) = c.project_with_gradient(&p) else {
                continue;
            };
            assert_eq!(Some(uv), c.project(&p));
            for axis in 0..3 {
                let mut e = Vector3::zeros();
                e[axis] = h;
                let (Some(a), Some(b)) = (c.project(&(p + e)), c.project(&(p - e))) else {
                    continue;
                };
                let numeric = [(a.0 - b.0) / (2.0 * h), (a.1 - b.1) / (2.0 * h)];
                for k in 0..2 {
                    let err = (grad[k][axis] - numeric[k]).abs();
                    assert!(
                        err < 1e-6 * (1.0 + numeric[k].abs()),
                        "{p:?} {axis} {k}: {grad:?} {numeric:?}"
                    );
                }
                checked += 1;
            }
        }
        assert!(checked > 300, "{checked}");
    }
}
