//! The oracle (`--controller oracle`): solving on an exact copy of the plant, its coarse
//! move lands where only the noise of the move and of the cameras leaves it, on the
//! realistic plant, and it rarely needs a fine move. Fails when the oracle's copy is not
//! the plant's state (its hysteresis history, drift, wear) or its solve stops short.

use trn_bench::schedule::Plan;
use trn_bench::spec::ControllerChoice;
use trn_bench::{run, Command, RunSpec};

#[test]
fn the_oracle_lands_its_coarse_move_at_the_noise() {
    let mut spec = RunSpec::new(Command::Train, 7);
    spec.profile.law = ControllerChoice::Oracle;
    spec.plan = Plan {
        snapshot_every: 0,
        ..Plan::new(0, 12, 4)
    };
    let r = run::run_quietly(&spec).unwrap();
    let d = &r.deployment;
    println!(
        "oracle: coarse {:.2} px (worst {:.2}), measured {:.2} px, floor {:.2}, stop rule {:.2} fine moves, grasps {:.0} %",
        d.combined_true_px[0],
        d.combined_true_max_px[0],
        d.combined_measured_px[0],
        d.noise_floor_px,
        r.fine_moves_mean,
        100.0 * r.grasp_success_rate
    );
    // the target itself carries the camera noise (0.3 px per coordinate): the noise-free
    // error of a perfect move is about that noise over the 12 coordinates, ~1 px
    assert!(d.combined_true_px[0] < 1.5, "{:?}", d.combined_true_px);
    assert!(
        d.combined_true_max_px[0] < 3.0,
        "{:?}",
        d.combined_true_max_px
    );
    assert!(d.combined_measured_px[0] < 1.2 * d.noise_floor_px);
    assert!(r.fine_moves_mean < 0.5, "{}", r.fine_moves_mean);
    // a light hidden from a camera (the realistic plant's occlusion) is no failure of the
    // controller's; nothing else may fail
    assert!(
        r.failures.iter().all(|f| f.cause.starts_with("lost light")),
        "{:?}",
        r.failures
    );
}

/// The oracle needs the plant in its process: on any other bus, or with checkpoints, it is
/// refused before anything runs.
#[test]
fn the_oracle_runs_in_process_only() {
    let mut spec = RunSpec::new(Command::Train, 7);
    spec.profile.law = ControllerChoice::Oracle;
    spec.bus.spec = trn_transport::BusSpec::SlcanQemu;
    let e = spec.check().unwrap_err().to_string();
    assert!(e.contains("oracle") && e.contains("in process only"), "{e}");
}
