//! Where targets come from.
//!
//! [`visit_and_return`] is the paper's protocol (Sec. 8.4.1, "split brain"): the arm itself
//! is driven to random pressures, the cameras read its lights, the pressures are forgotten
//! and the arm is moved away before the trial.

use rand_core::RngCore;

use crate::error::{Error, Result};
use crate::plant::{Cylinder, Plant, Pose, Readings};

/// A trial's target, with its ground truth.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Target {
    /// Lights p and q in both cameras, as measured (noisy): what the controller gets.
    pub v: [f32; 8],
    /// The same, noise-free.
    pub v_true: [f32; 8],
    /// Gripper centre (or, for a grasp, cylinder centre) in both cameras, as measured.
    pub c: [f32; 4],
    /// The same, noise-free.
    pub c_true: [f32; 4],
    /// What the camera noise alone gives at the target: |second reading - `v`|.
    pub noise_v: f32,
    /// The same for `c`.
    pub noise_c: f32,
    /// The gripper's pose at the target.
    pub pose: Pose,
    /// The pressures that produced it (sent only in supervised priming).
    pub pressures: [f32; 5],
    /// The cylinder of a grasp.
    pub cylinder: Option<Cylinder>,
}

/// Euclidean distance.
pub fn dist<const D: usize>(a: &[f32; D], b: &[f32; D]) -> f32 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y) * (x - y))
        .sum::<f32>()
        .sqrt()
}

fn second_reading<const K: usize, const D: usize>(r: Readings<K>, first: &[f32; D]) -> f32 {
    r.to_vector().map(|w| dist(&w, first)).unwrap_or(0.0)
}

/// The paper's target: the arm goes to random pressures, both cameras read its lights (a
/// second reading gives the noise floor), and, for a grasp, a cylinder is placed so that
/// this pose is its pre-grasp pose. Draws again while a light is not seen.
pub fn visit_and_return(plant: &mut Plant, rng: &mut impl RngCore, grasp: bool) -> Result<Target> {
    const DRAWS: usize = 1000;
    for _ in 0..DRAWS {
        let p = plant.random_pressures(rng);
        plant.command(&p);
        plant.settle();
        let lights = plant.observe_gripper_lights();
        let lights_true = plant.observe_gripper_lights_true();
        let centre = plant.observe_gripper_centre();
        let centre_true = plant.observe_gripper_centre_true();
        let (Some(v), Some(v_true), Some(c), Some(c_true)) = (
            lights.to_vector(),
            lights_true.to_vector(),
            centre.to_vector(),
            centre_true.to_vector(),
        ) else {
            continue;
        };
        let noise_v = second_reading(plant.observe_gripper_lights(), &v);
        let noise_c = second_reading(plant.observe_gripper_centre(), &c);
        let mut t = Target {
            v,
            v_true,
            c,
            c_true,
            noise_v,
            noise_c,
            pose: plant.gripper_pose(),
            pressures: p,
            cylinder: None,
        };
        if grasp {
            let cyl = plant.place_cylinder();
            let (Some(cc), Some(cc_true)) = (
                plant.observe_cylinder_centre().to_vector(),
                plant.observe_cylinder_centre_true().to_vector(),
            ) else {
                continue;
            };
            t.c = cc;
            t.c_true = cc_true;
            t.noise_c = second_reading(plant.observe_cylinder_centre(), &cc);
            t.cylinder = Some(cyl);
        }
        return Ok(t);
    }
    Err(Error::NoTarget(DRAWS))
}
