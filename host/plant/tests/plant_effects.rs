//! The real arm's effects beyond the ideal plant (`[realism]` in sim.toml), each measured
//! the way the issue asks: coupling as a cross-joint change, creep as the change between
//! the 1.2 s reading and rest, outlier and dropout rates against the configured values,
//! hysteresis branches that differ by more than an offset, and bounded wear.

use trn_plant::joint::{Joint, JointEffects};
use trn_plant::{Plant, PointStatus, SimConfig};

fn ideal() -> SimConfig {
    SimConfig::default()
}

/// Joint angles (degrees) after `p` was commanded and the arm rested `seconds`.
fn rest(plant: &mut Plant, p: &[f32; 5], seconds: f64) -> [f64; 5] {
    plant.command(p);
    plant.advance(seconds);
    plant.joint_angles().map(f64::to_degrees)
}

#[test]
fn gravity_couples_the_shoulder_to_the_elbow() {
    let mut cfg = ideal();
    cfg.realism.sag_shoulder_deg = 3.0;
    cfg.realism.sag_elbow_deg = 2.0;
    let shoulder_change = |cfg: &SimConfig| {
        let mut plant = Plant::new(cfg, 1).unwrap();
        let a = rest(&mut plant, &[0.0, 0.2, -0.6, 0.0, 0.0], 5.0)[1];
        // only the elbow's pressure changes; the shoulder's hysteresis history is the same
        let b = rest(&mut plant, &[0.0, 0.2, 0.6, 0.0, 0.0], 5.0)[1];
        b - a
    };
    let coupled = shoulder_change(&cfg);
    let independent = shoulder_change(&ideal());
    println!("shoulder moves {coupled:.3} deg with the elbow (ideal: {independent:.6})");
    // (the ideal arm's joints are independent: what is left is the dynamics' residue)
    assert!(independent.abs() < 1e-3, "{independent}");
    assert!(coupled.abs() > 0.2, "{coupled}");
}

#[test]
fn creep_moves_the_reading_after_the_settle_time() {
    let mut cfg = ideal();
    cfg.realism.creep_fraction = 0.05;
    cfg.realism.creep_tau_s = 4.0;
    let late_change = |cfg: &SimConfig| {
        let mut plant = Plant::new(cfg, 1).unwrap();
        rest(&mut plant, &[0.0, -0.5, 0.0, 0.0, 0.0], 60.0);
        let at_settle = rest(&mut plant, &[0.0, 0.5, 0.0, 0.0, 0.0], cfg.settle_s)[1];
        let at_rest = rest(&mut plant, &[0.0, 0.5, 0.0, 0.0, 0.0], 60.0)[1];
        (at_rest - at_settle, at_rest)
    };
    let (creep, at_rest) = late_change(&cfg);
    let (none, _) = late_change(&ideal());
    // the step moved the shoulder by about 28 deg: 5 % of it, decayed over 1.2 s of 4 s
    let expected = 0.05 * 28.0 * (-1.2f64 / 4.0).exp();
    println!("change after the settle time {creep:.3} deg (expected about {expected:.2} + the ideal arm's {none:.4} of residual oscillation); rest {at_rest:.2}");
    assert!(none.abs() < 0.15, "{none}");
    let extra = creep - none;
    assert!(extra > 0.5 * expected && extra < 1.5 * expected, "{extra}");
}

#[test]
fn outliers_and_dropouts_come_at_their_configured_rates() {
    let mut cfg = ideal();
    cfg.realism.outlier_rate = 0.02;
    cfg.realism.dropout_rate = 0.03;
    let mut plant = Plant::new(&cfg, 7).unwrap();
    rest(&mut plant, &[0.0, 0.3, 0.0, 0.0, 0.0], 3.0);
    let truth = plant.observe_gripper_lights_true();
    let (mut outliers, mut dropouts, n) = (0, 0, 20_000);
    for _ in 0..n / 4 {
        let r = plant.observe_gripper_lights();
        for (p, t) in r.points.iter().zip(truth.points.iter()) {
            match p.status {
                PointStatus::NotDetected => dropouts += 1,
                PointStatus::Valid if (p.x - t.x).hypot(p.y - t.y) > 10.0 => outliers += 1,
                _ => {}
            }
        }
    }
    let rate = |k: i32| k as f64 / n as f64;
    println!(
        "outliers {:.4} (0.02 x 0.97 not dropped), dropouts {:.4}",
        rate(outliers),
        rate(dropouts)
    );
    // binomial: 3 standard deviations of n = 20,000 draws; an outlier that lands within
    // 10 px of the truth is not counted (about 1e-3 of them)
    let within = |got: f64, p: f64| (got - p).abs() < 3.0 * (p * (1.0 - p) / n as f64).sqrt();
    assert!(within(rate(dropouts), 0.03), "{}", rate(dropouts));
    assert!(within(rate(outliers), 0.02 * 0.97), "{}", rate(outliers));
}

/// The camera processor's stereo check and new frames (plant::stereo): at ten times the
/// realistic fault rates, a checked capture reports almost no outlier (one that lies near
/// the epipolar line by chance, about one in a hundred) and almost no dropout (four frames
/// in a row), at the cost of a few extra frames. Without the check the same readings carry
/// the configured rates (the test above).
#[test]
fn the_stereo_check_rejects_outliers_and_recovers_dropouts() {
    let mut cfg = ideal();
    cfg.realism.outlier_rate = 0.02;
    cfg.realism.dropout_rate = 0.05;
    let mut plant = Plant::new(&cfg, 8).unwrap();
    rest(&mut plant, &[0.1, 0.3, -0.2, 0.1, 0.0], 3.0);
    let truth = plant.observe_gripper_lights_true();
    let (mut outliers, mut lost, mut frames, n) = (0, 0, 0, 20_000);
    for _ in 0..n / 4 {
        let (r, extra) = plant.capture_checked(Plant::observe_gripper_lights);
        frames += 1 + extra;
        for (p, t) in r.points.iter().zip(truth.points.iter()) {
            match p.status {
                PointStatus::NotDetected => lost += 1,
                PointStatus::Valid if (p.x - t.x).hypot(p.y - t.y) > 10.0 => outliers += 1,
                _ => {}
            }
        }
    }
    println!(
        "checked: outliers {outliers}, not detected {lost} of {n} readings, {:.3} frames per capture",
        frames as f64 / (n / 4) as f64
    );
    // unchecked, about 390 outliers and 1000 dropouts would be expected
    assert!(outliers <= 20, "{outliers}");
    // (a light bad in four frames in a row: about 3e-4 of them, 6 readings expected)
    assert!(lost <= 16, "{lost}");
    assert!(frames < (n / 4) * 13 / 10, "{frames}");
}

/// The camera processor fills in a gripper light hidden from a camera (the hand, the
/// cylinder in front of the pre-grasp pose) from the rigid marker body fitted to the lights
/// it sees, as valid only where those readings determine it: on the realistic plant at
/// pre-grasp poses, with nothing tracked (a trial's first capture), every valid reading lies
/// within the stereo check's tolerance (1 px + 6 sigma = 2.8 px) of where the light
/// projects, filled in or not. Where two mirror bodies explain the readings (the hidden
/// light's two candidates tens of pixels apart), it is estimated, not filled in: the
/// lowest-cost body of the two was the wrong one on these poses, 57 px off, and was
/// reported valid before.
#[test]
fn hidden_gripper_lights_are_filled_in_only_where_the_markers_seen_determine_them() {
    use rand_core::SeedableRng;
    let cfg = SimConfig::realistic();
    let mut plant = Plant::new(&cfg, 3).unwrap();
    let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(4);
    let (mut poses, mut hidden, mut usable, mut filled, mut estimated) = (0, 0, 0, 0, 0);
    let (mut worst, mut worst_estimate) = (0.0f64, 0.0f64);
    while poses < 150 {
        let p = plant.random_pressures(&mut rng);
        plant.command(&p);
        plant.settle();
        let cyl = plant.place_cylinder();
        if !plant.grasp_reachable(&cyl) {
            plant.set_cylinder(None);
            continue;
        }
        poses += 1;
        let truth = plant.observe_gripper_lights_true();
        let plain = plant.observe_gripper_lights();
        hidden += plain
            .points
            .iter()
            .any(|p| p.status == PointStatus::Occluded) as usize;
        // a trial's first capture: nothing tracked
        let (r, fill) = plant.gripper_lights_filled(&mut Default::default());
        filled += fill.filled;
        estimated += fill.estimated;
        usable += r.reported_vector::<8>().is_some() as usize;
        for (a, t) in r.points.iter().zip(truth.points.iter()) {
            let off = (a.x - t.x).hypot(a.y - t.y);
            match a.status {
                PointStatus::Valid => worst = worst.max(off),
                PointStatus::Estimated => worst_estimate = worst_estimate.max(off),
                _ => {}
            }
        }
        plant.set_cylinder(None);
    }
    println!("{poses} pre-grasp poses: a light hidden in {hidden}, {filled} readings filled in, {estimated} estimated (worst {worst_estimate:.1} px), {usable} usable, worst valid error {worst:.2} px");
    assert!(
        hidden >= poses / 5,
        "too few hidden lights to test: {hidden}"
    );
    assert!(usable >= poses * 95 / 100, "{usable} of {poses}");
    assert!(filled >= hidden / 3, "{filled}");
    assert!(
        estimated > 0,
        "no mirror bodies among the poses: the test lost its case"
    );
    let tolerance = trn_plant::stereo::tolerance_px(cfg.pixel_noise_px);
    assert!(worst < tolerance, "{worst} px against {tolerance}");
}

/// On the ideal plant the check never fires: the same readings, no extra frame, so every
/// figure measured before it stays bit for bit.
#[test]
fn the_stereo_check_changes_nothing_on_the_ideal_plant() {
    let mut a = Plant::new(&ideal(), 9).unwrap();
    rest(&mut a, &[0.2, 0.1, 0.3, -0.2, 0.1], 3.0);
    let mut b = a.clone();
    for _ in 0..2000 {
        let plain = a.observe_gripper_lights();
        let (checked, extra) = b.capture_checked(Plant::observe_gripper_lights);
        assert_eq!(extra, 0);
        assert_eq!(plain, checked);
    }
}

/// Fig. 8.2's loop, first increased then decreased. A uniform asymmetry moves the whole
/// loop by one constant (joint.rs shows it); with a skew the loop differs from the symmetric
/// one by more than any constant: its branches change shape.
#[test]
fn skewed_branches_differ_by_more_than_an_offset() {
    let loop_of = |asym: f64, skew: f64| {
        let mut cfg = ideal().joints[1].clone();
        cfg.hysteresis_asymmetry = asym;
        let mut j = Joint::new(&cfg);
        j.effects = JointEffects {
            skew,
            ..JointEffects::NONE
        };
        let mut sweep = |from: f64, to: f64| -> Vec<f64> {
            (0..=100)
                .map(|i| {
                    j.settle_at(from + (to - from) * i as f64 / 100.0);
                    j.angle_deg()
                })
                .collect()
        };
        sweep(0.0, -1.0);
        let mut pts = sweep(-1.0, 1.0);
        pts.extend(sweep(1.0, -1.0));
        pts
    };
    let symmetric = loop_of(0.0, 0.0);
    // away from the ends (the tanh's saturation), on both branches: the spread of the
    // difference to the symmetric loop is 0 for a loop that is only moved
    let spread = |other: &[f64]| {
        let d: Vec<f64> = symmetric
            .iter()
            .zip(other)
            .enumerate()
            .filter(|(i, _)| (30..71).contains(i) || (131..172).contains(i))
            .map(|(_, (a, b))| b - a)
            .collect();
        d.iter().cloned().fold(f64::MIN, f64::max) - d.iter().cloned().fold(f64::MAX, f64::min)
    };
    let (shifted, skewed) = (spread(&loop_of(0.3, 0.0)), spread(&loop_of(0.3, 0.4)));
    println!(
        "not explained by an offset: shifted loop {shifted:.3} deg, skewed loop {skewed:.3} deg"
    );
    assert!(shifted < 0.3, "{shifted}");
    assert!(skewed > 1.0, "{skewed}");
}

#[test]
fn wear_is_bounded() {
    let mut cfg = ideal();
    cfg.drift.wear = true;
    cfg.drift.wear_gain_per_rad = 1e-3;
    cfg.drift.wear_gain_max = 0.05;
    cfg.drift.wear_offset_deg_per_rad = 0.05;
    cfg.drift.wear_offset_max_deg = 1.0;
    let mut plant = Plant::new(&cfg, 1).unwrap();
    let mut ideal_plant = Plant::new(&ideal(), 1).unwrap();
    // far beyond both bounds: hundreds of radians of travel
    for k in 0..200 {
        let p = if k % 2 == 0 { 0.7 } else { -0.7 };
        rest(&mut plant, &[0.0, p, 0.0, 0.0, 0.0], 1.5);
        rest(&mut ideal_plant, &[0.0, p, 0.0, 0.0, 0.0], 1.5);
    }
    let worn = rest(&mut plant, &[0.0, 0.3, 0.0, 0.0, 0.0], 5.0)[1];
    let fresh = rest(&mut ideal_plant, &[0.0, 0.3, 0.0, 0.0, 0.0], 5.0)[1];
    let travel = plant.joints()[1].travel;
    println!("travel {travel:.0} rad: worn {worn:.3} deg, fresh {fresh:.3} deg");
    assert!(
        travel * 1e-3 > 0.05 && travel * 0.05 > 1.0,
        "beyond both bounds"
    );
    // at most 5 % of the gain (of a 56 deg range around the middle) and 1 deg of offset
    assert!(
        (worn - fresh).abs() < 0.05 * 28.0 + 1.0 + 0.2,
        "{worn} vs {fresh}"
    );
}

#[test]
fn process_noise_varies_each_move() {
    let mut cfg = ideal();
    cfg.realism.process_noise_deg = 0.2;
    let mut plant = Plant::new(&cfg, 3).unwrap();
    let mut seen = vec![];
    for _ in 0..200 {
        rest(&mut plant, &[0.0, -0.4, 0.0, 0.0, 0.0], 3.0);
        seen.push(rest(&mut plant, &[0.0, 0.4, 0.0, 0.0, 0.0], 3.0)[1]);
    }
    let mean = seen.iter().sum::<f64>() / seen.len() as f64;
    let sd =
        (seen.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (seen.len() - 1) as f64).sqrt();
    println!("the same move 200 times: sd {sd:.3} deg (configured 0.2)");
    assert!(sd > 0.15 && sd < 0.25, "{sd}");
}

#[test]
fn the_named_configurations_load_and_differ() {
    let load_sim_config = SimConfig::resolve;
    let realistic = load_sim_config(Some(std::path::Path::new("realistic"))).unwrap();
    assert_eq!(realistic, SimConfig::realistic());
    assert_eq!(
        load_sim_config(Some(std::path::Path::new("ideal"))).unwrap(),
        SimConfig::ideal()
    );
    assert_ne!(realistic, SimConfig::ideal());
    assert!(Plant::new(&realistic, 1).is_ok());
    assert!(load_sim_config(Some(std::path::Path::new("no-such-plant"))).is_err());
    // every name loads, validates and is its own plant
    let all: Vec<SimConfig> = SimConfig::NAMES
        .iter()
        .map(|n| load_sim_config(Some(std::path::Path::new(n))).unwrap())
        .collect();
    for (i, c) in all.iter().enumerate() {
        c.validate().unwrap();
        assert!(
            all[..i].iter().all(|o| o != c),
            "{} repeats",
            SimConfig::NAMES[i]
        );
    }
    // the realistic plant growing old: the realistic plant with exactly the drift and wear
    // the aging configuration adds to the ideal one
    let old = SimConfig::named("realistic-aging").unwrap();
    assert_eq!(old.drift, SimConfig::aging().drift);
    assert_eq!(
        SimConfig {
            drift: realistic.drift.clone(),
            ..old.clone()
        },
        realistic
    );
    assert!(old.drift.temperature && old.drift.wear);
}
