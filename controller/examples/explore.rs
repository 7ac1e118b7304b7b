//! Explores the controller's tunables on the synthetic map of `tests/learning.rs`.
//! Every knob is an environment variable, e.g.
//! `JE=1 JL=1000 SIG=5 SIGS=50 SIGT=100 cargo run --release -p trn-controller --example explore`
//! (the figures in `Config::project_default`'s doc comment come from it).

#[path = "../tests/common/mod.rs"]
mod common;

use common::{plant, random_pressures, run};
use rand_core::SeedableRng;
use rand_xoshiro::Xoshiro256PlusPlus;
use trn_controller::{Config, Controller, Task};

fn env(k: &str, d: f32) -> f32 {
    std::env::var(k)
        .ok()
        .and_then(|s| s.parse().ok())
        .unwrap_or(d)
}
fn main() {
    use trn_controller::config::TimeDecay;
    let mut cfg = Config::project_default();
    cfg.stage1.init.x = (200.0, 440.0);
    cfg.stage1.init.y = (120.0, 360.0);
    cfg.stage1.tolerance.floor = env("TOLF", 0.05);
    cfg.stage1.mature_tolerance = 0.2;
    cfg.stage1.max_fine_moves = env("CAP", 8.0) as u8;
    cfg.stage1.j.eps = env("JE", 0.5);
    cfg.stage1.j.decay = TimeDecay::Exp {
        lambda: env("JL", 300.0),
    };
    cfg.stage1.w.eps = env("WE", 0.7);
    cfg.stage1.w.decay = TimeDecay::Exp {
        lambda: env("WL", 100.0),
    };
    cfg.stage1.p.decay = TimeDecay::Exp {
        lambda: env("PL", 100.0),
    };
    cfg.stage1.sigma = env("SIG", 5.0);
    cfg.stage1.sigma_start = env("SIGS", cfg.stage1.sigma);
    cfg.stage1.sigma_tau = env("SIGT", 100.0);
    let steps = env("STEPS", 400.0) as usize;
    let nsup = env("NSUP", 50.0) as usize;
    let mut ctrl = Box::new(Controller::new(cfg));
    ctrl.init_random(1);
    let mut rng = Xoshiro256PlusPlus::seed_from_u64(2);
    let mut moves = 0.0;
    for step in 0..steps {
        let p = random_pressures(&mut rng);
        let v = plant(&p);
        let supervised = if step < nsup { Some(p) } else { None };
        let o = run(
            &mut ctrl,
            Task::Stage1 {
                v,
                supervised,
                learn: true,
            },
        )
        .stage1
        .unwrap();
        moves += o.fine_moves as f32;
        if (step + 1) % 100 == 0 {
            println!(
                "step {} coarse {:.1} final {:.2} moves/step {:.2}",
                step + 1,
                o.coarse_error,
                o.final_error,
                moves / 100.0
            );
            moves = 0.0;
        }
    }
    let mut c2 = *ctrl.config();
    c2.stage1.max_fine_moves = 3;
    ctrl.set_config(c2).unwrap();
    let mut fresh = Xoshiro256PlusPlus::seed_from_u64(1234);
    let (mut sf, mut sc, mut sm) = (0.0, 0.0, 0.0);
    let mut tr = [0.0f32; 4];
    for _ in 0..200 {
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
        sf += o.final_error;
        sc += o.coarse_error;
        sm += o.fine_moves as f32;
        for (i, x) in tr.iter_mut().enumerate() {
            *x += if i <= o.fine_moves as usize {
                o.trace[i]
            } else {
                o.final_error
            };
        }
    }
    println!(
        "EVAL coarse {:.2} final {:.3} moves {:.2} trace {:?}",
        sc / 200.0,
        sf / 200.0,
        sm / 200.0,
        tr.map(|x| x / 200.0)
    );
}
