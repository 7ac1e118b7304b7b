//! The in-process bus on a simulated clock: the runner's port, with the controller node
//! (any [`Control`]: the TRN, the Broyden servo, a host-only reference) on the same
//! [`InProcBus`] and serviced inline, the same [`ControllerNode::service`] the firmware runs.
//!
//! Nothing waits in wall time. When the runner waits for a frame, the node handles every
//! frame on the bus at the present instant; if nothing is then for the runner, the clock
//! jumps to the node's next deadline ([`ControllerNode::poll_timeout`]: a heartbeat, a
//! repeat) or to the end of the runner's wait, whichever is first. A faulted run therefore
//! costs CPU in proportion to its frames, and the same seed and faults give the same run
//! frame for frame (as quinn-proto's test `Pair` drives two endpoints on a simulated clock).

use std::time::Duration;

use trn_controller::Control;
use trn_node::{ControllerNode, NodeConfig, NodeStats};
use trn_protocol::bus::{BusStats, FaultConfig, InProcBus, InProcPort, ReceiveTimeout};
use trn_protocol::{BusMode, CanFrame, Encoder, Error, Reassembler};

use crate::clock::{millis, Clock, SimClock};

/// The controller node's side, serviced inline.
struct InlineNode<C: Control + ?Sized> {
    node: ControllerNode,
    ctrl: Box<C>,
    rx: Reassembler,
    enc: Encoder,
    port: InProcPort,
}

/// The runner's port on the in-process bus, with the controller node on the same bus
/// serviced inline on a simulated clock.
pub struct SimulatedBus<C: Control + ?Sized> {
    bus: InProcBus,
    port: InProcPort,
    node: InlineNode<C>,
    clock: SimClock,
}

impl<C: Control + ?Sized> SimulatedBus<C> {
    /// A bus in `mode` with `faults` (seeded by `seed`), the node running `ctrl` with the
    /// host's timing ([`NodeConfig::HOST`]), its guard unseeded (it issues no nonce) and
    /// nothing announced about its tables.
    pub fn new(mode: BusMode, seed: u64, faults: Option<FaultConfig>, ctrl: Box<C>) -> Self {
        Self::with_node(
            mode,
            seed,
            faults,
            ctrl,
            ControllerNode::new(NodeConfig::HOST),
        )
    }

    /// [`SimulatedBus::new`] with a node the caller booted: its guard seeded
    /// ([`ControllerNode::seed_guard`]) and told what the controller's store restored
    /// ([`ControllerNode::tables_restored`]), as a board's firmware does at reset.
    pub fn with_node(
        mode: BusMode,
        seed: u64,
        faults: Option<FaultConfig>,
        ctrl: Box<C>,
        node: ControllerNode,
    ) -> Self {
        let bus = InProcBus::new(mode, seed);
        if let Some(f) = faults {
            bus.set_faults(f);
        }
        let node = InlineNode {
            node,
            ctrl,
            rx: Reassembler::new(trn_protocol::DEFAULT_STALE_MS),
            enc: Encoder::new(mode),
            port: bus.port(),
        };
        SimulatedBus {
            port: bus.port(),
            bus,
            node,
            clock: SimClock::new(),
        }
    }

    /// The run's clock (a handle: the rig and the runner read the same time).
    pub fn clock(&self) -> SimClock {
        self.clock.clone()
    }

    /// What the bus did (frames sent, delivered, and every injected fault).
    pub fn bus_stats(&self) -> BusStats {
        self.bus.stats()
    }

    /// The node's counters.
    pub fn node_stats(&self) -> NodeStats {
        *self.node.node.stats()
    }

    /// The controller.
    pub fn controller(&self) -> &C {
        &self.node.ctrl
    }

    /// The controller node (its session, its counters).
    pub fn node(&self) -> &ControllerNode {
        &self.node.node
    }

    /// Ends the session: the controller (with its learned tables) and the node's counters.
    pub fn into_controller(self) -> (Box<C>, NodeStats) {
        let stats = *self.node.node.stats();
        (self.node.ctrl, stats)
    }

    /// The node's turn at the present instant: every frame on the bus, then its timers. The
    /// node runs on after a session ends (`ModeChange{Idle}`), as a board does: it answers
    /// until the bus is dropped.
    fn node_turn(&mut self) -> Result<(), Error> {
        let n = &mut self.node;
        let now = millis(self.clock.now());
        n.node
            .service(&mut *n.ctrl, &mut n.rx, &mut n.enc, &mut n.port, now)
    }

    /// When the node next needs a turn.
    fn node_deadline(&self) -> Option<Duration> {
        let n = &self.node.node;
        let now = self.clock.now();
        let due = n.poll_timeout()?;
        let ahead = due.wrapping_sub(millis(now));
        Some(if ahead > u32::MAX / 2 {
            now // overdue
        } else {
            Duration::from_millis(now.as_millis() as u64 + ahead as u64)
        })
    }
}

impl<C: Control + ?Sized> ReceiveTimeout for SimulatedBus<C> {
    /// Services the node until a frame is there for the runner, moving the clock to the
    /// node's deadlines; `Ok(None)` with the clock at the end of `timeout` when none came.
    fn receive_timeout(&mut self, timeout: Duration) -> Result<Option<CanFrame>, Error> {
        let end = self.clock.now() + timeout;
        loop {
            self.node_turn()?;
            if let Some(f) = self.port.try_receive() {
                return Ok(Some(f));
            }
            let now = self.clock.now();
            if now >= end {
                return Ok(None);
            }
            // at least a millisecond on: the node's clock counts milliseconds, and a
            // deadline it has just served is not served twice
            let next = self
                .node_deadline()
                .unwrap_or(end)
                .max(now + Duration::from_millis(1));
            self.clock.advance_to(next.min(end));
        }
    }
}

impl<C: Control + ?Sized> embedded_can::blocking::Can for SimulatedBus<C> {
    type Frame = CanFrame;
    type Error = Error;

    fn transmit(&mut self, frame: &CanFrame) -> Result<(), Error> {
        embedded_can::blocking::Can::transmit(&mut self.port, frame)
    }

    /// Waits (in simulated time) until a frame arrives; a node that stopped and a bus
    /// without traffic end in an error after a simulated hour instead of waiting forever.
    fn receive(&mut self) -> Result<CanFrame, Error> {
        self.receive_timeout(Duration::from_secs(3600))?
            .ok_or(Error::Io(std::io::ErrorKind::TimedOut))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use embedded_can::blocking::Can as _;
    use trn_controller::{Config, Controller};
    use trn_protocol::{Envelope, Message, Mode, ModeChange, NodeId};

    fn bus(faults: Option<FaultConfig>) -> SimulatedBus<Controller> {
        let mut ctrl = Box::new(Controller::new(Config::project_default()));
        ctrl.init_random(1);
        SimulatedBus::new(BusMode::Classic, 7, faults, ctrl)
    }

    fn heartbeats(b: &mut SimulatedBus<Controller>, wait: Duration) -> usize {
        let mut rx: Reassembler = Reassembler::new(trn_protocol::DEFAULT_STALE_MS);
        let mut beats = 0;
        let end = b.clock().now() + wait;
        while b.clock().now() < end {
            let left = end - b.clock().now();
            let Some(f) = b.receive_timeout(left).unwrap() else {
                break;
            };
            if let Ok(Some(env)) = rx.push(&f, millis(b.clock().now())) {
                beats += matches!(env.msg, Message::Heartbeat(_)) as usize;
            }
        }
        beats
    }

    /// Ten simulated seconds of an idle node: a heartbeat at 0 and every 100 ms up to and
    /// including 10 s (101), the clock exactly at the end, and no wall time spent waiting. Fails if the clock skips a
    /// heartbeat, stalls, or runs past the wait.
    #[test]
    fn an_idle_node_beats_on_simulated_time() {
        let mut b = bus(None);
        let wall = std::time::Instant::now();
        let beats = heartbeats(&mut b, Duration::from_secs(10));
        assert_eq!(beats, 101);
        assert_eq!(b.clock().now(), Duration::from_secs(10));
        assert!(
            wall.elapsed() < Duration::from_secs(5),
            "it waited in wall time"
        );
    }

    /// The node answers a mode change at the same simulated instant; after `Idle` it runs
    /// on, as a board does (its heartbeats go on, every 100 ms).
    #[test]
    fn the_node_answers_at_once_and_runs_on_after_idle() {
        let mut b = bus(None);
        let mut enc = Encoder::new(BusMode::Classic);
        let mut rx: Reassembler = Reassembler::new(trn_protocol::DEFAULT_STALE_MS);
        let idle = Envelope::new(NodeId::Controller, ModeChange { mode: Mode::Idle }.into());
        for f in &enc.encode(&idle).unwrap() {
            b.transmit(f).unwrap();
        }
        let t0 = b.clock().now();
        let mut echoed = false;
        while let Some(f) = b.receive_timeout(Duration::ZERO).unwrap() {
            if let Ok(Some(env)) = rx.push(&f, 0) {
                echoed |= env.node == NodeId::Broadcast
                    && env.msg == Message::ModeChange(ModeChange { mode: Mode::Idle });
            }
        }
        assert!(echoed, "the echo of Idle");
        assert_eq!(b.clock().now(), t0, "answered at the same instant");
        assert!(b.node().idle_requested());
        assert_eq!(heartbeats(&mut b, Duration::from_secs(1)), 10);
        assert_eq!(b.clock().now(), t0 + Duration::from_secs(1));
    }

    /// The same seed and faults give the same frames and the same counters.
    #[test]
    fn the_same_faults_give_the_same_run() {
        let faults = FaultConfig {
            drop: 0.2,
            duplicate: 0.1,
            ..FaultConfig::default()
        };
        let run = || {
            let mut b = bus(Some(faults));
            let beats = heartbeats(&mut b, Duration::from_secs(20));
            (beats, b.bus_stats())
        };
        let (a, b) = (run(), run());
        assert_eq!(a, b);
        assert!(a.1.dropped > 0 && a.1.duplicated > 0, "{:?}", a.1);
    }
}
