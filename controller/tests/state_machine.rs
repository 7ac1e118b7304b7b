//! The learning step as a state machine: its order of moves, and bad input.

use trn_controller::{Command, Config, Controller, Error, Observation, ObserveKind, Task};

fn ctrl() -> Box<Controller> {
    let mut c = Box::new(Controller::new(Config::project_default()));
    c.init_random(3);
    c
}

const V: [f32; 8] = [300.0, 200.0, 310.0, 210.0, 320.0, 220.0, 330.0, 230.0];
const C: [f32; 4] = [300.0, 200.0, 310.0, 210.0];

fn snapshot(c: &Controller) -> (trn_controller::Stage1Net, trn_controller::Stage2Net) {
    (c.stage1().net().clone(), c.stage2().net().clone())
}

#[test]
fn bad_observations_are_typed_errors_and_change_nothing() {
    let mut c = ctrl();
    assert_eq!(
        c.observe(Observation::Lights(V)),
        Err(Error::UnexpectedObservation)
    );
    let cmd = c
        .begin(Task::Stage1 {
            v: V,
            supervised: None,
            learn: true,
        })
        .unwrap();
    assert!(matches!(
        cmd,
        Command::Move {
            joints: 5,
            observe: ObserveKind::Lights,
            ..
        }
    ));
    let before = snapshot(&c);
    let mut nan = V;
    nan[3] = f32::NAN;
    assert_eq!(
        c.observe(Observation::Lights(nan)),
        Err(Error::NonFiniteInput { index: 3 })
    );
    let mut inf = V;
    inf[0] = f32::INFINITY;
    assert_eq!(
        c.observe(Observation::Lights(inf)),
        Err(Error::NonFiniteInput { index: 0 })
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
    assert_eq!(
        c.begin(Task::Stage2 { c: C, learn: true }),
        Err(Error::Busy)
    );
    assert!(snapshot(&c) == before, "rejected input touched the tables");
    // the trial goes on with a valid observation
    assert!(c.observe(Observation::Lights(V)).is_ok());
}

#[test]
fn bad_targets_are_rejected_before_any_update() {
    let mut c = ctrl();
    let before = snapshot(&c);
    let mut nan = V;
    nan[1] = f32::NAN;
    assert_eq!(
        c.begin(Task::Stage1 {
            v: nan,
            supervised: None,
            learn: true
        }),
        Err(Error::NonFiniteInput { index: 1 })
    );
    assert_eq!(
        c.begin(Task::Stage1 {
            v: V,
            supervised: Some([0.0, 2.0, 0.0, 0.0, 0.0]),
            learn: true
        }),
        Err(Error::InvalidPressure { index: 1 })
    );
    assert_eq!(
        c.begin(Task::Grasp {
            v: V,
            c: [f32::NAN; 4],
            learn: false
        }),
        Err(Error::NonFiniteInput { index: 0 })
    );
    let mut cfg = *c.config();
    cfg.stage1.max_target_distance = 10.0;
    c.set_config(cfg).unwrap();
    let far = [5000.0; 8];
    assert!(matches!(
        c.begin(Task::Stage1 {
            v: far,
            supervised: None,
            learn: false
        }),
        Err(Error::TargetOutsideLearnedRegion { .. })
    ));
    assert!(snapshot(&c) == before);
    assert!(!c.busy());
}

#[test]
fn zero_length_dv_is_skipped_and_counted() {
    let mut c = ctrl();
    c.begin(Task::Stage1 {
        v: V,
        supervised: None,
        learn: true,
    })
    .unwrap();
    // an arm that does not move at all: every dv is zero
    let stuck = [100.0; 8];
    let mut n = 0;
    let outcome = loop {
        match c.observe(Observation::Lights(stuck)).unwrap() {
            Command::Move { .. } => n += 1,
            Command::Done(o) => break o.stage1.unwrap(),
        }
    };
    assert!(outcome.cap_hit, "the cap on fine moves must be reported");
    assert_eq!(outcome.fine_moves, c.config().stage1.max_fine_moves);
    assert_eq!(n, outcome.fine_moves as usize);
    assert_eq!(outcome.skipped_updates, outcome.fine_moves);
    assert!(c.stage1().net().is_finite());
}

#[test]
fn mature_operation_does_not_learn_and_grasp_closes_the_gripper() {
    let mut c = ctrl();
    let before = snapshot(&c);
    let mut cmd = c
        .begin(Task::Grasp {
            v: V,
            c: C,
            learn: false,
        })
        .unwrap();
    let mut stage2_moves = 0;
    let outcome = loop {
        match cmd {
            Command::Move {
                observe: ObserveKind::Lights,
                joints,
                ..
            } => {
                assert_eq!(joints, 5);
                cmd = c.observe(Observation::Lights(V)).unwrap();
            }
            Command::Move {
                observe: ObserveKind::Centre,
                joints,
                pressures,
            } => {
                assert_eq!(joints, 3);
                assert!(pressures.iter().all(|p| p.abs() <= 1.0));
                stage2_moves += 1;
                cmd = c.observe(Observation::Centre(C)).unwrap();
            }
            Command::Done(o) => break o,
        }
    };
    assert!(outcome.close_gripper);
    assert_eq!(outcome.stage1.unwrap().final_error, 0.0);
    assert_eq!(
        stage2_moves, 1,
        "on target after the coarse move: no fine move when mature"
    );
    assert!(
        snapshot(&c) == before,
        "mature operation changed the tables"
    );
    assert_eq!(c.stage1().learning_step(), 0);
}

#[test]
fn learning_steps_count_and_the_tolerance_schedule_applies() {
    let mut c = Box::new(Controller::new(Config::paper()));
    c.init_random(4);
    for t in 1..=3u32 {
        let mut cmd = c.begin(Task::Stage2 { c: C, learn: true }).unwrap();
        let o = loop {
            match cmd {
                Command::Move { .. } => cmd = c.observe(Observation::Centre(C)).unwrap(),
                Command::Done(o) => break o.stage2.unwrap(),
            }
        };
        assert_eq!(o.t, t);
        assert!((o.tolerance - (0.1 + 100.0 * (-(t as f32) / 120.0).exp())).abs() < 1e-3);
        // while learning, at least one fine move is made (substeps 7-9 always run)
        assert_eq!(o.fine_moves, 1);
    }
    assert_eq!(c.stage2().learning_step(), 3);
}

/// The evaluation's fixed move budget: exactly `n` fine moves, even when every reading is
/// on target (the controller's rule would stop at once), for a grasp's two stages too.
#[test]
fn a_fixed_budget_makes_exactly_its_fine_moves() {
    use trn_controller::FineMoves;
    let count = |c: &mut Controller, task: Task, fine: FineMoves| -> (u8, Option<u8>) {
        let mut cmd = c.begin_with(task, fine).unwrap();
        loop {
            match cmd {
                Command::Move { observe, .. } => {
                    let obs = match observe {
                        ObserveKind::Lights => Observation::Lights(V),
                        ObserveKind::Centre => Observation::Centre(C),
                    };
                    cmd = c.observe(obs).unwrap();
                }
                Command::Done(o) => {
                    let s1 = o.stage1.map(|s| s.fine_moves).unwrap_or(0);
                    return (s1, o.stage2.map(|s| s.fine_moves));
                }
            }
        }
    };
    let mut c = ctrl();
    let stage1 = Task::Stage1 {
        v: V,
        supervised: None,
        learn: false,
    };
    assert_eq!(
        count(&mut c, stage1, FineMoves::Policy).0,
        0,
        "on target: stops"
    );
    assert_eq!(count(&mut c, stage1, FineMoves::Exactly(4)).0, 4);
    assert_eq!(count(&mut c, stage1, FineMoves::Exactly(0)).0, 0);
    let grasp = Task::Grasp {
        v: V,
        c: C,
        learn: false,
    };
    assert_eq!(count(&mut c, grasp, FineMoves::Exactly(3)), (3, Some(3)));
    assert_eq!(
        c.begin_with(stage1, FineMoves::Exactly(32)),
        Err(Error::FineMoveBudget)
    );
    assert!(!c.busy(), "a rejected budget starts nothing");
}
