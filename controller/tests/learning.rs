//! The controller learns a known smooth nonlinear map (no simulator): from random tables,
//! a few hundred learning steps, then fresh targets in mature operation.

mod common;

use common::{plant, random_pressures, run};
use rand_core::SeedableRng;
use rand_xoshiro::Xoshiro256PlusPlus;
use trn_controller::{Config, Controller, Task};

fn config() -> Config {
    let mut cfg = Config::project_default();
    cfg.stage1.init.x = (200.0, 440.0);
    cfg.stage1.init.y = (120.0, 360.0);
    cfg.stage1.tolerance.floor = 0.05;
    cfg.stage1.mature_tolerance = 0.2;
    cfg.stage1.max_fine_moves = 3;
    cfg
}

#[test]
fn learns_a_smooth_map_to_well_under_a_pixel() {
    let mut ctrl = Box::new(Controller::new(config()));
    ctrl.init_random(1);
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(2);
    for step in 0..400 {
        let p = random_pressures(&mut rng);
        let v = plant(&p);
        let supervised = if step < 50 { Some(p) } else { None };
        run(
            &mut ctrl,
            Task::Stage1 {
                v,
                supervised,
                learn: true,
            },
        );
    }
    // fresh targets, no learning
    let mut fresh = Xoshiro256PlusPlus::seed_from_u64(1234);
    let (mut sum_final, mut sum_coarse, mut sum_moves, mut worst) = (0.0, 0.0, 0.0, 0.0f32);
    let trials = 200;
    for _ in 0..trials {
        let v = plant(&random_pressures(&mut fresh));
        let o = run(
            &mut ctrl,
            Task::Stage1 {
                v,
                supervised: None,
                learn: false,
            },
        )
        .stage1
        .unwrap();
        assert!(!o.learned);
        sum_final += o.final_error;
        sum_coarse += o.coarse_error;
        sum_moves += o.fine_moves as f32;
        worst = worst.max(o.final_error);
        assert!(o.fine_moves <= 3);
    }
    let (mean_final, mean_coarse, mean_moves) = (
        sum_final / trials as f32,
        sum_coarse / trials as f32,
        sum_moves / trials as f32,
    );
    println!("coarse {mean_coarse:.2} px, final {mean_final:.3} px (worst {worst:.2}), fine moves {mean_moves:.2}");
    assert!(mean_final < 0.3, "mean final error {mean_final} px");
    assert!(mean_moves <= 3.0);
}

#[test]
fn same_seed_same_learning_curve() {
    let curve = |seed: u64| -> Vec<f32> {
        let mut ctrl = Box::new(Controller::new(config()));
        ctrl.init_random(seed);
        let mut rng = Xoshiro256PlusPlus::seed_from_u64(seed);
        (0..80)
            .map(|step| {
                let p = random_pressures(&mut rng);
                let supervised = if step < 20 { Some(p) } else { None };
                run(
                    &mut ctrl,
                    Task::Stage1 {
                        v: plant(&p),
                        supervised,
                        learn: true,
                    },
                )
                .stage1
                .unwrap()
                .final_error
            })
            .collect()
    };
    let a = curve(5);
    assert_eq!(a, curve(5));
    assert_ne!(a, curve(6));
}
