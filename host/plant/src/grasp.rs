//! Cylinders to grasp and the score of a grasp (Fig. 8.3).

use super::geometry::angle_deg;
use super::kinematics::forward;
use super::{Plant, Vector3};

/// A cylinder to grasp.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Cylinder {
    /// Centre of mass (mm).
    pub centre: Vector3<f64>,
    /// Unit axis (ZZ').
    pub axis: Vector3<f64>,
    /// Radius (mm).
    pub radius: f64,
    /// Length (mm).
    pub length: f64,
}

/// How well a grasp went.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GraspScore {
    /// Gripper centre to cylinder centre (mm).
    pub distance_mm: f64,
    /// Deviation of the gripper from perpendicular to the cylinder axis (degrees).
    pub perpendicular_error_deg: f64,
    /// Both within the configured limits.
    pub success: bool,
}

impl Plant {
    /// Places a cylinder for the current pose as the pre-grasp pose (Fig. 8.3): its axis
    /// along the gripper's normal (parallel to the line of the lights p and q, which are the
    /// gripper's lights now), its centre `approach_mm` ahead of the gripper centre.
    pub fn place_cylinder(&mut self) -> Cylinder {
        let pose = self.gripper_pose();
        let c = Cylinder {
            centre: pose.centre_mm + pose.approach * self.cfg.approach_mm,
            axis: pose.normal,
            radius: self.cfg.cylinder_radius_mm,
            length: self.cfg.cylinder_length_mm,
        };
        self.cylinder = Some(c);
        c
    }

    /// Places `cyl` in the world (a cylinder placed for another arm's pose: a deployment
    /// target of the twin), or removes it.
    pub fn set_cylinder(&mut self, cyl: Option<Cylinder>) {
        self.cylinder = cyl;
    }

    /// The cylinder placed last.
    pub fn cylinder(&self) -> Option<&Cylinder> {
        self.cylinder.as_ref()
    }

    /// Whether the arm can hold `cyl` from where it is now, moving the joints stage 2 moves
    /// (base, shoulder, elbow; the wrists as they are): angles exist that put the gripper
    /// centre on the cylinder centre with a tilt within the grasp limit, each inside the range
    /// the joint reaches with drive pressures within its `target_limit`
    /// ([`super::joint::Joint::angle_range`]), the range every target pose is drawn from.
    /// A cylinder placed `approach_mm` ahead of a pose near the edge of the workspace can
    /// need a shoulder or an elbow beyond its stop: no controller can grasp it, and a
    /// held-out grasp set must not hold it. Found by Gauss-Newton on the forward kinematics
    /// (finite-difference Jacobian, from the present angles).
    pub fn grasp_reachable(&self, cyl: &Cylinder) -> bool {
        const MOVED: usize = 3;
        let mut q = self.joint_angles();
        let centre = |q: &[f64; 5]| forward(&self.cfg, q).pose.centre_mm;
        for _ in 0..30 {
            let r = cyl.centre - centre(&q);
            if r.norm() < 0.01 {
                break;
            }
            let mut jac = nalgebra::Matrix3::<f64>::zeros();
            for k in 0..MOVED {
                let mut qk = q;
                qk[k] += 1e-6;
                let d = centre(&qk) - centre(&q);
                for row in 0..3 {
                    jac[(row, k)] = d[row] / 1e-6;
                }
            }
            let Some(dq) = jac.lu().solve(&r) else {
                return false;
            };
            // at most 0.2 rad per step: the solution nearest the present pose
            let step = dq.amax().max(0.2) / 0.2;
            for k in 0..MOVED {
                q[k] += dq[k] / step;
            }
        }
        let pose = forward(&self.cfg, &q).pose;
        let tilt = angle_deg(&pose.normal, &cyl.axis);
        let in_range = self.joints[..MOVED]
            .iter()
            .zip(&self.cfg.joints)
            .zip(&q)
            .all(|((j, c), a)| {
                let (lo, hi) = j.angle_range(c.target_limit);
                (lo..=hi).contains(a)
            });
        (cyl.centre - pose.centre_mm).norm() < 0.1
            && tilt.min(180.0 - tilt) <= self.cfg.grasp_angle_deg
            && in_range
    }

    /// Scores a grasp of `cyl` with the gripper where it is now.
    pub fn grasp_score(&self, cyl: &Cylinder) -> GraspScore {
        let pose = self.gripper_pose();
        let distance_mm = (pose.centre_mm - cyl.centre).norm();
        // perpendicular: the cylinder axis along the gripper normal, i.e. perpendicular to
        // both the approach direction and the finger axis
        let tilt = angle_deg(&pose.normal, &cyl.axis);
        let perpendicular_error_deg = tilt.min(180.0 - tilt);
        let success = distance_mm <= self.cfg.grasp_distance_mm
            && perpendicular_error_deg <= self.cfg.grasp_angle_deg;
        GraspScore {
            distance_mm,
            perpendicular_error_deg,
            success,
        }
    }
}
