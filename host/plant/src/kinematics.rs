//! Forward kinematics of the five-joint arm: base rotation, shoulder, elbow, and a
//! differential wrist.
//!
//! Frame: x forward, y left, z up, origin at the base. Joint 0 turns the arm about z;
//! joints 1 (shoulder) and 2 (elbow) pitch the upper arm and forearm in the arm's vertical
//! plane. The wrist is differential, as the SoftArm's (Sec. 8.2): joints 3 and 4 each turn
//! the gripper about both of its axes, pitch YY' = (q3 + q4) / 2 and roll XX' = (q3 - q4) / 2;
//! a pure rotation about either axis needs both pressures.

use super::config::SimConfig;
use super::geometry::{angle_deg, unit};
use super::Vector3;

/// The gripper's pose.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Pose {
    /// Gripper centre, between the fingers (mm).
    pub centre_mm: Vector3<f64>,
    /// Approach direction (the gripper's XX', pointing from wrist to fingers).
    pub approach: Vector3<f64>,
    /// Finger-closing axis (YY').
    pub finger_axis: Vector3<f64>,
    /// The axis a grasped cylinder must have, approach x finger axis (ZZ').
    pub normal: Vector3<f64>,
    /// Joint angles (degrees).
    pub joint_angles_deg: [f64; 5],
}

impl Pose {
    /// No pose (NaN everywhere).
    pub const NONE: Pose = Pose {
        centre_mm: Vector3::new(f64::NAN, f64::NAN, f64::NAN),
        approach: Vector3::new(f64::NAN, f64::NAN, f64::NAN),
        finger_axis: Vector3::new(f64::NAN, f64::NAN, f64::NAN),
        normal: Vector3::new(f64::NAN, f64::NAN, f64::NAN),
        joint_angles_deg: [f64::NAN; 5],
    };

    /// Position (mm) and orientation (degrees: the larger of the approach and normal
    /// deviations) error of this pose against `target`.
    pub fn error_to(&self, target: &Pose) -> (f32, f32) {
        let mm = (self.centre_mm - target.centre_mm).norm();
        let deg = angle_deg(&self.approach, &target.approach)
            .max(angle_deg(&self.normal, &target.normal));
        (mm as f32, deg as f32)
    }
}

/// Shoulder, elbow, wrist and gripper-centre positions, and the pose.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Chain {
    /// Shoulder (mm).
    pub shoulder: Vector3<f64>,
    /// Elbow (mm).
    pub elbow: Vector3<f64>,
    /// Wrist (mm).
    pub wrist: Vector3<f64>,
    /// The gripper's pose.
    pub pose: Pose,
}

impl Chain {
    /// The arm as a polyline (mm): the base's origin, the shoulder, the elbow, the wrist and
    /// the gripper's centre (what the pictures, the live view and the renderer draw).
    pub fn links(&self) -> [Vector3<f64>; 5] {
        [
            Vector3::zeros(),
            self.shoulder,
            self.elbow,
            self.wrist,
            self.pose.centre_mm,
        ]
    }
}

/// Forward kinematics for joint angles `q` (radians).
pub fn forward(cfg: &SimConfig, q: &[f64; 5]) -> Chain {
    let (c0, s0) = (q[0].cos(), q[0].sin());
    let radial = |a: f64| Vector3::new(a.cos() * c0, a.cos() * s0, a.sin());
    let shoulder = Vector3::new(0.0, 0.0, cfg.shoulder_height_mm);
    let a1 = q[1];
    let a2 = q[1] + q[2];
    let elbow = shoulder + radial(a1) * cfg.upper_arm_mm;
    let wrist = elbow + radial(a2) * cfg.forearm_mm;
    let pitch = 0.5 * (q[3] + q[4]);
    let roll = 0.5 * (q[3] - q[4]);
    let approach = unit(&radial(a2 + pitch));
    // the finger axis before roll: horizontal, perpendicular to the arm's plane
    let lateral = Vector3::new(-s0, c0, 0.0);
    let up_in_plane = approach.cross(&lateral);
    let finger_axis = unit(&(lateral * roll.cos() + up_in_plane * roll.sin()));
    let normal = unit(&approach.cross(&finger_axis));
    let centre = wrist + approach * cfg.hand_mm;
    let mut deg = [0.0; 5];
    for (d, a) in deg.iter_mut().zip(q.iter()) {
        *d = a.to_degrees();
    }
    Chain {
        shoulder,
        elbow,
        wrist,
        pose: Pose {
            centre_mm: centre,
            approach,
            finger_axis,
            normal,
            joint_angles_deg: deg,
        },
    }
}

/// The gripper lights p and q: at the centre, `light_offset_mm` either way along the normal
/// (the axis a grasped cylinder has), so that at the pre-grasp pose they coincide with the
/// target lights in front of the cylinder (Fig. 8.3).
pub fn lights(cfg: &SimConfig, pose: &Pose) -> [Vector3<f64>; 2] {
    let d = pose.normal * cfg.light_offset_mm;
    [pose.centre_mm + d, pose.centre_mm + d * -1.0]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn straight_arm_by_hand() {
        let cfg = SimConfig::default();
        let c = forward(&cfg, &[0.0; 5]);
        let reach = cfg.upper_arm_mm + cfg.forearm_mm + cfg.hand_mm;
        assert!((c.pose.centre_mm[0] - reach).abs() < 1e-9);
        assert!((c.pose.centre_mm[2] - cfg.shoulder_height_mm).abs() < 1e-9);
        assert!((c.pose.finger_axis[1] - 1.0).abs() < 1e-12);
        assert!(
            (c.pose.normal[2] - 1.0).abs() < 1e-12,
            "{:?}",
            c.pose.normal
        );
    }

    #[test]
    fn the_wrist_is_differential() {
        let cfg = SimConfig::default();
        // equal wrist angles: pure pitch; opposite: pure roll (approach unchanged)
        let pitch = forward(&cfg, &[0.0, 0.0, 0.0, 0.3, 0.3]).pose;
        assert!((pitch.approach[2] - 0.3f64.sin()).abs() < 1e-12);
        let roll = forward(&cfg, &[0.0, 0.0, 0.0, 0.3, -0.3]).pose;
        assert!((roll.approach[0] - 1.0).abs() < 1e-12);
        assert!((roll.finger_axis[2] - 0.3f64.sin()).abs() < 1e-12);
        // one wrist joint alone moves both
        let one = forward(&cfg, &[0.0, 0.0, 0.0, 0.3, 0.0]).pose;
        assert!(one.approach[2] > 0.0 && one.finger_axis[2] > 0.0);
        for p in [pitch, roll, one] {
            assert!((p.normal.norm() - 1.0).abs() < 1e-12);
            assert!(p.normal.dot(&p.approach).abs() < 1e-12);
        }
    }
}
