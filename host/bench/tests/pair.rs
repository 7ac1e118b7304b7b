//! The lab on the simulated clock, driven step by step (as quinn-proto's `Pair`): the rig
//! and the runner against the controller node on the in-process bus, or against scripted
//! peers (silent, heartbeats only, a stray frame). Each test checks one rule of the runner,
//! or the schedule, and takes no wall time waiting (the conformance suite against such a
//! peer: trn-conformance's tests/pair.rs).

use std::rc::Rc;
use std::time::{Duration, Instant};

use embedded_can::blocking::Can;
use trn_bench::observe::Observer;
use trn_bench::ports::ControllerPort;
use trn_bench::records::{Phase, TrialKind, TrialRecord};
use trn_bench::rig::Rig;
use trn_bench::runner::{Runner, Source, Timing, TrialSpec};
use trn_bench::schedule::{self, Context, Plan};
use trn_bench::targets::HeldOut;
use trn_bench::LabError;
use trn_controller::{Config, Controller};
use trn_plant::{Plant, SimConfig};
use trn_protocol::bus::ReceiveTimeout;
use trn_protocol::{
    BusMode, CanFrame, Encoder, Envelope, GripperCommand, Heartbeat, Message, NodeId, NodeState,
    FINE_MOVES_POLICY,
};
use trn_transport::inproc::SimulatedBus;
use trn_transport::{Clock, SimClock};

const MODE: BusMode = BusMode::Classic;

fn plant() -> Plant {
    Plant::new(&SimConfig::ideal(), 5).unwrap()
}

fn timing() -> Timing {
    Timing {
        alive: Duration::from_millis(500),
        ..Timing::new(Duration::from_millis(60), Duration::from_secs(10))
    }
}

/// The project's controller, seeded, on the simulated in-process bus.
fn controller_bus() -> SimulatedBus<Controller> {
    let mut c = Box::new(Controller::new(Config::project_default()));
    c.init_random(5);
    SimulatedBus::new(MODE, 5, None, c)
}

fn runner<P>(port: P, clock: Rc<dyn Clock>) -> Runner<P>
where
    P: Can<Frame = CanFrame, Error = trn_protocol::Error> + ReceiveTimeout,
{
    let rig = Rig::new(port, clock, plant(), MODE, Default::default());
    Runner::new(rig, 5, timing())
}

fn frames(msg: Message) -> Vec<CanFrame> {
    Encoder::new(MODE)
        .encode(&Envelope::new(NodeId::Controller, msg))
        .unwrap()
        .to_vec()
}

/// A scripted peer on the simulated clock: it sends a heartbeat every 100 ms (or nothing)
/// and answers nothing; what the runner sends is counted.
struct Scripted {
    clock: SimClock,
    heartbeats: bool,
    next_beat: Duration,
    counter: u8,
    received: usize,
}

impl Scripted {
    fn new(heartbeats: bool) -> Scripted {
        Scripted {
            clock: SimClock::new(),
            heartbeats,
            next_beat: Duration::ZERO,
            counter: 0,
            received: 0,
        }
    }
}

impl Can for Scripted {
    type Frame = CanFrame;
    type Error = trn_protocol::Error;
    fn transmit(&mut self, _: &CanFrame) -> Result<(), trn_protocol::Error> {
        self.received += 1;
        Ok(())
    }
    fn receive(&mut self) -> Result<CanFrame, trn_protocol::Error> {
        unreachable!("the rig waits with a timeout")
    }
}

impl ReceiveTimeout for Scripted {
    fn receive_timeout(&mut self, t: Duration) -> Result<Option<CanFrame>, trn_protocol::Error> {
        let end = self.clock.now() + t;
        if self.heartbeats && self.next_beat <= end {
            self.clock.advance_to(self.next_beat);
            self.next_beat += Duration::from_millis(100);
            self.counter = self.counter.wrapping_add(1);
            let hb = Heartbeat {
                counter: self.counter,
                state: NodeState::Operational,
            };
            return Ok(frames(hb.into()).into_iter().next());
        }
        self.clock.advance_to(end);
        Ok(None)
    }
}

impl ControllerPort for Scripted {}

fn stage1(source: Source) -> TrialSpec {
    TrialSpec {
        kind: TrialKind::Stage1 {
            supervised: false,
            learn: false,
        },
        phase: Phase::Evaluation,
        source,
        fine_moves: FINE_MOVES_POLICY,
    }
}

/// A controller that sends nothing at all ends the run with `BusSilent` after the run's
/// silence, in simulated time. Fails when the runner waits forever or gives up earlier.
#[test]
fn a_silent_controller_ends_the_run_after_the_silence() {
    let port = Scripted::new(false);
    let clock = port.clock.clone();
    let mut r = runner(port, Rc::new(clock.clone()));
    let wall = Instant::now();
    let e = r
        .run_trial(TrialKind::Stage2 { learn: true }, Phase::Training)
        .unwrap_err();
    assert!(matches!(e, LabError::BusSilent(_)), "{e}");
    assert!(clock.now() >= Duration::from_secs(10) && clock.now() < Duration::from_secs(11));
    assert!(
        wall.elapsed() < Duration::from_secs(2),
        "it waited in wall time"
    );
}

/// A controller that is alive (heartbeats) but never answers a target: the trial is given
/// up after its repeats, exactly `retries` of them, `reply` apart.
#[test]
fn a_live_controller_that_never_answers_is_given_up_after_its_repeats() {
    let port = Scripted::new(true);
    let clock = port.clock.clone();
    let mut r = runner(port, Rc::new(clock.clone()));
    let rec = r
        .run_trial(TrialKind::Stage2 { learn: true }, Phase::Training)
        .unwrap();
    assert!(rec.gave_up && rec.reports.is_empty());
    let t = timing();
    assert_eq!(r.stats().target_repeats, t.retries);
    assert_eq!(r.stats().given_up, 1);
    let expected = t.reply * (t.retries + 1);
    assert!(
        clock.now() >= expected && clock.now() < expected + Duration::from_millis(200),
        "{:?} (expected about {expected:?})",
        clock.now()
    );
}

/// A port that drops the first `drop` frames the runner sends and can slip a frame of the
/// controller in before the runner's next wait (a stray or stale frame).
struct Meddling {
    inner: SimulatedBus<Controller>,
    drop: usize,
    inject: Vec<CanFrame>,
}

impl Can for Meddling {
    type Frame = CanFrame;
    type Error = trn_protocol::Error;
    fn transmit(&mut self, f: &CanFrame) -> Result<(), trn_protocol::Error> {
        if self.drop > 0 {
            self.drop -= 1;
            return Ok(());
        }
        self.inner.transmit(f)
    }
    fn receive(&mut self) -> Result<CanFrame, trn_protocol::Error> {
        self.inner.receive()
    }
}

impl ReceiveTimeout for Meddling {
    fn receive_timeout(&mut self, t: Duration) -> Result<Option<CanFrame>, trn_protocol::Error> {
        if !self.inject.is_empty() {
            return Ok(Some(self.inject.remove(0)));
        }
        self.inner.receive_timeout(t)
    }
}

impl ControllerPort for Meddling {}

fn held_out(grasp: bool) -> HeldOut {
    let mut rng = <rand_xoshiro::Xoshiro256PlusPlus as rand_core::SeedableRng>::seed_from_u64(3);
    HeldOut::set(&plant(), &mut rng, 1, grasp).unwrap()[0]
}

fn meddled(drop: usize, inject: Vec<CanFrame>, spec: &TrialSpec) -> (TrialRecord, u32) {
    let inner = controller_bus();
    let clock = inner.clock();
    let mut r = runner(
        Meddling {
            inner,
            drop,
            inject,
        },
        Rc::new(clock),
    );
    let rec = r.run(spec).unwrap();
    (rec, r.stats().target_repeats)
}

/// A lost target (its frames dropped) is repeated, and the trial then runs exactly as an
/// undisturbed one: the same captures and reports. Fails when a repeat is not sent or is
/// taken for a second trial.
#[test]
fn a_lost_target_is_repeated_and_the_trial_is_the_same() {
    let spec = stage1(Source::HeldOut(held_out(false)));
    let (clean, repeats) = meddled(0, vec![], &spec);
    assert_eq!(repeats, 0);
    let (lost, repeats) = meddled(3, vec![], &spec);
    assert!(repeats >= 1, "no repeat");
    assert_eq!(lost.captures, clean.captures);
    assert_eq!(lost.reports, clean.reports);
}

/// A gripper close of an earlier grasp that arrives at the start of this one (a repeat of
/// its command) is not this grasp's: the score is the undisturbed grasp's. Fails when the
/// runner scores the first close it sees (the arm is then at its start pose).
#[test]
fn a_stale_close_does_not_score_the_grasp() {
    let spec = TrialSpec {
        kind: TrialKind::Grasp { learn: false },
        phase: Phase::Grasping,
        source: Source::HeldOut(held_out(true)),
        fine_moves: FINE_MOVES_POLICY,
    };
    let (clean, _) = meddled(0, vec![], &spec);
    assert!(clean.grasp.is_some());
    let close = Encoder::new(MODE)
        .encode(&Envelope::new(
            NodeId::Gripper,
            GripperCommand { close: true }.into(),
        ))
        .unwrap()
        .to_vec();
    let (stale, _) = meddled(0, close, &spec);
    assert_eq!(stale.grasp, clean.grasp);
}

/// Interrupts the run after `after` trials.
struct StopAfter {
    after: usize,
    seen: usize,
    phases: Vec<String>,
}

impl Observer for StopAfter {
    fn phase(&mut self, name: &str) {
        self.phases.push(name.to_string());
    }
    fn trial(&mut self, _: &TrialRecord) {
        self.seen += 1;
    }
    fn stop_requested(&self) -> bool {
        self.seen >= self.after
    }
}

fn schedule_run(plan: Plan, stop_after: usize) -> (trn_bench::records::RunLog, StopAfter) {
    let bus = controller_bus();
    let clock = bus.clock();
    let mut r = runner(bus, Rc::new(clock));
    let cfg = Config::project_default();
    let mut obs = StopAfter {
        after: stop_after,
        seen: 0,
        phases: vec![],
    };
    let cx = Context {
        cfg: &cfg,
        seed: 5,
        observer: &mut obs,
        resume: None,
        checkpoints: None,
    };
    let log = schedule::run(&mut r, plan, cx).unwrap();
    (log, obs)
}

/// The schedule's order: training pairs with a frozen snapshot every `snapshot_every`
/// trials, then the fixed-budget and stop-rule evaluations, the paper's protocol, grasps;
/// the numbers of each as planned.
#[test]
fn the_schedule_runs_its_trials_in_order() {
    let plan = Plan {
        snapshot_every: 2,
        snapshot_targets: 1,
        ..Plan::new(4, 2, 1)
    };
    let (log, obs) = schedule_run(plan, usize::MAX);
    let count = |p: Phase| log.phase(p).count();
    assert_eq!(count(Phase::Training), 8);
    assert_eq!(count(Phase::Snapshot(2)), 2);
    assert_eq!(count(Phase::Snapshot(4)), 2);
    assert_eq!(count(Phase::Deployment), 4);
    assert_eq!(count(Phase::Evaluation), 4);
    assert_eq!(count(Phase::VisitAndReturn), 4);
    assert_eq!(count(Phase::Grasping), 1);
    let order: Vec<Phase> = log.trials.iter().map(|r| r.phase).collect();
    let first_snapshot = order.iter().position(|p| *p == Phase::Snapshot(2)).unwrap();
    assert_eq!(first_snapshot, 4, "after two training pairs");
    assert_eq!(obs.phases.first().map(String::as_str), Some("training"));
    assert!(!log.interrupted);
    assert_eq!(log.end_of_training.unwrap().trials_done, 4);
}

/// An interrupt stops at the next trial boundary: the log holds the pairs done, is marked,
/// and its simulator state says how far training got.
#[test]
fn an_interrupt_stops_at_the_next_trial_boundary() {
    let plan = Plan {
        snapshot_every: 0,
        ..Plan::new(10, 2, 1)
    };
    let (log, _) = schedule_run(plan, 6);
    assert!(log.interrupted);
    assert_eq!(log.phase(Phase::Training).count(), 6, "three pairs");
    assert_eq!(log.phase(Phase::Deployment).count(), 0, "no evaluation");
    let state = log.end_of_training.unwrap();
    assert_eq!((state.trials_done, state.trials_planned), (3, 10));
    assert_eq!(state.history.stage1_error_px.len(), 3);
}
