//! The controller node's host loop: a thread on the in-process bus, or the
//! `controller-node` process on SocketCAN. The node logic is `trn-node`, the same the
//! firmware runs; this loop only adds the clock and the transport.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use embedded_can::blocking::Can;
use trn_controller::Controller;
use trn_node::{ControllerNode, NodeConfig, NodeStats};
use trn_protocol::bus::ReceiveTimeout;
use trn_protocol::{BusMode, CanFrame, Encoder, Reassembler};

/// What the loop did.
#[derive(Debug, Clone, Copy, Default)]
pub struct LoopStats {
    /// Node counters.
    pub node: NodeStats,
    /// Frames received.
    pub frames_in: u64,
    /// Frames rejected by the reassembler.
    pub frame_errors: u64,
}

/// Runs the controller node on `port` until the runner sends `ModeChange{Idle}` or `stop`
/// is set. Returns the controller (with its learned tables) and the counters.
pub fn run<P>(
    mut port: P,
    mut ctrl: Box<Controller>,
    mode: BusMode,
    stop: &AtomicBool,
) -> LoopResult
where
    P: Can<Frame = CanFrame, Error = trn_protocol::Error> + ReceiveTimeout,
{
    let start = Instant::now();
    let now_ms = || start.elapsed().as_millis() as u32;
    let mut node = ControllerNode::new(NodeConfig::default());
    let mut enc = Encoder::new(mode);
    let mut rx: Reassembler = Reassembler::new(trn_protocol::DEFAULT_STALE_MS);
    let mut stats = LoopStats::default();
    let mut tx_err = None;
    while !stop.load(Ordering::Relaxed) {
        if let Some(frame) = port.receive_timeout(Duration::from_millis(20))? {
            stats.frames_in += 1;
            let mut tx = |f: &CanFrame| {
                if let Err(e) = port.transmit(f) {
                    tx_err = Some(e);
                }
            };
            if node
                .on_frame(&mut ctrl, &mut rx, &mut enc, &frame, now_ms(), &mut tx)
                .is_err()
            {
                stats.frame_errors += 1;
            }
            if node.idle_requested() {
                break;
            }
        }
        let mut tx = |f: &CanFrame| {
            if let Err(e) = port.transmit(f) {
                tx_err = Some(e);
            }
        };
        node.poll_frames(&mut ctrl, &mut enc, now_ms(), &mut tx)?;
        if let Some(e) = tx_err.take() {
            return Err(e);
        }
    }
    stats.node = *node.stats();
    Ok((ctrl, stats))
}

/// What the node's loop hands back: the controller with its learned tables, and counters.
pub type LoopResult = Result<(Box<Controller>, LoopStats), trn_protocol::Error>;

/// The controller node in a thread of this process.
pub struct ControllerThread {
    stop: Arc<AtomicBool>,
    join: Option<JoinHandle<LoopResult>>,
}

impl ControllerThread {
    /// Starts the node on `port`.
    pub fn spawn<P>(port: P, ctrl: Box<Controller>, mode: BusMode) -> Self
    where
        P: Can<Frame = CanFrame, Error = trn_protocol::Error> + ReceiveTimeout + Send + 'static,
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

    /// Waits for the node to end (after `ModeChange{Idle}`), returning the controller.
    pub fn join(mut self) -> LoopResult {
        let join = self.join.take().expect("joined once");
        join.join()
            .unwrap_or(Err(trn_protocol::Error::Io(std::io::ErrorKind::BrokenPipe)))
    }
}

impl Drop for ControllerThread {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(j) = self.join.take() {
            let _ = j.join();
        }
    }
}
