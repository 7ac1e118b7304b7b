//! The camera node's loop on a real port (SocketCAN, a serial SLCAN adapter), on the wall
//! clock: it sleeps until a frame arrives or its next heartbeat is due, reassembles what it
//! hears, hands each message to the node and frames what the node sends.

use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use embedded_can::blocking::Can;
use trn_protocol::bus::ReceiveTimeout;
use trn_protocol::{CanFrame, Encoder, Envelope, Reassembler};
use trn_transport::clock::{millis, Clock, WallClock};

use crate::node::{CameraNode, Served};
use crate::source::FrameSource;
use crate::CameraError;

/// The longest sleep between looks at the `stop` flag.
const MAX_SLEEP: Duration = Duration::from_millis(100);

/// Counters of the loop itself (the node's are [`CameraNode::stats`]).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct LoopStats {
    /// Frames received.
    pub frames_in: u64,
    /// Frames sent.
    pub frames_out: u64,
    /// Frames that were no message's (malformed, a segment out of order): dropped.
    pub frame_errors: u64,
}

/// Runs `node` on `port` until `stop` is set; `served` hears what became of each message
/// (the command line logs captures that failed). The port's own failures end it.
pub fn run<P, S>(
    mut port: P,
    node: &mut CameraNode<S>,
    clock: &WallClock,
    stop: &AtomicBool,
    served: &mut dyn FnMut(&Served),
) -> Result<LoopStats, CameraError>
where
    P: Can<Frame = CanFrame, Error = trn_protocol::Error> + ReceiveTimeout,
    S: FrameSource,
{
    let mut enc = Encoder::new(node.mode());
    let mut rx: Reassembler = Reassembler::new(trn_protocol::DEFAULT_STALE_MS);
    let mut out: Vec<Envelope> = Vec::new();
    let mut stats = LoopStats::default();
    while !stop.load(Ordering::Relaxed) {
        let now = millis(clock.now());
        node.poll(now, &mut out);
        send(&mut port, &mut enc, &mut out, &mut stats)?;
        rx.expire(now);
        let ahead = node.poll_timeout().wrapping_sub(now);
        let sleep = if ahead > u32::MAX / 2 {
            Duration::ZERO
        } else {
            Duration::from_millis(ahead as u64).min(MAX_SLEEP)
        };
        let frame = match port.receive_timeout(sleep) {
            Ok(Some(f)) => f,
            // nothing, or a signal (the stop flag is looked at next)
            Ok(None) | Err(trn_protocol::Error::Io(std::io::ErrorKind::Interrupted)) => continue,
            Err(e) => return Err(e.into()),
        };
        stats.frames_in += 1;
        match rx.push(&frame, millis(clock.now())) {
            Ok(Some(env)) => {
                served(&node.on_message(&env, &mut out));
                enc.set_mode(node.mode());
                send(&mut port, &mut enc, &mut out, &mut stats)?;
            }
            Ok(None) => {}
            Err(_) => stats.frame_errors += 1,
        }
    }
    Ok(stats)
}

fn send<P>(
    port: &mut P,
    enc: &mut Encoder,
    out: &mut Vec<Envelope>,
    stats: &mut LoopStats,
) -> Result<(), CameraError>
where
    P: Can<Frame = CanFrame, Error = trn_protocol::Error>,
{
    for env in out.drain(..) {
        for f in &enc.encode(&env)? {
            port.transmit(f)?;
            stats.frames_out += 1;
        }
    }
    Ok(())
}
