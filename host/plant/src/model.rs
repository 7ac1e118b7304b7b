//! The arm as a robot description the field's tools read: URDF ([`urdf`]) and MuJoCo's MJCF
//! ([`mjcf`]), written from a configuration's lengths and joint ranges.
//!
//! Both hold the same chain ([`chain`]), in metres and radians:
//!
//! | joint         | parent → child               | axis (parent frame) | origin           |
//! |---------------|------------------------------|---------------------|------------------|
//! | `base`        | `base_link` → `turntable`    | +z                  | 0                |
//! | `shoulder`    | `turntable` → `upper_arm`    | −y                  | shoulder height z|
//! | `elbow`       | `upper_arm` → `forearm`      | −y                  | upper arm x      |
//! | `wrist_pitch` | `forearm` → `wrist`          | −y                  | forearm x        |
//! | `wrist_roll`  | `wrist` → `hand`             | +x                  | 0                |
//!
//! and fixed frames `gripper_centre` (hand length along the hand's x), `light_p` and
//! `light_q` (`light_offset_mm` either way along the centre's z). At zero angles the arm
//! points along the base's x; a positive shoulder, elbow or wrist pitch raises it. The
//! `gripper_centre` frame's axes are the plant's [`Pose`](crate::Pose): x the approach, y
//! the finger axis, z the normal.
//!
//! The SoftArm's wrist is differential ([`crate::kinematics`]): its joints A and B (the
//! plant's joints 3 and 4) turn the gripper about both axes, pitch = (A + B) / 2 and
//! roll = (A − B) / 2. A URDF joint moves about one axis, so the descriptions have the
//! gripper's own axes `wrist_pitch` and `wrist_roll`; [`description_angles`] maps the
//! plant's five angles onto them. Joint limits are the ranges the configuration gives (the
//! angles at the extreme pressures); the wrist's follow from A's and B's. Overshoot, sag
//! and drift can take an angle a little beyond them.
//!
//! The masses are nominal (the relative weights of the plant's gravity model, upper arm 1,
//! forearm 0.8, hand 0.7, taken as kilograms, each a uniform rod): the plant has no rigid-body
//! dynamics, only its kinematics are the plant's.

use std::fmt::Write;

use crate::config::SimConfig;

/// One joint of the description: a revolute joint, or a fixed frame (`axis` `None`).
#[derive(Debug, Clone, PartialEq)]
pub struct ChainJoint {
    /// The joint's name.
    pub name: &'static str,
    /// The parent link.
    pub parent: &'static str,
    /// The child link (the frame it moves).
    pub child: &'static str,
    /// The child frame's origin in the parent frame at zero angle (m).
    pub origin_m: [f64; 3],
    /// The rotation axis in the parent frame (a unit vector); `None` for a fixed frame.
    pub axis: Option<[f64; 3]>,
    /// Lower and upper limits (rad); (0, 0) for a fixed frame.
    pub limits_rad: (f64, f64),
}

/// Relative masses of the upper arm, the forearm and the hand (the plant's gravity model).
const MASSES: [f64; 3] = [1.0, 0.8, 0.7];

/// The description's joints from the base out, with the three fixed frames last.
pub fn chain(cfg: &SimConfig) -> Vec<ChainJoint> {
    let mm = |x: f64| x / 1000.0;
    let range = |i: usize| -> (f64, f64) {
        cfg.joints.get(i).map_or((0.0, 0.0), |j| {
            (
                j.min_deg.min(j.max_deg).to_radians(),
                j.min_deg.max(j.max_deg).to_radians(),
            )
        })
    };
    let (a, b) = (range(3), range(4));
    let y_down = [0.0, -1.0, 0.0];
    let fixed = |name, parent, origin_m| ChainJoint {
        name,
        parent,
        child: name,
        origin_m,
        axis: None,
        limits_rad: (0.0, 0.0),
    };
    let revolute = |name, parent, child, origin_m, axis, limits_rad| ChainJoint {
        name,
        parent,
        child,
        origin_m,
        axis: Some(axis),
        limits_rad,
    };
    let (x, z) = ([1.0, 0.0, 0.0], [0.0, 0.0, 1.0]);
    vec![
        revolute("base", "base_link", "turntable", [0.0; 3], z, range(0)),
        revolute(
            "shoulder",
            "turntable",
            "upper_arm",
            [0.0, 0.0, mm(cfg.shoulder_height_mm)],
            y_down,
            range(1),
        ),
        revolute(
            "elbow",
            "upper_arm",
            "forearm",
            [mm(cfg.upper_arm_mm), 0.0, 0.0],
            y_down,
            range(2),
        ),
        revolute(
            "wrist_pitch",
            "forearm",
            "wrist",
            [mm(cfg.forearm_mm), 0.0, 0.0],
            y_down,
            (0.5 * (a.0 + b.0), 0.5 * (a.1 + b.1)),
        ),
        revolute(
            "wrist_roll",
            "wrist",
            "hand",
            [0.0; 3],
            x,
            (0.5 * (a.0 - b.1), 0.5 * (a.1 - b.0)),
        ),
        fixed("gripper_centre", "hand", [mm(cfg.hand_mm), 0.0, 0.0]),
        fixed(
            "light_p",
            "gripper_centre",
            [0.0, 0.0, mm(cfg.light_offset_mm)],
        ),
        fixed(
            "light_q",
            "gripper_centre",
            [0.0, 0.0, -mm(cfg.light_offset_mm)],
        ),
    ]
}

/// The description's joint angles (base, shoulder, elbow, wrist_pitch, wrist_roll) for the
/// plant's five joint angles (base, shoulder, elbow, wrist A, wrist B), in the same unit.
pub fn description_angles(q: &[f64; 5]) -> [f64; 5] {
    [q[0], q[1], q[2], 0.5 * (q[3] + q[4]), 0.5 * (q[3] - q[4])]
}

/// A link's body: a rod from its origin along x (`length_m`, radius `radius_m`), or none.
struct Rod {
    link: &'static str,
    length_m: f64,
    mass_kg: f64,
    /// Along z (the base's pillar) instead of x.
    vertical: bool,
}

fn rods(cfg: &SimConfig) -> [Rod; 4] {
    let mm = |x: f64| x / 1000.0;
    [
        Rod {
            link: "turntable",
            length_m: mm(cfg.shoulder_height_mm),
            mass_kg: 0.0,
            vertical: true,
        },
        Rod {
            link: "upper_arm",
            length_m: mm(cfg.upper_arm_mm),
            mass_kg: MASSES[0],
            vertical: false,
        },
        Rod {
            link: "forearm",
            length_m: mm(cfg.forearm_mm),
            mass_kg: MASSES[1],
            vertical: false,
        },
        Rod {
            link: "hand",
            length_m: mm(cfg.hand_mm),
            mass_kg: MASSES[2],
            vertical: false,
        },
    ]
}

/// A number as the descriptions write it: the shortest text that reads back as the same
/// double.
fn num(x: f64) -> String {
    // `{}` of an f64 is the shortest round-trip form; -0 as 0
    if x == 0.0 {
        "0".into()
    } else {
        format!("{x}")
    }
}

fn vec3(v: &[f64; 3]) -> String {
    format!("{} {} {}", num(v[0]), num(v[1]), num(v[2]))
}

/// The arm as URDF (metres, radians), with the LEDs' frames as fixed links. A `<mujoco>`
/// element asks MuJoCo's loader to keep those frames as bodies (`fusestatic="false"`);
/// other readers ignore it.
pub fn urdf(cfg: &SimConfig) -> String {
    let r = cfg.link_radius_mm / 1000.0;
    let mut s = String::new();
    // `write!` to a String cannot fail
    let _ = writeln!(s, "<?xml version=\"1.0\"?>");
    let _ = writeln!(
        s,
        "<!-- The SoftArm of the TRN project, from its plant configuration. The differential \
         wrist's joints A and B are wrist_pitch = (A + B) / 2, wrist_roll = (A - B) / 2. -->"
    );
    let _ = writeln!(s, "<robot name=\"softarm\">");
    let _ = writeln!(
        s,
        "  <mujoco>\n    <compiler fusestatic=\"false\" discardvisual=\"false\" \
         balanceinertia=\"true\"/>\n  </mujoco>"
    );
    let _ = writeln!(
        s,
        "  <material name=\"arm\"><color rgba=\"0.95 0.55 0.1 1\"/></material>"
    );
    let _ = writeln!(
        s,
        "  <material name=\"led\"><color rgba=\"0.2 1 0.2 1\"/></material>"
    );
    let _ = writeln!(s, "  <link name=\"base_link\"/>");
    for rod in rods(cfg) {
        let (centre, rpy) = if rod.vertical {
            ([0.0, 0.0, 0.5 * rod.length_m], [0.0; 3])
        } else {
            (
                [0.5 * rod.length_m, 0.0, 0.0],
                [0.0, std::f64::consts::FRAC_PI_2, 0.0],
            )
        };
        let _ = writeln!(s, "  <link name=\"{}\">", rod.link);
        let _ = writeln!(
            s,
            "    <visual>\n      <origin xyz=\"{}\" rpy=\"{}\"/>\n      <geometry><cylinder \
             radius=\"{}\" length=\"{}\"/></geometry>\n      <material name=\"arm\"/>\n    </visual>",
            vec3(&centre),
            vec3(&rpy),
            num(r),
            num(rod.length_m)
        );
        let (m, l) = (rod.mass_kg.max(0.1), rod.length_m);
        let across = m * (3.0 * r * r + l * l) / 12.0;
        let along = 0.5 * m * r * r;
        let (ixx, izz) = if rod.vertical {
            (across, along)
        } else {
            (along, across)
        };
        let _ = writeln!(
            s,
            "    <inertial>\n      <origin xyz=\"{}\"/>\n      <mass value=\"{}\"/>\n      \
             <inertia ixx=\"{}\" ixy=\"0\" ixz=\"0\" iyy=\"{}\" iyz=\"0\" izz=\"{}\"/>\n    \
             </inertial>",
            vec3(&centre),
            num(m),
            num(ixx),
            num(across),
            num(izz)
        );
        let _ = writeln!(s, "  </link>");
    }
    // the wrist between its two joints: a small sphere
    let _ = writeln!(
        s,
        "  <link name=\"wrist\">\n    <inertial>\n      <mass value=\"0.01\"/>\n      \
         <inertia ixx=\"1e-6\" ixy=\"0\" ixz=\"0\" iyy=\"1e-6\" iyz=\"0\" izz=\"1e-6\"/>\n    \
         </inertial>\n  </link>"
    );
    for name in ["gripper_centre", "light_p", "light_q"] {
        let _ = writeln!(s, "  <link name=\"{name}\">");
        if name != "gripper_centre" {
            let _ = writeln!(
                s,
                "    <visual>\n      <geometry><sphere radius=\"0.008\"/></geometry>\n      \
                 <material name=\"led\"/>\n    </visual>"
            );
        }
        let _ = writeln!(s, "  </link>");
    }
    for j in chain(cfg) {
        let kind = if j.axis.is_some() {
            "revolute"
        } else {
            "fixed"
        };
        let _ = writeln!(s, "  <joint name=\"{}\" type=\"{kind}\">", j.name);
        let _ = writeln!(
            s,
            "    <parent link=\"{}\"/>\n    <child link=\"{}\"/>\n    <origin xyz=\"{}\" rpy=\"0 0 0\"/>",
            j.parent,
            j.child,
            vec3(&j.origin_m)
        );
        if let Some(axis) = j.axis {
            let _ = writeln!(
                s,
                "    <axis xyz=\"{}\"/>\n    <limit lower=\"{}\" upper=\"{}\" effort=\"100\" velocity=\"3\"/>",
                vec3(&axis),
                num(j.limits_rad.0),
                num(j.limits_rad.1)
            );
        }
        let _ = writeln!(s, "  </joint>");
    }
    let _ = writeln!(s, "</robot>");
    s
}

/// The arm as MuJoCo's MJCF (metres, radians): the same chain as bodies with hinge joints,
/// the gripper centre and the LEDs as sites, the two cameras (their pose and vertical field
/// of view; MuJoCo's pinhole has no lens distortion) and a floor. No geometry collides (the
/// plant has no contacts: its links and hand only hide lights from the cameras).
pub fn mjcf(cfg: &SimConfig) -> String {
    let r = cfg.link_radius_mm / 1000.0;
    let joints = chain(cfg);
    let mut s = String::new();
    let _ = writeln!(
        s,
        "<!-- The SoftArm of the TRN project, from its plant configuration. The differential \
         wrist's joints A and B are wrist_pitch = (A + B) / 2, wrist_roll = (A - B) / 2. -->"
    );
    let _ = writeln!(s, "<mujoco model=\"softarm\">");
    let _ = writeln!(s, "  <compiler angle=\"radian\" autolimits=\"true\"/>");
    let _ = writeln!(
        s,
        "  <default>\n    <geom rgba=\"0.95 0.55 0.1 1\" density=\"300\" contype=\"0\" conaffinity=\"0\"/>\n  </default>"
    );
    let _ = writeln!(s, "  <worldbody>");
    let _ = writeln!(
        s,
        "    <light pos=\"0 0 3\" dir=\"0 0 -1\"/>\n    <geom name=\"floor\" type=\"plane\" \
         size=\"2 2 0.05\" rgba=\"0.8 0.8 0.8 1\"/>"
    );
    for (i, cam) in cfg.cameras.iter().enumerate() {
        let c = crate::camera::Camera::new(cam);
        let (right, down) = c.image_axes();
        let up = -down;
        let fovy = 2.0 * (0.5 * cam.resolution[1] as f64 / cam.focal_px).atan();
        let pos = cam.position_mm.map(|x| x / 1000.0);
        let _ = writeln!(
            s,
            "    <camera name=\"camera_{i}\" pos=\"{}\" xyaxes=\"{} {}\" fovy=\"{}\" \
             resolution=\"{} {}\"/>",
            vec3(&pos),
            vec3(&right.into()),
            vec3(&up.into()),
            num(fovy.to_degrees()),
            cam.resolution[0],
            cam.resolution[1]
        );
    }
    let rods = rods(cfg);
    let mut depth = 2;
    let mut open = 0;
    for j in &joints {
        let pad = " ".repeat(2 * depth);
        match j.axis {
            Some(axis) => {
                let _ = writeln!(
                    s,
                    "{pad}<body name=\"{}\" pos=\"{}\">",
                    j.child,
                    vec3(&j.origin_m)
                );
                let _ = writeln!(
                    s,
                    "{pad}  <joint name=\"{}\" type=\"hinge\" axis=\"{}\" range=\"{} {}\"/>",
                    j.name,
                    vec3(&axis),
                    num(j.limits_rad.0),
                    num(j.limits_rad.1)
                );
                match rods.iter().find(|rod| rod.link == j.child) {
                    Some(rod) => {
                        let end = if rod.vertical {
                            [0.0, 0.0, rod.length_m]
                        } else {
                            [rod.length_m, 0.0, 0.0]
                        };
                        let _ = writeln!(
                            s,
                            "{pad}  <geom type=\"capsule\" fromto=\"0 0 0 {}\" size=\"{}\"/>",
                            vec3(&end),
                            num(r)
                        );
                    }
                    None => {
                        let _ = writeln!(
                            s,
                            "{pad}  <geom type=\"sphere\" size=\"{}\"/>",
                            num(0.9 * r)
                        );
                    }
                }
                depth += 1;
                open += 1;
            }
            None => {
                let origin = if j.parent == "gripper_centre" {
                    // the LEDs: relative to the gripper centre, which is a site in the hand
                    let c = joints
                        .iter()
                        .find(|k| k.name == "gripper_centre")
                        .map_or([0.0; 3], |k| k.origin_m);
                    [
                        c[0] + j.origin_m[0],
                        c[1] + j.origin_m[1],
                        c[2] + j.origin_m[2],
                    ]
                } else {
                    j.origin_m
                };
                let look = if j.name == "gripper_centre" {
                    "size=\"0.01\" rgba=\"1 1 1 1\""
                } else {
                    "size=\"0.008\" rgba=\"0.2 1 0.2 1\""
                };
                let _ = writeln!(
                    s,
                    "{pad}<site name=\"{}\" pos=\"{}\" {look}/>",
                    j.name,
                    vec3(&origin)
                );
            }
        }
    }
    for _ in 0..open {
        depth -= 1;
        let _ = writeln!(s, "{}</body>", " ".repeat(2 * depth));
    }
    let _ = writeln!(s, "  </worldbody>\n</mujoco>");
    s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kinematics::{forward, lights};
    use crate::random::uniform;
    use crate::Vector3;
    use rand_core::SeedableRng;

    /// A rotation by `angle` about the unit `axis` applied to `v` (Rodrigues).
    fn rotate(axis: &Vector3<f64>, angle: f64, v: &Vector3<f64>) -> Vector3<f64> {
        let (c, s) = (angle.cos(), angle.sin());
        v * c + axis.cross(v) * s + axis * axis.dot(v) * (1.0 - c)
    }

    /// Every frame's origin (mm) by composing the chain's joints: the chain as data, checked
    /// here against the plant; the XML written from it is checked by MuJoCo
    /// (python/tests/test_model.py).
    fn frames(cfg: &SimConfig, angles: &[f64; 5]) -> Vec<(&'static str, Vector3<f64>)> {
        // each link's origin and axes (columns) in the base frame
        let mut links = vec![(
            "base_link",
            Vector3::zeros(),
            [Vector3::x(), Vector3::y(), Vector3::z()],
        )];
        let mut k = 0;
        for j in chain(cfg) {
            let (_, o, r) = *links.iter().find(|l| l.0 == j.parent).expect("parent");
            let at = |v: &[f64; 3]| r[0] * v[0] + r[1] * v[1] + r[2] * v[2];
            let origin = o + at(&j.origin_m);
            let axes = match j.axis {
                Some(a) => {
                    let world_axis = at(&a);
                    let angle = angles[k];
                    k += 1;
                    r.map(|col| rotate(&world_axis, angle, &col))
                }
                None => r,
            };
            links.push((j.child, origin, axes));
        }
        links
            .into_iter()
            .map(|(n, o, _)| (n, o.map(|x| x * 1000.0)))
            .collect()
    }

    #[test]
    fn the_chain_is_the_plants_kinematics() {
        let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(39);
        for cfg in [SimConfig::ideal(), odd_config()] {
            for _ in 0..500 {
                let q: [f64; 5] = std::array::from_fn(|_| uniform(&mut rng, -1.6, 1.6));
                let c = forward(&cfg, &q);
                let [p, l_q] = lights(&cfg, &c.pose);
                let f = frames(&cfg, &description_angles(&q));
                let at = |n: &str| f.iter().find(|x| x.0 == n).expect("frame").1;
                for (name, want) in [
                    ("upper_arm", c.shoulder),
                    ("forearm", c.elbow),
                    ("wrist", c.wrist),
                    ("gripper_centre", c.pose.centre_mm),
                    ("light_p", p),
                    ("light_q", l_q),
                ] {
                    let err = (at(name) - want).norm();
                    assert!(err < 1e-9, "{name} off by {err} mm at {q:?}");
                }
            }
        }
    }

    /// A configuration whose lengths all differ from the default's (a length taken from the
    /// wrong key shows).
    fn odd_config() -> SimConfig {
        let mut c = SimConfig::ideal();
        c.shoulder_height_mm = 310.0;
        c.upper_arm_mm = 455.0;
        c.forearm_mm = 377.0;
        c.hand_mm = 123.0;
        c.light_offset_mm = 61.0;
        c.joints[3].min_deg = -30.0;
        c.joints[4].max_deg = 20.0;
        c
    }

    #[test]
    fn the_wrist_limits_follow_a_and_b() {
        let c = chain(&odd_config());
        let pitch = c.iter().find(|j| j.name == "wrist_pitch").expect("pitch");
        let roll = c.iter().find(|j| j.name == "wrist_roll").expect("roll");
        // A in [-30, 45], B in [-45, 20]
        let close = |a: f64, deg: f64| (a - deg.to_radians()).abs() < 1e-12;
        assert!(close(pitch.limits_rad.0, -37.5) && close(pitch.limits_rad.1, 32.5));
        assert!(close(roll.limits_rad.0, -25.0) && close(roll.limits_rad.1, 45.0));
    }

    #[test]
    fn the_descriptions_carry_the_configuration() {
        let cfg = odd_config();
        let (u, m) = (urdf(&cfg), mjcf(&cfg));
        for text in [&u, &m] {
            assert!(text.contains("\"0 0 0.31\""), "shoulder height");
            assert!(text.contains("\"0.455 0 0\""), "upper arm");
            assert!(text.contains("\"0.377 0 0\""), "forearm");
        }
        assert!(u.contains("\"0 0 0.061\"") && u.contains("\"0 0 -0.061\""));
        assert!(m.contains("\"0.123 0 0.061\"") && m.contains("\"0.123 0 -0.061\""));
        for name in ["base", "shoulder", "elbow", "wrist_pitch", "wrist_roll"] {
            assert!(u.contains(&format!("<joint name=\"{name}\" type=\"revolute\">")));
            assert!(m.contains(&format!("<joint name=\"{name}\" type=\"hinge\"")));
        }
        for name in ["gripper_centre", "light_p", "light_q"] {
            assert!(u.contains(&format!("<joint name=\"{name}\" type=\"fixed\">")));
            assert!(m.contains(&format!("<site name=\"{name}\"")));
        }
        assert_eq!(m.matches("<body").count(), m.matches("</body>").count());
        assert_eq!(u.matches("<link").count(), 9);
        assert_ne!(urdf(&SimConfig::ideal()), u);
    }
}
