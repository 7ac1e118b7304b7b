//! Host-in-the-loop over the in-process bus: the controller node and the simulator's nodes
//! on one bus on a simulated clock, every message through CAN frames.

use std::rc::Rc;
use trn_bench::schedule::Plan;
use trn_bench::{run, Command, RunSpec};
use trn_transport::WallClock;

const PLAN: Plan = Plan::new(60, 5, 3);

fn run_plan(seed: u64, fd: bool, plan: Plan) -> trn_bench::Report {
    let mut spec = RunSpec::new(Command::Train, seed);
    spec.bus.fd = fd;
    spec.plan = plan;
    run::run_quietly(&spec).unwrap()
}

#[test]
fn same_seed_same_learning_curve_bit_for_bit() {
    let a = run_plan(7, false, PLAN);
    let b = run_plan(7, false, PLAN);
    let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    assert_eq!(a.stage1_error_px.len(), 60);
    assert_eq!(bits(&a.stage1_error_px), bits(&b.stage1_error_px));
    assert_eq!(bits(&a.stage2_error_px), bits(&b.stage2_error_px));
    assert_eq!(a.fine_moves, b.fine_moves);
    assert_eq!(a.final_error_px.to_bits(), b.final_error_px.to_bits());
    let c = run_plan(8, false, PLAN);
    assert_ne!(bits(&a.stage1_error_px), bits(&c.stage1_error_px));
}

#[test]
fn can_fd_carries_the_same_learning_curve_as_can_2_0() {
    let a = run_plan(3, false, PLAN);
    let b = run_plan(3, true, PLAN);
    assert_eq!(a.stage1_error_px, b.stage1_error_px);
    assert_eq!(a.stage2_error_px, b.stage2_error_px);
}

#[test]
fn training_learns_and_grasps_are_scored() {
    let r = run_plan(1, false, Plan::new(120, 10, 5));
    // Learning measured on frozen networks with a fixed move budget, not on end-of-trial
    // errors (those follow the tolerance schedule whether or not anything is learned):
    // fails when the tables do not learn.
    let coarse = |i: usize| r.learning_curve[i].combined_true_px[0];
    let after2 = |i: usize| r.learning_curve[i].combined_true_px[2];
    let last = r.learning_curve.len() - 1;
    assert_eq!(r.learning_curve.len(), 120 / 25);
    // without learning the frozen snapshots score the same targets alike (ratio 1); seed 1
    // learns to 0.82 in 120 trials (0.70 with the averages over 128 ranks; 10 targets per
    // snapshot are noisy at this stage: both reach the same error by 300 trials)
    assert!(
        coarse(last) < 0.9 * coarse(0),
        "the coarse move did not learn: {} -> {} px",
        coarse(0),
        coarse(last)
    );
    assert!(
        after2(last) < after2(0) / 2.0,
        "{} -> {} px",
        after2(0),
        after2(last)
    );
    // the fixed budget was made: 1 + 6 moves per trial
    assert_eq!(r.deployment.combined_true_px.len(), 7);
    // every grasp is a success or a failure with a cause
    let failed: usize = r.grasp.failure_causes.values().sum();
    let succeeded = (r.grasp_success_rate * 5.0).round() as usize;
    assert_eq!(succeeded + failed, 5, "{:?}", r.grasp.failure_causes);
}

#[test]
fn a_silent_bus_is_a_typed_error() {
    use std::time::Duration;
    use trn_bench::records::{Phase, TrialKind};
    use trn_bench::rig::Rig;
    use trn_bench::runner::Runner;
    use trn_bench::LabError as Error;
    use trn_plant::{Plant, SimConfig};
    use trn_protocol::bus::InProcBus;
    use trn_protocol::BusMode;
    // no controller on this bus
    let bus = InProcBus::new(BusMode::Classic, 1);
    let plant = Plant::new(&SimConfig::default(), 1).unwrap();
    let rig = Rig::new(
        bus.port(),
        Rc::new(WallClock::start()),
        plant,
        BusMode::Classic,
        Default::default(),
    );
    let timing =
        trn_bench::runner::Timing::new(Duration::from_millis(50), Duration::from_millis(200));
    let mut s = Runner::new(rig, 1, timing);
    let _other = bus.port();
    let e = s
        .run_trial(TrialKind::Stage2 { learn: true }, Phase::Training)
        .unwrap_err();
    assert!(matches!(e, Error::BusSilent(_)), "{e}");
    assert!(e.to_string().contains("bus silent"));
}

#[test]
fn servo_drives_that_lose_the_heartbeat_enter_the_safe_state_and_say_so() {
    use embedded_can::blocking::Can;
    use std::time::Duration;
    use trn_bench::records::{Phase, TrialKind};
    use trn_bench::rig::Rig;
    use trn_bench::runner::Runner;
    use trn_bench::LabError as Error;
    use trn_plant::{Plant, SimConfig};
    use trn_protocol::bus::{InProcBus, ReceiveTimeout};
    use trn_protocol::{
        BusMode, Encoder, Envelope, Heartbeat, Message, NodeId, NodeState, Reassembler,
        SafeStateAction, SafeStateReason,
    };
    let bus = InProcBus::new(BusMode::Classic, 1);
    let plant = Plant::new(&SimConfig::default(), 1).unwrap();
    let rig = Rig::new(
        bus.port(),
        Rc::new(WallClock::start()),
        plant,
        BusMode::Classic,
        Default::default(),
    );
    let timing =
        trn_bench::runner::Timing::new(Duration::from_millis(50), Duration::from_millis(1500));
    let mut s = Runner::new(rig, 1, timing);
    // a controller that sends one heartbeat, then dies
    let mut ctrl = bus.port();
    let hb = Envelope::new(
        NodeId::Controller,
        Heartbeat {
            counter: 0,
            state: NodeState::Operational,
        }
        .into(),
    );
    for f in &Encoder::new(BusMode::Classic).encode(&hb).unwrap() {
        ctrl.transmit(f).unwrap();
    }
    let e = s
        .run_trial(TrialKind::Stage2 { learn: true }, Phase::Training)
        .unwrap_err();
    assert!(matches!(e, Error::BusSilent(_)));
    assert!((0..5).all(|j| s.rig().servo_safe(j)));
    let mut rx: Reassembler = Reassembler::new(100);
    let mut announced = vec![];
    while let Some(f) = ctrl.receive_timeout(Duration::from_millis(10)).unwrap() {
        if let Ok(Some(Envelope {
            node: NodeId::Servo(j),
            msg: Message::SafeStateEntered(m),
        })) = rx.push(&f, 0)
        {
            assert_eq!(m.reason, SafeStateReason::HeartbeatLost);
            assert_eq!(m.action, SafeStateAction::HoldLast);
            announced.push(j.index());
        }
    }
    assert_eq!(announced, vec![0, 1, 2, 3, 4], "each drive says so once");
}
