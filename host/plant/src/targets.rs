//! Where targets come from.
//!
//! [`visit_and_return`] is the paper's protocol (Sec. 8.4.1, "split brain"): the arm itself
//! is driven to random pressures, the cameras read its lights, the pressures are forgotten
//! and the arm is moved away before the trial. Training uses it, as the paper does. With
//! hysteresis it flatters an evaluation: commanding the target pressure again from nearby
//! often lands on the very pose, by the play operators' return-point memory.
//!
//! [`HeldOut`] targets are deployment-style: the pose is reached by a [`Plant::twin`] (an
//! arm in the same state of drift and wear) from rest along its own random path, so the
//! evaluated arm never benefits from having just been there, as with a cylinder a person
//! placed. Every held-out evaluation uses them.

use rand_core::RngCore;

use crate::{Cylinder, Plant, PlantError as Error, Pose, Readings};

type Result<T> = std::result::Result<T, Error>;

/// A trial's target, with its ground truth.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
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

impl Target {
    /// No target (a trial whose target could not be seen).
    pub const NONE: Target = Target {
        v: [f32::NAN; 8],
        v_true: [f32::NAN; 8],
        c: [f32::NAN; 4],
        c_true: [f32::NAN; 4],
        noise_v: f32::NAN,
        noise_c: f32::NAN,
        pose: Pose::NONE,
        pressures: [f32::NAN; 5],
        cylinder: None,
    };
}

/// Intermediate pressures a twin passes through on its way to a held-out target.
pub const PATH: usize = 3;

/// A held-out target, fixed for a whole run: the same pressures, path and noise realise the
/// same target at every evaluation (on a static plant), or its drifted counterpart.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HeldOut {
    /// The target pressures.
    pub pressures: [f32; 5],
    /// The twin's path from rest to the target pressures.
    pub path: [[f32; 5]; PATH],
    /// Seed of the twin's camera noise.
    pub noise_seed: u64,
    /// Pressures of the evaluated arm's start pose (stage 2 and grasps: its wrist goes to the
    /// target's wrist pressures instead, along its own path).
    pub start: [f32; 5],
}

impl HeldOut {
    /// A random held-out target.
    pub fn draw(plant: &Plant, rng: &mut impl RngCore) -> HeldOut {
        HeldOut {
            pressures: plant.random_pressures(rng),
            path: core::array::from_fn(|_| plant.random_pressures(rng)),
            noise_seed: rng.next_u64(),
            start: plant.random_pressures(rng),
        }
    }

    /// `n` held-out targets all lights of which both cameras see from a twin of `plant`.
    pub fn set(
        plant: &Plant,
        rng: &mut impl RngCore,
        n: usize,
        grasp: bool,
    ) -> Result<Vec<HeldOut>> {
        Ok(HeldOut::set_realised(plant, rng, n, grasp)?
            .into_iter()
            .map(|(h, _)| h)
            .collect())
    }

    /// [`HeldOut::set`], given up when `stop` says so (asked before every 64th draw): `None`
    /// then. A large set takes long to realise (each target settles a twin of the arm), and
    /// an interrupt must not wait for it. `stop` draws nothing: the set is the same.
    pub fn set_unless(
        plant: &Plant,
        rng: &mut impl RngCore,
        n: usize,
        grasp: bool,
        stop: &dyn Fn() -> bool,
    ) -> Result<Option<Vec<HeldOut>>> {
        Ok(HeldOut::realise_unless(plant, rng, n, grasp, stop)?
            .map(|set| set.into_iter().map(|(h, _)| h).collect()))
    }

    /// [`HeldOut::set`] with each target as it was realised (the same draws, the same
    /// targets): a caller that needs the targets now does not realise them again.
    pub fn set_realised(
        plant: &Plant,
        rng: &mut impl RngCore,
        n: usize,
        grasp: bool,
    ) -> Result<Vec<(HeldOut, Target)>> {
        Ok(HeldOut::realise_unless(plant, rng, n, grasp, &|| false)?.unwrap_or_default())
    }

    fn realise_unless(
        plant: &Plant,
        rng: &mut impl RngCore,
        n: usize,
        grasp: bool,
        stop: &dyn Fn() -> bool,
    ) -> Result<Option<Vec<(HeldOut, Target)>>> {
        let mut out = Vec::with_capacity(n);
        let mut draws = 0;
        while out.len() < n {
            if draws % 64 == 0 && stop() {
                return Ok(None);
            }
            draws += 1;
            if draws > 20 * n + 1000 {
                return Err(Error::NoTarget(draws));
            }
            let h = HeldOut::draw(plant, rng);
            if let Ok(t) = h.realise(plant, grasp) {
                out.push((h, t));
            }
        }
        Ok(Some(out))
    }

    /// The target on a twin of `plant` (the same drift and wear), with its cylinder for a
    /// grasp; `NoTarget` when a light is not seen.
    pub fn realise(&self, plant: &Plant, grasp: bool) -> Result<Target> {
        let mut twin = plant.twin(self.noise_seed);
        for p in &self.path {
            twin.command(p);
            twin.settle();
        }
        twin.command(&self.pressures);
        twin.settle();
        read_target(&mut twin, self.pressures, grasp).ok_or(Error::NoTarget(1))
    }
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
        if let Some(t) = read_target(plant, p, grasp) {
            return Ok(t);
        }
    }
    Err(Error::NoTarget(DRAWS))
}

/// Reads the target at the plant's pose (`p` produced it), with a second reading for the
/// noise floor and, for a grasp, a cylinder placed so that this pose is its pre-grasp pose.
fn read_target(plant: &mut Plant, p: [f32; 5], grasp: bool) -> Option<Target> {
    {
        // read as the camera processor reads (stereo check, new frames), twice, the two
        // frames agreeing (plant::stereo): a target is shown once and kept, so an outlier
        // that passes the stereo check by chance must not become one
        // (first readings of lights and centre, then the second ones: the order of the
        // camera noise draws of the plant before the check, so the ideal plant's runs stay
        // bit for bit what they were)
        let lights_fn = |p: &mut Plant| p.gripper_lights_filled(&mut Default::default()).0;
        let centre_fn = |p: &mut Plant| p.gripper_centre_filled(&mut Default::default()).0;
        let lights = lights_fn(plant);
        let lights_true = plant.observe_gripper_lights_true();
        let centre = centre_fn(plant);
        let centre_true = plant.observe_gripper_centre_true();
        if lights.to_vector::<8>().is_none() || centre.to_vector::<4>().is_none() {
            return None;
        }
        let mut lights = (lights, lights_fn(plant));
        let mut centre = (centre, centre_fn(plant));
        plant.until_agreeing(&mut lights, lights_fn);
        plant.until_agreeing(&mut centre, centre_fn);
        let (Some(v), Some(v_true), Some(c), Some(c_true)) = (
            lights.0.to_vector(),
            lights_true.to_vector(),
            centre.0.to_vector(),
            centre_true.to_vector(),
        ) else {
            return None;
        };
        let noise_v = second_reading(lights.1, &v);
        let noise_c = second_reading(centre.1, &c);
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
            // a grasp no arm of this make can hold (a joint beyond its range) is no target
            if !plant.grasp_reachable(&cyl) {
                return None;
            }
            let (cyl_c, cyl_c2) = plant.capture_twice_checked(Plant::observe_cylinder_centre);
            let (Some(cc), Some(cc_true)) = (
                cyl_c.to_vector(),
                plant.observe_cylinder_centre_true().to_vector(),
            ) else {
                return None;
            };
            t.c = cc;
            t.c_true = cc_true;
            t.noise_c = second_reading(cyl_c2, &cc);
            t.cylinder = Some(cyl);
        }
        Some(t)
    }
}
