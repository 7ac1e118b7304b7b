//! Where targets come from and what a record scores, each rule on its own: held-out sets
//! fixed by the seed and realised on a twin without touching the arm; errors by move from
//! the captures; the combined error; by-move means that keep a trial's last error.

use rand_core::SeedableRng;
use rand_xoshiro::Xoshiro256PlusPlus;
use trn_bench::metrics::by_move_means;
use trn_bench::records::{Phase, TrialKind, TrialRecord};
use trn_bench::scoring::{self, combined};
use trn_bench::targets::{self, HeldOut, Target};
use trn_plant::nodes::{Capture, Sight};
use trn_plant::{PixelReading, Plant, PointStatus, Pose, Readings, SimConfig};

fn plant() -> Plant {
    Plant::new(&SimConfig::realistic(), 11).unwrap()
}

/// The same seed draws the same held-out set; every target of it is seen from a twin;
/// realising one does not move the evaluated arm, and realises the same target twice on a
/// plant that did not change. Fails when held-out targets depend on the arm's history or a
/// twin shares the arm's state.
#[test]
fn held_out_sets_are_fixed_by_the_seed_and_realised_on_a_twin() {
    let p = plant();
    let set = |seed| {
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
        HeldOut::set(&p, &mut rng, 5, false).unwrap()
    };
    assert_eq!(set(3), set(3));
    assert_ne!(set(3), set(4));
    let before = p.joint_angles();
    for h in set(3) {
        let a = h.realise(&p, false).unwrap();
        let b = h.realise(&p, false).unwrap();
        assert_eq!(a, b, "the same target twice");
        assert!(a.v.iter().all(|x| x.is_finite()) && a.c.iter().all(|x| x.is_finite()));
        assert!(a.noise_v > 0.0, "a second reading gives the floor");
    }
    assert_eq!(p.joint_angles(), before, "the evaluated arm did not move");
}

/// A held-out grasp's target is a cylinder the twin can hold from its pre-grasp pose (with
/// the wrist as it is there), and its target `c` is the cylinder's centre, not the
/// gripper's.
#[test]
fn held_out_grasps_have_a_reachable_cylinder() {
    let p = plant();
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(5);
    for h in HeldOut::set(&p, &mut rng, 4, true).unwrap() {
        let t = h.realise(&p, true).unwrap();
        let cyl = t.cylinder.expect("a grasp has its cylinder");
        let mut twin = p.twin(h.noise_seed);
        for q in &h.path {
            twin.command(q);
            twin.settle();
        }
        twin.command(&h.pressures);
        twin.settle();
        assert!(twin.grasp_reachable(&cyl));
        twin.set_cylinder(Some(cyl));
        let centre = twin
            .observe_cylinder_centre_true()
            .to_vector::<4>()
            .unwrap();
        assert_eq!(centre, t.c_true);
    }
}

/// The paper's target: the arm itself visits random pressures and is read there; the target
/// keeps those pressures (sent only in priming) and its noise-free lights are where the
/// arm was.
#[test]
fn visit_and_return_reads_the_arm_where_it_went() {
    let mut p = plant();
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(8);
    let t = targets::visit_and_return(&mut p, &mut rng, false).unwrap();
    let seen = p.observe_gripper_lights_true().to_vector::<8>().unwrap();
    assert_eq!(seen, t.v_true, "read at the pose it reached");
    assert!(t.pressures.iter().all(|x| (-1.0..=1.0).contains(x)));
}

fn reading(v: &[f32]) -> PixelReading {
    PixelReading {
        x: v[0] as f64,
        y: v[1] as f64,
        status: PointStatus::Valid,
    }
}

fn lights(v: [f32; 8]) -> Readings<4> {
    Readings {
        points: core::array::from_fn(|i| reading(&v[2 * i..])),
    }
}

fn capture(noisy: [f32; 8], truth: [f32; 8]) -> Capture {
    Capture {
        seq: 1,
        sight: Sight::Lights {
            noisy: lights(noisy),
            truth: lights(truth),
        },
        pose: Pose::NONE,
        time_s: 1.2,
        fill: Default::default(),
    }
}

/// The errors after each move are the distances of each capture to the target, measured
/// against measured and truth against truth; the combined error is the norm over both
/// networks' coordinates.
#[test]
fn a_record_scores_each_move_against_its_target() {
    let target = Target {
        v: [100.0; 8],
        v_true: [101.0; 8],
        noise_v: 0.5,
        ..Target::NONE
    };
    let rec = TrialRecord {
        trial: 1,
        kind: TrialKind::Stage1 {
            supervised: false,
            learn: false,
        },
        phase: Phase::Deployment,
        fine_moves: 1,
        target,
        target_seen: true,
        captures: vec![
            capture([103.0; 8], [104.0; 8]), // 3 px off per coordinate
            capture([100.5; 8], [101.0; 8]),
        ],
        reports: vec![],
        errors: vec![],
        aborted: false,
        gave_up: false,
        grasp: None,
        started_s: 0.0,
    };
    let s = scoring::stage1(&rec).unwrap();
    let root8 = 8f32.sqrt();
    assert_eq!(s.errors_px, vec![3.0 * root8, 0.5 * root8]);
    assert_eq!(s.errors_true_px, vec![3.0 * root8, 0.0]);
    assert_eq!((s.fine_moves(), s.noise_floor_px), (1, 0.5));
    assert!(
        scoring::stage2(&rec).is_none(),
        "a stage-1 trial has no stage 2"
    );
    assert_eq!(combined(3.0, 4.0), 5.0);
}

/// By-move means: a trial that stopped early keeps its last error for the later moves.
#[test]
fn a_trial_that_stopped_keeps_its_last_error_in_the_means() {
    let m = by_move_means(&[vec![10.0, 4.0], vec![8.0, 2.0, 1.0]]);
    assert_eq!(m, vec![9.0, 3.0, 2.5]);
}
