//! Cylinders to grasp and the score of a grasp (Fig. 8.3).

use super::vec3::{add, angle_deg, norm, scale, sub, V3};
use super::Plant;

/// A cylinder to grasp.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Cylinder {
    /// Centre of mass (mm).
    pub centre: V3,
    /// Unit axis (ZZ').
    pub axis: V3,
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
            centre: add(
                &pose.centre_mm,
                &scale(&pose.approach, self.cfg.approach_mm),
            ),
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

    /// Scores a grasp of `cyl` with the gripper where it is now.
    pub fn grasp_score(&self, cyl: &Cylinder) -> GraspScore {
        let pose = self.gripper_pose();
        let distance_mm = norm(&sub(&pose.centre_mm, &cyl.centre));
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
