//! The Broyden servo baseline behind the same state machine as the TRN: the controller
//! tests of `state_machine.rs` (typed errors for bad input, the cap, the fixed budget, the
//! grasp's two stages) under `Law::Broyden` (built with the feature `broyden`, a default).
#![cfg(feature = "broyden")]

use trn_controller::{
    Command, Config, Controller, Error, FineMoves, Law, Observation, ObserveKind, Outcome, Task,
};

fn ctrl() -> Box<Controller> {
    let cfg = Config {
        law: Law::Broyden,
        ..Config::project_default()
    };
    let mut c = Box::new(Controller::new(cfg));
    c.init_random(3);
    c
}

const V: [f32; 8] = [300.0, 200.0, 310.0, 210.0, 320.0, 220.0, 330.0, 230.0];
const C: [f32; 4] = [300.0, 200.0, 310.0, 210.0];

/// A linear arm: 5 pressures to 8 lights, the first 3 to the centre.
fn lights(p: &[f32; 5]) -> [f32; 8] {
    core::array::from_fn(|i| V[i] + 120.0 * p[i % 5] + 30.0 * p[(i + 2) % 5])
}

fn centre(p: &[f32; 5]) -> [f32; 4] {
    core::array::from_fn(|i| C[i] + 100.0 * p[i % 3] - 25.0 * p[(i + 1) % 3])
}

/// Runs a task against the linear arm.
fn run(c: &mut Controller, task: Task, fine: FineMoves) -> Outcome {
    let mut cmd = c.begin_with(task, fine).unwrap();
    loop {
        match cmd {
            Command::Move {
                pressures, observe, ..
            } => {
                let obs = match observe {
                    ObserveKind::Lights => Observation::Lights(lights(&pressures)),
                    ObserveKind::Centre => Observation::Centre(centre(&pressures)),
                };
                cmd = c.observe(obs).unwrap();
            }
            Command::Done(o) => return o,
        }
    }
}

#[test]
fn bad_input_is_a_typed_error_and_the_trial_goes_on() {
    let mut c = ctrl();
    assert_eq!(
        c.observe(Observation::Lights(V)),
        Err(Error::UnexpectedObservation)
    );
    let mut nan = V;
    nan[1] = f32::NAN;
    let stage1 = |v| Task::Stage1 {
        v,
        supervised: None,
        learn: true,
    };
    assert_eq!(
        c.begin(stage1(nan)),
        Err(Error::NonFiniteInput { index: 1 })
    );
    assert_eq!(
        c.begin(Task::Grasp {
            v: V,
            c: [f32::NAN; 4],
            learn: false
        }),
        Err(Error::NonFiniteInput { index: 0 })
    );
    assert!(!c.busy(), "a rejected target starts nothing");
    c.begin(stage1(V)).unwrap();
    assert_eq!(
        c.observe(Observation::Lights(nan)),
        Err(Error::NonFiniteInput { index: 1 })
    );
    let mut far = V;
    far[7] = 1.0e7;
    assert!(matches!(
        c.observe(Observation::Lights(far)),
        Err(Error::InputOutOfRange { index: 7, .. })
    ));
    assert_eq!(
        c.observe(Observation::Centre(C)),
        Err(Error::WrongObservationKind)
    );
    assert_eq!(c.begin(stage1(V)), Err(Error::Busy));
    assert!(c.observe(Observation::Lights(lights(&[0.0; 5]))).is_ok());
}

#[test]
fn a_stuck_arm_hits_the_cap_and_reports_it() {
    let mut c = ctrl();
    let mut cmd = c
        .begin(Task::Stage1 {
            v: V,
            supervised: None,
            learn: false,
        })
        .unwrap();
    let stuck = [100.0; 8];
    let o = loop {
        match cmd {
            Command::Move { .. } => cmd = c.observe(Observation::Lights(stuck)).unwrap(),
            Command::Done(o) => break o.stage1.unwrap(),
        }
    };
    assert!(o.cap_hit);
    assert_eq!(o.fine_moves, c.config().broyden.max_fine_moves);
}

#[test]
fn it_servos_to_the_tolerance_and_a_budget_is_exact() {
    let mut c = ctrl();
    let target = lights(&[0.3, -0.2, 0.5, 0.1, -0.4]);
    let task = Task::Stage1 {
        v: target,
        supervised: None,
        learn: false,
    };
    let first = run(&mut c, task, FineMoves::Policy).stage1.unwrap();
    assert!(
        !first.cap_hit && first.final_error <= first.tolerance,
        "{first:?}"
    );
    assert!(c.broyden1().home_jacobian().is_some());
    let o = run(&mut c, task, FineMoves::Exactly(3)).stage1.unwrap();
    assert_eq!(o.fine_moves, 3);
    // a linear arm: the measured Jacobian is exact; the step limit (0.4) splits the way
    // (0.5 on joint 2) into two moves, the second lands within a pixel
    assert!(o.trace[1] > o.trace[2] && o.trace[2] < 1.0, "{o:?}");
}

#[test]
fn a_grasp_runs_both_stages_and_closes_the_gripper() {
    let mut c = ctrl();
    let p = [0.2, 0.1, -0.3, 0.4, 0.0];
    let o = run(
        &mut c,
        Task::Grasp {
            v: lights(&p),
            c: centre(&p),
            learn: false,
        },
        FineMoves::Exactly(6),
    );
    assert!(o.close_gripper);
    assert!(o.stage1.unwrap().final_error < 1.0, "{o:?}");
    assert!(o.stage2.unwrap().final_error < 1.0, "{o:?}");
    assert_eq!(o.stage2.unwrap().fine_moves, 6);
}
