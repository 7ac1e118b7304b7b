//! The controller node's host loop: a thread on the in-process bus, or the
//! `controller-node` process on SocketCAN. The node logic is `trn-node`, the same the
//! firmware runs; this loop only adds the clock and the transport.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use trn_controller::{Control, Controller};
use trn_node::{ControllerNode, NodeConfig, NodeStats};
use trn_protocol::bus::ReceiveTimeout;
use trn_protocol::{BusMode, CanFrame, Encoder, Reassembler};

/// What the loop did.
#[derive(Debug, Clone, Copy, Default)]
pub struct LoopStats {
    /// Node counters (frame errors included).
    pub node: NodeStats,
}

/// A blocking port seen through `embedded-can`'s non-blocking trait, with one frame already
/// waited for: the host loop sleeps in `receive_timeout` instead of spinning, then hands the
/// port to [`ControllerNode::service`], the code path the firmware runs too.
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

/// Runs the controller node on `port` until the runner sends `ModeChange{Idle}` or `stop`
/// is set. Returns the controller (with its learned tables) and the counters.
pub fn run<P, C: Control>(
    mut port: P,
    mut ctrl: Box<C>,
    mode: BusMode,
    stop: &AtomicBool,
) -> LoopResult<C>
where
    P: embedded_can::nb::Can<Frame = CanFrame, Error = trn_protocol::Error> + ReceiveTimeout,
{
    let start = Instant::now();
    let now_ms = || start.elapsed().as_millis() as u32;
    let mut node = ControllerNode::new(NodeConfig::HOST);
    let mut enc = Encoder::new(mode);
    let mut rx: Reassembler = Reassembler::new(trn_protocol::DEFAULT_STALE_MS);
    while !stop.load(Ordering::Relaxed) && !node.idle_requested() {
        let first = port.receive_timeout(Duration::from_millis(20))?;
        let mut waited = Waited {
            port: &mut port,
            first,
        };
        node.service(&mut *ctrl, &mut rx, &mut enc, &mut waited, now_ms())?;
    }
    Ok((
        ctrl,
        LoopStats {
            node: *node.stats(),
        },
    ))
}

/// What the node's loop hands back: the controller with its learned tables, and counters.
pub type LoopResult<C = Controller> = Result<(Box<C>, LoopStats), trn_protocol::Error>;

/// The controller node in a thread of this process, running any [`Control`] (the project's
/// controller, or the simulator's model-based reference).
pub struct ControllerThread<C: Control + Send + 'static = Controller> {
    stop: Arc<AtomicBool>,
    join: Option<JoinHandle<LoopResult<C>>>,
}

impl<C: Control + Send + 'static> ControllerThread<C> {
    /// Starts the node on `port`.
    pub fn spawn<P>(port: P, ctrl: Box<C>, mode: BusMode) -> Self
    where
        P: embedded_can::nb::Can<Frame = CanFrame, Error = trn_protocol::Error>
            + ReceiveTimeout
            + Send
            + 'static,
    {
        let stop = Arc::new(AtomicBool::new(false));
        let flag = stop.clone();
        let join = std::thread::Builder::new()
            .name("controller-node".into())
            .stack_size(4 << 20)
            .spawn(move || run(port, ctrl, mode, &flag))
            .expect("spawning a thread");
        ControllerThread {
            stop,
            join: Some(join),
        }
    }

    /// Ends the node's loop (the session is over: the runner had the `Idle` acknowledged,
    /// or gave up on the controller) and returns the controller. Never waits for a message
    /// that may have been lost.
    pub fn join(mut self) -> LoopResult<C> {
        self.stop.store(true, Ordering::Relaxed);
        let join = self.join.take().expect("joined once");
        join.join()
            .unwrap_or(Err(trn_protocol::Error::Io(std::io::ErrorKind::BrokenPipe)))
    }
}

impl<C: Control + Send + 'static> Drop for ControllerThread<C> {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(j) = self.join.take() {
            let _ = j.join();
        }
    }
}
