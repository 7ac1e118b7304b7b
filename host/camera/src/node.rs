//! The camera processor's CAN node, sans-IO: messages heard on the bus and the time in,
//! messages to send out; it owns no bus and reads no clock.
//!
//! - A `CaptureRequest` to it takes the next capture from its [`FrameSource`], reads it
//!   ([`Processor`]) and answers an `Observation` of the same `seq` and kind. A capture that
//!   cannot be had or read (nothing left, a capture of another kind, a damaged frame) is
//!   answered with its lights `NotDetected` and counted: the controller aborts that trial
//!   and goes on, where silence would stall it until its timeout.
//! - A repeat of the last request (its observation was lost) gets the same observation
//!   again, without a new capture; an older request (late, reordered) is ignored.
//! - A heartbeat every 100 ms, state `Operational`, as every node sends.
//! - Long messages go out as CAN FD frames once a session says so (the runner's
//!   `SessionConfig` to the controller, which every node hears), segmented CAN 2.0 frames
//!   before and otherwise.

use trn_protocol::heartbeat::{HeartbeatSender, DEFAULT_PERIOD_MS};
use trn_protocol::{BusMode, Envelope, Message, NodeId, NodeState, Observation, PixelPoint};

use crate::processor::Processor;
use crate::source::FrameSource;

/// The node's counters.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct NodeStats {
    /// Captures read and answered.
    pub captures: u64,
    /// Captures that could not be had or read, answered with their lights not detected.
    pub failed: u64,
    /// Requests repeated (the observation sent again).
    pub repeats: u64,
    /// Older requests ignored.
    pub stale: u64,
    /// Points reported valid.
    pub valid_points: u64,
    /// Lights valid in both cameras that the stereo check refused.
    pub inconsistent: u64,
}

/// What a message was for the node.
#[derive(Debug, Clone, PartialEq)]
pub enum Served {
    /// Not a capture request for it.
    Nothing,
    /// A new capture, answered.
    Capture(Observation),
    /// A new capture that failed (why), answered with its lights not detected.
    Failed(String),
    /// A repeat of the last request: the same observation sent again.
    Repeat,
    /// An older request: ignored.
    Stale,
}

/// The camera processor's node on frames from `S`.
#[derive(Debug)]
pub struct CameraNode<S> {
    source: S,
    processor: Processor,
    last: Option<Observation>,
    heartbeat: HeartbeatSender,
    mode: BusMode,
    stats: NodeStats,
}

impl<S: FrameSource> CameraNode<S> {
    /// A node reading `source` with `processor`, its first heartbeat due at `now_ms`.
    pub fn new(source: S, processor: Processor, now_ms: u32) -> Self {
        CameraNode {
            source,
            processor,
            last: None,
            heartbeat: HeartbeatSender::new(DEFAULT_PERIOD_MS, now_ms),
            mode: BusMode::Classic,
            stats: NodeStats::default(),
        }
    }

    /// The frames it sends long messages in.
    pub fn mode(&self) -> BusMode {
        self.mode
    }

    /// Its counters.
    pub fn stats(&self) -> NodeStats {
        self.stats
    }

    /// Its frame source.
    pub fn source(&self) -> &S {
        &self.source
    }

    /// When it next has something to send unasked (ms, the clock of `now_ms`).
    pub fn poll_timeout(&self) -> u32 {
        self.heartbeat.next_due_ms()
    }

    /// What is due at `now_ms` (its heartbeat) into `out`.
    pub fn poll(&mut self, now_ms: u32, out: &mut Vec<Envelope>) {
        if let Some(hb) = self.heartbeat.poll(now_ms, NodeState::Operational) {
            out.push(Envelope::new(NodeId::CameraProcessor, hb));
        }
    }

    /// A message heard on the bus; what it sends in answer goes into `out`.
    pub fn on_message(&mut self, env: &Envelope, out: &mut Vec<Envelope>) -> Served {
        if let (NodeId::Controller, Message::SessionConfig(s)) = (env.node, env.msg) {
            self.mode = if s.fd { BusMode::Fd } else { BusMode::Classic };
            return Served::Nothing;
        }
        let (NodeId::CameraProcessor, Message::CaptureRequest(req)) = (env.node, env.msg) else {
            return Served::Nothing;
        };
        if let Some(last) = self.last {
            if last.seq == req.seq && last.what == req.what {
                self.stats.repeats += 1;
                out.push(Envelope::new(NodeId::CameraProcessor, last.into()));
                return Served::Repeat;
            }
            let behind = last.seq.wrapping_sub(req.seq);
            if behind != 0 && behind < 0x8000 {
                self.stats.stale += 1;
                return Served::Stale;
            }
        }
        let read = self
            .source
            .capture(req.what)
            .and_then(|frames| self.processor.observe(&frames));
        let (points, failed) = match read {
            Ok(o) => {
                self.stats.captures += 1;
                self.stats.inconsistent += o.inconsistent as u64;
                (o.points, None)
            }
            Err(e) => {
                self.stats.failed += 1;
                ([PixelPoint::UNUSED; 4], Some(e.to_string()))
            }
        };
        let obs = Observation {
            seq: req.seq,
            what: req.what,
            points,
        };
        self.stats.valid_points += obs
            .used_points()
            .iter()
            .filter(|p| p.status == trn_protocol::PointStatus::Valid)
            .count() as u64;
        self.last = Some(obs);
        out.push(Envelope::new(NodeId::CameraProcessor, obs.into()));
        match failed {
            None => Served::Capture(obs),
            Some(why) => Served::Failed(why),
        }
    }
}

#[cfg(test)]
mod tests;
