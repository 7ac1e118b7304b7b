use super::*;
use crate::vec3::{add, cross, scale, sub, unit};
use crate::{kinematics, SimConfig};
use rand_core::SeedableRng;
use rand_xoshiro::Xoshiro256PlusPlus;

/// The gripper's lights p, q and c.
fn gripper_lights(plant: &Plant) -> Vec<V3> {
    let pose = plant.gripper_pose();
    let [p, q] = kinematics::lights(plant.config(), &pose);
    vec![p, q, pose.centre_mm]
}

/// Over random poses of the realistic plant with a cylinder placed: what the pixels say of
/// each light in each camera, against the geometry (projection and `hidden_by`).
struct Tally {
    clear_valid: usize,
    clear: usize,
    hidden_refused: usize,
    hidden: usize,
    worst_error_px: f64,
}

fn tally(protocol: &CaptureProtocol, poses: usize) -> Tally {
    let mut plant = Plant::new(&SimConfig::realistic(), 3).unwrap();
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(5);
    let v = PixelVision::default();
    let mut t = Tally {
        clear_valid: 0,
        clear: 0,
        hidden_refused: 0,
        hidden: 0,
        worst_error_px: 0.0,
    };
    for n in 0..poses {
        plant.move_to_random_joints(&mut rng, 1);
        plant.place_cylinder();
        let lights = gripper_lights(&plant);
        let chain = plant.chain();
        for cam in 0..2 {
            let read = plant
                .read_by_pixels(cam, &lights, protocol, &v, n as u64)
                .unwrap();
            let proj: Vec<Option<(f64, f64)>> = lights
                .iter()
                .map(|p| plant.cameras[cam].project(p))
                .collect();
            for (i, (r, p)) in read.iter().zip(&proj).enumerate() {
                let Some((u, w)) = p else {
                    assert_eq!(r.status, PointStatus::OutOfView);
                    continue;
                };
                // lights closer on the image than the gate's double cannot be told apart
                let crowded = proj.iter().enumerate().any(|(j, o)| {
                    j != i && o.is_some_and(|(a, b)| (a - u).hypot(b - w) < 4.0 * v.gate_px)
                });
                if plant.hidden_by(cam, &lights[i], &chain).is_some() {
                    t.hidden += 1;
                    t.hidden_refused += (r.status != PointStatus::Valid) as usize;
                } else if !crowded {
                    t.clear += 1;
                    if r.status == PointStatus::Valid {
                        t.clear_valid += 1;
                        t.worst_error_px = t.worst_error_px.max((r.x - u).hypot(r.y - w));
                    }
                }
            }
        }
    }
    t
}

#[test]
fn pixels_read_the_lights_where_the_geometry_projects_them() {
    let t = tally(&CaptureProtocol::constant_weight(3, 3, 2).unwrap(), 40);
    assert_eq!(t.hidden, t.hidden_refused);
    // most captures have two lights closer than twice the gate in one camera or the other
    // (the gripper's lights foreshortened): those are refused, as the protocol says
    assert!(t.clear >= 50, "{}", t.clear);
    assert!(
        t.clear_valid as f64 >= 0.95 * t.clear as f64,
        "{} of {}",
        t.clear_valid,
        t.clear
    );
    assert!(t.worst_error_px < 0.5, "{}", t.worst_error_px);
}

#[test]
fn a_light_behind_a_link_is_refused_and_one_beside_it_read() {
    let mut plant = Plant::new(&SimConfig::realistic(), 3).unwrap();
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(8);
    let v = PixelVision::default();
    let one = CaptureProtocol::sequential(1).unwrap();
    let r = plant.config().link_radius_mm;
    let (mut behind_tried, mut beside_tried) = (0, 0);
    for n in 0..20 {
        plant.move_to_random_joints(&mut rng, 1);
        let chain = plant.chain();
        let mid = scale(&add(&chain.elbow, &chain.wrist), 0.5);
        for cam in 0..2 {
            let eye = plant.cameras[cam].position();
            let ray = unit(&sub(&mid, &eye));
            // 60 mm behind the forearm's axis, on the camera's ray through it
            let behind = add(&mid, &scale(&ray, 2.0 * r + 60.0));
            if plant.cameras[cam].project(&behind).is_some()
                && plant.hidden_by(cam, &behind, &chain).is_some()
            {
                behind_tried += 1;
                let read = plant.read_by_pixels(cam, &[behind], &one, &v, n).unwrap();
                assert_eq!(
                    read[0].status,
                    PointStatus::NotDetected,
                    "pose {n}, camera {cam}"
                );
            }
            // the same distance behind, but 3 radii aside across the forearm
            let across = unit(&cross(&ray, &sub(&chain.wrist, &chain.elbow)));
            let beside = add(&behind, &scale(&across, 3.0 * r));
            if let Some((u, w)) = plant.cameras[cam].project(&beside) {
                if plant.hidden_by(cam, &beside, &chain).is_none() {
                    beside_tried += 1;
                    let read = plant.read_by_pixels(cam, &[beside], &one, &v, n).unwrap();
                    assert_eq!(read[0].status, PointStatus::Valid, "pose {n}, camera {cam}");
                    assert!((read[0].x - u).hypot(read[0].y - w) < 0.2);
                }
            }
        }
    }
    assert!(
        behind_tried >= 10 && beside_tried >= 10,
        "{behind_tried} {beside_tried}"
    );
}
