//! The controller node's host loop on a real bus (the `controller-node` process on
//! SocketCAN): the node logic is `trn-node`, the same the firmware runs; this loop adds the
//! wall clock and sleeps until a frame arrives or the node's next deadline
//! ([`ControllerNode::poll_timeout`]). It runs until told to stop, across sessions.

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use trn_controller::Control;
use trn_node::ControllerNode;
use trn_protocol::bus::ReceiveTimeout;
use trn_protocol::{BusMode, CanFrame, Encoder, Reassembler};

use crate::clock::{millis, Clock, WallClock};

/// A blocking port seen through `embedded-can`'s non-blocking trait, with one frame already
/// waited for: the loop sleeps in `receive_timeout` instead of spinning, then hands the port
/// to [`ControllerNode::service`], the code path the firmware runs too.
struct Waited<'a, P> {
    port: &'a mut P,
    first: Option<CanFrame>,
}

impl<P> embedded_can::nb::Can for Waited<'_, P>
where
    P: embedded_can::nb::Can<Frame = CanFrame, Error = trn_protocol::Error>,
{
    type Frame = CanFrame;
    type Error = trn_protocol::Error;

    fn transmit(&mut self, frame: &CanFrame) -> nb::Result<Option<CanFrame>, Self::Error> {
        self.port.transmit(frame)
    }

    fn receive(&mut self) -> nb::Result<CanFrame, Self::Error> {
        match self.first.take() {
            Some(f) => Ok(f),
            None => self.port.receive(),
        }
    }
}

/// The longest sleep between turns (the `stop` flag is looked at after each).
const MAX_SLEEP: Duration = Duration::from_millis(100);

/// Runs `node` with the controller `ctrl` on `port` until `stop` is set (a signal, the
/// embedding's end), as a board runs: a session's end (`ModeChange{Idle}`) does not end it.
/// The node comes booted (its guard seeded, told what was restored) and starts framing in
/// CAN 2.0 (a `SessionConfig` switches it to FD); its counters are [`ControllerNode::stats`].
pub fn run<P, C: Control + ?Sized>(
    mut port: P,
    ctrl: &mut C,
    node: &mut ControllerNode,
    clock: &WallClock,
    stop: &AtomicBool,
) -> Result<(), trn_protocol::Error>
where
    P: embedded_can::nb::Can<Frame = CanFrame, Error = trn_protocol::Error> + ReceiveTimeout,
{
    let mut enc = Encoder::new(BusMode::Classic);
    let mut rx: Reassembler = Reassembler::new(trn_protocol::DEFAULT_STALE_MS);
    while !stop.load(Ordering::Relaxed) {
        let now = millis(clock.now());
        let sleep = node.poll_timeout().map_or(MAX_SLEEP, |due| {
            let ahead = due.wrapping_sub(now);
            if ahead > u32::MAX / 2 {
                Duration::ZERO
            } else {
                Duration::from_millis(ahead as u64).min(MAX_SLEEP)
            }
        });
        let first = port.receive_timeout(sleep)?;
        let mut waited = Waited {
            port: &mut port,
            first,
        };
        node.service(ctrl, &mut rx, &mut enc, &mut waited, millis(clock.now()))?;
    }
    Ok(())
}

/// A fresh host node on `port` until `stop`: the project preset for the default cameras as
/// its reset configuration (a session's `SessionConfig` replaces it), its store in memory,
/// its guard seeded from `guard` ([`crate::board::guard_seed`]), the host's timing. What a
/// test or a benchmark puts on the far end of a bus (one end of a pseudo-terminal pair) to
/// play a board; `controller-node` is the same with a tables file and the OS's entropy.
pub fn run_fresh<P>(port: P, guard: u64, stop: &AtomicBool) -> Result<(), trn_protocol::Error>
where
    P: embedded_can::nb::Can<Frame = CanFrame, Error = trn_protocol::Error> + ReceiveTimeout,
{
    use trn_controller::presets::{self, Ablation, ImageSize, Preset};
    let reset = presets::configure(Preset::Project, Ablation::None, ImageSize::DEFAULT);
    // a store in memory: nothing to open, nothing that fails
    let (mut b, restored) = crate::board::boot(reset, None)
        .map_err(|_| trn_protocol::Error::Io(std::io::ErrorKind::Other))?;
    let mut node = crate::board::node(
        &mut b,
        restored.ok(),
        crate::board::guard_seed(guard),
        trn_node::NodeConfig::HOST,
    );
    run(port, &mut b, &mut node, &WallClock::start(), stop)
}
