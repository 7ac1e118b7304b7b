//! Life-long learning (issue 17): why grasps collapsed under wear, the shortened scenario
//! that fails if they collapse again, and checkpoints that continue a run exactly.

use std::path::Path;

use rand_core::SeedableRng;
use rand_xoshiro::Xoshiro256PlusPlus;
use trn_bench::schedule::Plan;
use trn_bench::targets::HeldOut;
use trn_bench::{run, sim_state, Command, LabError, Report, RunSpec};
use trn_plant::{Plant, SimConfig};
use trn_studies::lifelong::{self, LifelongSpec, ARMS};

/// A folder of the test's own, named after it, removed when the test ends, passed or failed.
fn scratch(name: &str) -> tempfile::TempDir {
    tempfile::Builder::new()
        .prefix(&format!("trn-lifelong-{name}-"))
        .tempdir()
        .expect("a temporary folder")
}

/// Wears `plant` by `moves` random moves over the whole pressure range.
fn wear(plant: &mut Plant, moves: usize) {
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(9);
    for _ in 0..moves {
        let p = plant.random_pressures(&mut rng).map(|x| x * 1.25);
        plant.command(&p);
        plant.settle();
    }
}

/// Of `n` held-out targets drawn on the new arm, the fraction the worn arm's twin can no
/// longer realise (a light out of view, an unreachable grasp).
fn lost_after_wear(cfg: &SimConfig, moves: usize, n: usize, grasp: bool) -> f32 {
    let mut plant = Plant::new(cfg, 4).unwrap();
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(5);
    let set = HeldOut::set(&plant, &mut rng, n, grasp).unwrap();
    wear(&mut plant, moves);
    let lost = set
        .iter()
        .filter(|h| h.realise(&plant, grasp).is_err())
        .count();
    lost as f32 / n as f32
}

/// The first cause of the collapse, reproduced: the old wear (linear in travel, down to half
/// the gain) shrinks the arm's reach so far that after 12,000 random moves (fewer than a
/// 2,000-trial run makes) nearly all held-out grasps drawn on the new arm cannot be realised
/// any more (the "target not visible from the twin arm" failures of the issue: 93 % here);
/// the bounded wear of the `aging` plant (5 % of the gain, 0.5 degrees) keeps nearly all of
/// them (2 % lost).
#[test]
fn unbounded_wear_takes_the_targets_out_of_reach_bounded_wear_does_not() {
    let mut old = SimConfig::aging();
    old.drift.temperature = false;
    old.drift.wear_gain_max = 0.5;
    old.drift.wear_offset_max_deg = 1.0e6;
    let mut bounded = SimConfig::aging();
    bounded.drift.temperature = false;
    let moves = 12_000;
    let lost_old = lost_after_wear(&old, moves, 60, true);
    let lost_bounded = lost_after_wear(&bounded, moves, 60, true);
    println!("grasps lost after {moves} moves: old wear {lost_old}, bounded {lost_bounded}");
    assert!(lost_old > 0.5, "old wear lost only {lost_old}");
    assert!(lost_bounded < 0.1, "bounded wear lost {lost_bounded}");
}

/// The second cause (under any wear): a cylinder placed 40 mm ahead of a pose near the edge
/// of the workspace can need a shoulder or an elbow beyond its stop. Such grasps are not
/// held-out targets any more (`Plant::grasp_reachable`); checked against the plant itself:
/// a servo on the true gripper centre that moves base, shoulder and elbow within their
/// target ranges reaches the cylinder when the check says it can, and stays off when the
/// check says it cannot.
#[test]
fn the_reachability_check_agrees_with_a_servo_on_the_plant() {
    let cfg = SimConfig::ideal();
    let mut plant = Plant::new(&cfg, 11).unwrap();
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(12);
    let (mut agree, mut unreachable, mut total) = (0, 0, 0);
    while total < 40 {
        let p = plant.random_pressures(&mut rng);
        plant.command(&p);
        plant.settle();
        let cyl = plant.place_cylinder();
        let verdict = plant.grasp_reachable(&cyl);
        unreachable += !verdict as usize;
        total += 1;
        // Newton steps on the pressures of joints 0..3 with finite differences on the plant
        let mut q = p;
        let centre = |pl: &mut Plant, q: &[f32; 5]| {
            pl.command(q);
            pl.settle();
            pl.gripper_pose().centre_mm
        };
        let mut best = f64::MAX;
        for _ in 0..12 {
            let c = centre(&mut plant, &q);
            let r: Vec<f64> = (0..3).map(|i| cyl.centre[i] - c[i]).collect();
            best = best.min(r.iter().map(|x| x * x).sum::<f64>().sqrt());
            let mut jac = nalgebra::Matrix3::<f64>::zeros();
            for k in 0..3 {
                let mut qk = q;
                qk[k] += if qk[k] > 0.0 { -0.02 } else { 0.02 };
                let ck = centre(&mut plant, &qk);
                for row in 0..3 {
                    jac[(row, k)] = (ck[row] - c[row]) / (qk[k] - q[k]) as f64;
                }
            }
            let Some(dq) = jac.lu().solve(&nalgebra::Vector3::new(r[0], r[1], r[2])) else {
                break;
            };
            for k in 0..3 {
                let lim = cfg.joints[k].target_limit as f32;
                q[k] = (q[k] + dq[k] as f32).clamp(-lim, lim);
            }
        }
        let reached = best <= cfg.grasp_distance_mm / 3.0;
        agree += (reached == verdict) as usize;
        plant.set_cylinder(None);
    }
    println!("{agree} of {total} verdicts agree with the servo; {unreachable} unreachable");
    assert!(
        unreachable >= 2,
        "too few unreachable grasps to test: {unreachable}"
    );
    assert!(agree >= total - 2, "{agree} of {total} agree");
}

fn lifelong_args(out: &Path) -> LifelongSpec {
    LifelongSpec {
        seed: 5,
        trials: 1000,
        initial: 250,
        snapshot_every: 250,
        snapshot_targets: 30,
        snapshot_grasps: 20,
        config: "aging".into(),
        only: vec!["lifelong".into()],
        out: out.to_path_buf(),
    }
}

/// The scenario, shortened: the lifelong preset on the aging plant for 1,000 trials. Fails
/// if grasps collapse again (below 90 % at any snapshot after the initial training) or the
/// error leaves the noise floor's neighbourhood (above 1.6x after the budget: with 30
/// targets one hard target near the workspace's edge moves a snapshot by 0.3x).
#[test]
fn grasps_keep_working_under_drift_and_wear() {
    let dir_scratch = scratch("scenario");
    let a = lifelong_args(dir_scratch.path());
    let arm = ARMS.iter().find(|a| a.key == "lifelong").unwrap();
    let r = run::run_quietly(&lifelong::arm_run(&a, arm).unwrap()).unwrap();
    let curve = lifelong::Curve {
        key: arm.key.into(),
        name: arm.name.into(),
        snapshots: r.learning_curve.clone(),
        failed_trials: r.failed_trials,
        wall_s: r.wall_s,
    };
    assert_eq!(curve.snapshots.len(), 4);
    for (p, (_, ratio)) in curve.snapshots.iter().zip(curve.ratios()) {
        println!(
            "after {}: {ratio:.2} x the floor, grasps {:.2} ({} unreachable) {:?}",
            p.trial, p.grasp_success, p.grasps_unreachable, p.grasp_failures
        );
        assert_eq!(p.grasps, 20);
    }
    let (ratio, grasp) = curve.worst_after(a.initial);
    assert!(grasp >= 0.9, "grasps fell to {grasp}");
    assert!(ratio <= 1.6, "error {ratio} x the floor");
}

/// `--only` takes the scenario's keys and refuses anything else.
#[test]
fn unknown_controllers_are_refused() {
    assert_eq!(
        lifelong::select(&["broyden".into()]).unwrap()[0].key,
        "broyden"
    );
    assert!(lifelong::select(&["frozen".into(), "bogus".into()]).is_err());
}

/// More initial trials than trials is refused before anything runs or is written.
#[test]
fn more_initial_trials_than_trials_is_a_config_error() {
    let out = std::env::temp_dir().join(format!("trn-lifelong-{}-refused", std::process::id()));
    let a = LifelongSpec {
        initial: 1001,
        ..lifelong_args(&out)
    };
    match a.study() {
        Err(LabError::Usage(m)) => assert!(m.contains("--initial 1001"), "{m}"),
        other => panic!("expected a configuration error, got {other:?}"),
    }
    assert!(!out.exists(), "a refused run created {}", out.display());
}

/// A run on the aging plant with `trials` training trials, a snapshot every 30.
fn spec(checkpoint_run: bool, trials: usize) -> RunSpec {
    let seed = if checkpoint_run { 3 } else { 4 };
    let mut s = RunSpec::new(Command::Train, seed)
        .with_plant(Some("aging"))
        .unwrap();
    s.plan = Plan {
        snapshot_every: 30,
        snapshot_targets: 10,
        ..Plan::new(trials, 10, 3)
    };
    s
}

/// `spec` writing its checkpoint to `out`.
fn saving(mut s: RunSpec, out: &Path) -> RunSpec {
    s.outputs.checkpoint = Some(out.to_path_buf());
    s
}

/// `spec` continuing from the checkpoint `from` (`--continue` when `resume`).
fn from(mut s: RunSpec, from: &Path, resume: bool) -> RunSpec {
    s.checkpoint_in = Some(from.to_path_buf());
    s.plan.resume = resume;
    s
}

fn curve(r: &Report) -> Vec<(usize, Vec<u32>)> {
    r.learning_curve
        .iter()
        .map(|p| {
            (
                p.trial,
                p.combined_true_px.iter().map(|x| x.to_bits()).collect(),
            )
        })
        .collect()
}

/// A run interrupted after 60 trials and continued from its checkpoint (`--continue`) gives
/// the curve of one that ran 120 trials without stopping, bit for bit: the snapshots and
/// the training trials' errors; the continued run's report holds the whole curve and counts
/// the network's 120 trials.
#[test]
fn an_interrupted_run_continues_bit_for_bit() {
    let dir_scratch = scratch("continue");
    let dir = dir_scratch.path();
    let ck = dir.join("c");
    let whole = run::run_quietly(&spec(true, 120)).unwrap();
    let first = run::run_quietly(&saving(spec(true, 60), &ck)).unwrap();
    assert!(sim_state::path_beside(&ck).exists());
    let second = run::run_quietly(&from(spec(true, 60), &ck, true)).unwrap();
    assert_eq!(curve(&second), curve(&whole));
    assert_eq!(curve(&first), curve(&whole)[..curve(&first).len()]);
    let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(&second.stage1_error_px), bits(&whole.stage1_error_px));
    assert_eq!((second.trials, second.trials_this_run), (120, 60));
}

/// Without `--continue` a checkpoint still continues its schedule: no second priming, the
/// snapshots numbered on from the trials it learned.
#[test]
fn a_checkpoint_continues_its_schedule() {
    let dir_scratch = scratch("schedule");
    let dir = dir_scratch.path();
    let ck = dir.join("c");
    run::run_quietly(&saving(spec(false, 60), &ck)).unwrap();
    let r = run::run_quietly(&from(spec(false, 30), &ck, false)).unwrap();
    let trials: Vec<usize> = r.learning_curve.iter().map(|p| p.trial).collect();
    assert_eq!(trials, vec![90]);
    assert_eq!(r.trials, 90, "the network's trials in all");
}

/// A checkpoint trained on one plant is refused on another (its `.sim` says which), unless
/// the change is allowed.
#[test]
fn a_checkpoint_of_another_plant_is_refused() {
    let dir_scratch = scratch("plant");
    let dir = dir_scratch.path();
    let ck = dir.join("c");
    run::run_quietly(&saving(spec(false, 5), &ck)).unwrap();
    let mut s = from(spec(false, 5), &ck, false)
        .with_plant(Some("realistic"))
        .unwrap();
    let e = run::run_quietly(&s).unwrap_err().to_string();
    assert!(
        e.contains("another plant") && e.contains("--allow-config-change"),
        "{e}"
    );
    s.allow_config_change = true;
    run::run_quietly(&s).unwrap();
}

/// A simulator checkpoint is refused, with the file named, when it does not belong to the
/// controller checkpoint beside it, is corrupt, or is missing.
#[test]
fn a_mismatched_corrupt_or_missing_simulator_checkpoint_is_refused() {
    let dir_scratch = scratch("refuse");
    let dir = dir_scratch.path();
    let (a, b) = (dir.join("a"), dir.join("b"));
    run::run_quietly(&saving(spec(false, 31), &a)).unwrap();
    run::run_quietly(&saving(spec(false, 30), &b)).unwrap();
    let err = |ck: &Path| {
        run::run_quietly(&from(spec(false, 5), ck, true))
            .unwrap_err()
            .to_string()
    };
    // b's simulator state beside a's checkpoint
    std::fs::copy(sim_state::path_beside(&b), sim_state::path_beside(&a)).unwrap();
    let e = err(&a);
    assert!(
        e.contains("another controller checkpoint") && e.contains("a.sim"),
        "{e}"
    );
    // a flipped bit
    let p = sim_state::path_beside(&b);
    let mut bytes = std::fs::read(&p).unwrap();
    let n = bytes.len() / 2;
    bytes[n] ^= 1;
    std::fs::write(&p, bytes).unwrap();
    let e = err(&b);
    assert!(e.contains("CRC") && e.contains("b.sim"), "{e}");
    // none
    std::fs::remove_file(&p).unwrap();
    assert!(err(&b).contains("b.sim"));
}
