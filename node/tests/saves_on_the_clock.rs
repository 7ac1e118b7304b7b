//! Saves during back-to-back training on a flash that takes time, shaped as each board's: the
//! node, the drives' heartbeat supervision, the plant and a runner on one simulated clock.
//!
//! The STM32H743's flash is `trn_store::sim::H743Flash` (32-byte flash words, 128 KiB
//! sectors, the store's slots of f32 images two sectors each) with the part's erase and
//! program durations (`FlashTiming::H743_X32` typical, `H743_X32_MAX` maximum); the
//! STM32G474's is `G474Flash` (8-byte double words, 2 KiB pages, slots of compact images of
//! 56 pages each; `FlashTiming::G474` typical, `G474_MAX` maximum). The plant answers a drive's
//! command after 2 ms and a capture after 1.2 s (the simulated arm's settle time); the runner
//! sends the next target 1 ms after a trial ends and repeats a start that shows no sign every
//! 300 ms, giving it up after 12 repeats (SocketCAN's figures, protocol/SPEC.md 3.1). The
//! drives supervise the controller's heartbeat with the protocol's `HeartbeatMonitor` (500 ms)
//! and answer in their safe state once it is lost.
//!
//! Run with `--nocapture` for the figures: the longest heartbeat gap, how long starts waited,
//! the trials each save took, the erases per sector.

mod common;

use common::*;
use trn_controller::checkpoint::Encoding;
use trn_controller::WithStore;
use trn_node::{ControllerNode, NodeConfig, Outbox};
use trn_protocol::heartbeat::{HeartbeatConfig, HeartbeatMonitor};
use trn_protocol::{Envelope, Message, Mode, ModeChange, NodeId, SafeState, TablesEvent};
use trn_store::sim::{FlashTiming, G474Flash, SimClock, SimFlash};
use trn_store::{FlashStore, TableStore};

/// A board: the controller and its store on a flash of `W`-byte write units and `E`-byte
/// pages.
type Board<const W: usize, const E: usize> =
    WithStore<Box<trn_controller::Controller>, FlashStore<SimFlash<W, E>>>;

/// Time of one turn of the node's loop when it is due at once (µs).
const TURN_US: u64 = 50;
/// The runner's reply timeout and repeats (SocketCAN).
const RUNNER_TIMEOUT_US: u64 = 300_000;
const RUNNER_REPEATS: u32 = 12;
/// The plant's answer times (µs).
const SERVO_US: u64 = 2_000;
const CAPTURE_US: u64 = 1_200_000;
/// Learning steps between saves in these runs.
const SAVE_EVERY: u32 = 3;

/// What a run measured.
#[derive(Debug, Default)]
struct Figures {
    /// The longest time between two heartbeats the drives received (µs).
    max_gap_us: u64,
    /// Times the drives entered their safe state.
    safe_entries: u32,
    /// The longest a trial's start waited (from its first target to the trial's start, µs).
    max_wait_us: u64,
    /// The most repeats of one start by the runner.
    max_repeats: u32,
    /// Trials the runner gave up.
    given_up: u32,
    /// Errors the node reported.
    errors: Vec<(u16, u32)>,
    /// For each completed save: the trials that ended between its start and its `Saved`, and
    /// the erases of each sector it made.
    saves: Vec<(u32, Vec<u32>)>,
    trials_done: u32,
    /// Trials aborted.
    aborted: u32,
}

struct Rig<const W: usize, const E: usize> {
    clock: SimClock,
    n: ControllerNode,
    b: Board<W, E>,
    plant: Plant,
    drives: HeartbeatMonitor,
    last_heartbeat_us: u64,
    /// Messages to the node: (arrival time in µs, message).
    queue: Vec<(u64, Envelope)>,
    f: Figures,
    erases_at_last_save: Vec<u32>,
    save_began_at_trial: Option<u32>,
}

impl<const W: usize, const E: usize> Rig<W, E> {
    fn new(timing: FlashTiming, background: bool, encoding: Encoding) -> Self {
        let clock = SimClock::new();
        let slot = FlashStore::<SimFlash<W, E>>::slot_size_needed_as(encoding);
        let sectors = 2 * slot as usize / E;
        let flash = SimFlash::<W, E>::new(sectors).with_timing(clock.clone(), timing);
        let mut store = FlashStore::new_as(flash, 0, slot, encoding).unwrap();
        if background {
            store = store.with_background_erase();
        }
        let b = Board {
            ctrl: learned(52, 0),
            store,
        };
        let n = ControllerNode::new(NodeConfig {
            save_every_steps: SAVE_EVERY,
            ..NodeConfig::DEFAULT
        });
        Rig {
            clock,
            n,
            b,
            plant: Plant::new(),
            drives: HeartbeatMonitor::new(HeartbeatConfig::default(), 0),
            last_heartbeat_us: 0,
            queue: Vec::new(),
            f: Figures::default(),
            erases_at_last_save: vec![0; sectors],
            save_began_at_trial: None,
        }
    }

    fn send_now(&mut self, msg: Message) {
        let at = self.clock.now_us();
        self.queue.push((at, to_ctrl(msg)));
    }

    /// One turn of the node's loop: the messages that arrived, then `poll`; what it sent
    /// leaves when the turn ends (a flash call that blocks moves the clock within the turn).
    fn turn(&mut self) {
        let now_us = self.clock.now_us();
        let now = self.clock.now_ms();
        let mut arrived = Vec::new();
        self.queue.retain(|(t, e)| {
            if *t <= now_us {
                arrived.push((*t, *e));
                false
            } else {
                true
            }
        });
        arrived.sort_by_key(|(t, _)| *t);
        let mut out = Outbox::new();
        for (_, e) in &arrived {
            self.n.on_message(&mut self.b, e, now, &mut out);
        }
        self.n.poll(&mut self.b, now, &mut out);
        if self.save_began_at_trial.is_none() && self.b.store.saving() {
            self.save_began_at_trial = Some(self.f.trials_done);
        }
        self.clock.advance(TURN_US);
        self.emit(&out);
    }

    /// What the node sent, received by the drives, the plant and the runner.
    fn emit(&mut self, out: &[Envelope]) {
        let at = self.clock.now_us();
        let at_ms = self.clock.now_ms();
        for e in out {
            match e.msg {
                Message::Heartbeat(_) => {
                    if self.drives.poll(at_ms).is_some() {
                        self.f.safe_entries += 1;
                    }
                    self.drives.observe(e, NodeId::Controller, at_ms);
                    self.f.max_gap_us = self.f.max_gap_us.max(at - self.last_heartbeat_us);
                    self.last_heartbeat_us = at;
                }
                Message::ErrorReport(r) => self.f.errors.push((r.code, r.detail)),
                Message::TablesStatus(s) if s.event == TablesEvent::Saved => {
                    let now = self.b.store.flash().erase_counts().to_vec();
                    let made = now
                        .iter()
                        .zip(&self.erases_at_last_save)
                        .map(|(a, b)| a - b)
                        .collect();
                    let began = self
                        .save_began_at_trial
                        .take()
                        .unwrap_or(self.f.trials_done);
                    self.f.saves.push((self.f.trials_done - began, made));
                    self.erases_at_last_save = now;
                }
                _ => {}
            }
            if self.drives.poll(at_ms).is_some() {
                self.f.safe_entries += 1;
            }
            let safe = self.drives.is_safe();
            for mut a in self.plant.answer(std::slice::from_ref(e)) {
                let delay = match a.msg {
                    Message::ServoStatus(ref mut s) => {
                        if safe {
                            s.safe_state = SafeState::HoldLast;
                        }
                        SERVO_US
                    }
                    _ => CAPTURE_US,
                };
                self.queue.push((at + delay, a));
            }
        }
    }

    /// Moves the clock to the node's next turn: at once while it is due, else its next
    /// timer or the next message, whichever comes first.
    fn wait(&mut self, runner_at: u64) {
        let now = self.clock.now_ms();
        let node = match self.n.poll_timeout() {
            Some(due) if (due.wrapping_sub(now) as i32) <= 0 => return,
            Some(due) => due.wrapping_sub(now) as u64 * 1000 + self.clock.now_us(),
            None => return,
        };
        let msg = self.queue.iter().map(|(t, _)| *t).min().unwrap_or(u64::MAX);
        self.clock.advance_to(node.min(msg).min(runner_at));
    }

    /// Back-to-back learning trials from `first` to `last`: the runner sends each target 1 ms
    /// after the trial before it ended, repeating it while the node shows no sign of it.
    fn train(&mut self, first: u32, last: u32) {
        for trial in first..=last {
            let t = learning_target(trial);
            self.clock.advance(1_000);
            let first_sent = self.clock.now_us();
            let mut sent = first_sent;
            let mut repeats = 0;
            self.send_now(t.into());
            // until it starts
            loop {
                self.turn();
                if self.n.trial() == Some(trial) {
                    break;
                }
                if self.clock.now_us() >= sent + RUNNER_TIMEOUT_US {
                    repeats += 1;
                    if repeats > RUNNER_REPEATS {
                        self.f.given_up += 1;
                        break;
                    }
                    sent = self.clock.now_us();
                    self.send_now(t.into());
                }
                self.wait(sent + RUNNER_TIMEOUT_US);
            }
            self.f.max_repeats = self.f.max_repeats.max(repeats);
            self.f.max_wait_us = self.f.max_wait_us.max(self.clock.now_us() - first_sent);
            // until it ends
            let deadline = self.clock.now_us() + 60_000_000;
            while self.n.trial() == Some(trial) {
                assert!(self.clock.now_us() < deadline, "trial {trial} never ended");
                self.wait(u64::MAX);
                self.turn();
            }
            self.f.trials_done += 1;
        }
    }
}

/// Trains `trials` trials back to back in `Training` with a save due every 3 learning steps,
/// on the H743's flash.
fn run(timing: FlashTiming, background: bool, trials: u32) -> Figures {
    run_on::<32, 131072>(timing, background, trials, Encoding::F32)
}

/// [`run`] on a flash of `W`-byte write units and `E`-byte pages, saving in `encoding`.
fn run_on<const W: usize, const E: usize>(
    timing: FlashTiming,
    background: bool,
    trials: u32,
    encoding: Encoding,
) -> Figures {
    let mut r = Rig::<W, E>::new(timing, background, encoding);
    r.send_now(session(3, false).into());
    r.send_now(
        ModeChange {
            mode: Mode::Training,
        }
        .into(),
    );
    r.turn();
    r.train(1, trials);
    assert_eq!(r.n.stats().trials, trials);
    r.f.aborted = r.n.stats().aborted;
    let f = r.f;
    println!(
        "{timing:?} ({W} B writes, {E} B pages, {encoding:?}), background erase {background}: heartbeat gap max {} ms, drives' safe state \
         entered {} times, longest wait of a start {} ms (runner repeats max {}, given up {}), \
         errors {:?}, aborted {}, saves completed {} (trials from start to Saved, erases per \
         sector): {:?}",
        f.max_gap_us / 1000,
        f.safe_entries,
        f.max_wait_us / 1000,
        f.max_repeats,
        f.given_up,
        f.errors,
        f.aborted,
        f.saves.len(),
        f.saves
    );
    f
}

/// The acceptance: with the erases in the background, the drives never miss a heartbeat
/// (no gap above 500 ms), no trial aborts or is given up, each save completes within 2
/// trials of its start (the start of one trial waits for it, below the runner's give-up),
/// and each save erases each sector of its slot once.
#[test]
fn saves_during_back_to_back_training_keep_the_heartbeat_and_erase_each_sector_once() {
    for timing in [FlashTiming::H743_X32, FlashTiming::H743_X32_MAX] {
        let f = run(timing, true, 12);
        assert_eq!(f.aborted, 0, "no trial aborted");
        assert!(
            f.max_gap_us <= 500_000,
            "heartbeat gap {} ms",
            f.max_gap_us / 1000
        );
        assert_eq!(f.safe_entries, 0);
        assert!(f.errors.is_empty(), "{:?}", f.errors);
        assert_eq!(f.given_up, 0);
        assert!(
            f.max_wait_us < (RUNNER_REPEATS as u64 + 1) * RUNNER_TIMEOUT_US,
            "a start waited {} ms",
            f.max_wait_us / 1000
        );
        // a save due every 3 steps: one completes every few trials
        assert!(f.saves.len() >= 3, "{} saves in 12 trials", f.saves.len());
        for (trials, erases) in &f.saves {
            assert!(*trials <= 2, "a save took {trials} trials");
            let per_sector: Vec<u32> = erases.iter().copied().filter(|&e| e > 0).collect();
            assert_eq!(per_sector, vec![1, 1], "erases per sector {erases:?}");
        }
    }
}

/// The same on the G474's flash with its compact images: each save erases each of its slot's
/// 56 pages once, no heartbeat gap above 500 ms, no trial aborted.
#[test]
fn saves_on_the_g474s_flash_keep_the_heartbeat_and_erase_each_page_once() {
    let pages = FlashStore::<G474Flash>::slot_size_needed_as(Encoding::Compact) as usize / 2048;
    assert_eq!(pages, 56);
    for timing in [FlashTiming::G474, FlashTiming::G474_MAX] {
        let f = run_on::<8, 2048>(timing, true, 12, Encoding::Compact);
        assert_eq!(f.aborted, 0, "no trial aborted");
        assert!(
            f.max_gap_us <= 500_000,
            "heartbeat gap {} ms",
            f.max_gap_us / 1000
        );
        assert_eq!(f.safe_entries, 0);
        assert!(f.errors.is_empty(), "{:?}", f.errors);
        assert_eq!(f.given_up, 0);
        assert!(f.saves.len() >= 3, "{} saves in 12 trials", f.saves.len());
        for (trials, erases) in &f.saves {
            assert!(*trials <= 2, "a save took {trials} trials");
            let per_page: Vec<u32> = erases.iter().copied().filter(|&e| e > 0).collect();
            assert_eq!(per_page, vec![1; pages], "erases per page {erases:?}");
        }
    }
}

/// The hazard the background erase removes: the same run with each erase blocking the loop
/// (embassy's blocking erase) leaves the drives without a heartbeat for a sector's erase.
#[test]
fn a_blocking_erase_silences_the_node_for_a_sector_erase() {
    let f = run(FlashTiming::H743_X32, false, 6);
    assert!(
        f.max_gap_us >= 1_100_000,
        "heartbeat gap {} ms",
        f.max_gap_us / 1000
    );
    assert!(f.safe_entries > 0);
}
