//! [`LogDecoder`]: every frame of a log (a candump file, a capture) as the messages it
//! carries, segmented ones included, with the frames that carried no message and why.
//!
//! The decoder is the receivers' own ([`Reassembler`]): a kind added to the protocol is
//! decoded here, by `trn decode` and by the Python package without a change. Time comes
//! from the frames' timestamps, so a transfer left incomplete for longer than the stale
//! timeout is discarded as a receiver would discard it.
//!
//! ```
//! use trn_protocol::decode::{LogDecoder, Outcome};
//! use trn_protocol::*;
//! let obs = Observation::centre(7, PixelPoint::valid(10.0, 20.0), PixelPoint::valid(30.0, 40.0));
//! let env = Envelope::new(NodeId::CameraProcessor, obs.into());
//! let mut dec = LogDecoder::new();
//! let mut last = None;
//! for (i, f) in Encoder::new(BusMode::Classic).encode(&env)?.iter().enumerate() {
//!     last = Some(dec.push(f, 1_000 * i as u64));
//! }
//! assert_eq!(last.unwrap().outcome, Outcome::Message(env));
//! let s = dec.finish();
//! assert_eq!((s.frames, s.messages, s.undecoded), (7, 1, 0));
//! # Ok::<(), trn_protocol::Error>(())
//! ```

use std::collections::BTreeMap;

use crate::envelope::Envelope;
use crate::error::Error;
use crate::frame::CanFrame;
use crate::reassembly::{Reassembler, DEFAULT_STALE_MS};
use crate::segment::segment_count;
use crate::{id::CanId, kind::MessageKind};

/// What one frame was.
#[derive(Debug, Clone, PartialEq)]
pub enum Outcome {
    /// A whole message: a single frame, an FD frame, or the last segment of a segmented one.
    Message(Envelope),
    /// A segment of a message still being assembled.
    Segment {
        /// The message's kind.
        kind: MessageKind,
        /// The segment's index.
        index: u8,
        /// The message's segment count.
        count: u8,
        /// The transfer id of its message.
        transfer: u8,
    },
    /// The frame carries no message: why.
    Error(Error),
}

/// One frame of the log, decoded.
#[derive(Debug, Clone, PartialEq)]
pub struct Decoded {
    /// The frame's position in the log (0 = the first frame).
    pub index: usize,
    /// What it was.
    pub outcome: Outcome,
}

/// The counts of a decoded log.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Summary {
    /// Frames read.
    pub frames: usize,
    /// Messages decoded (a segmented message counts once).
    pub messages: usize,
    /// Frames that are part of no decoded message: rejected frames, duplicates, and the
    /// segments of transfers that never completed.
    pub undecoded: usize,
}

/// Decodes a log frame by frame (see the module).
#[derive(Debug, Clone)]
pub struct LogDecoder {
    rx: Reassembler<16>,
    /// The frames of each id's transfer in progress.
    pending: BTreeMap<u16, Vec<usize>>,
    summary: Summary,
    decoded_frames: usize,
}

impl Default for LogDecoder {
    fn default() -> Self {
        Self::new()
    }
}

impl LogDecoder {
    /// A decoder with the receivers' stale timeout ([`DEFAULT_STALE_MS`]).
    pub fn new() -> Self {
        LogDecoder {
            rx: Reassembler::new(DEFAULT_STALE_MS),
            pending: BTreeMap::new(),
            summary: Summary::default(),
            decoded_frames: 0,
        }
    }

    /// Decodes the next frame of the log, received at `timestamp_us`.
    pub fn push(&mut self, frame: &CanFrame, timestamp_us: u64) -> Decoded {
        let index = self.summary.frames;
        self.summary.frames += 1;
        let raw = frame.raw_id();
        // wrapping milliseconds, as every receiver counts time
        let now_ms = (timestamp_us / 1000) as u32;
        let outcome = match self.rx.push(frame, now_ms) {
            Ok(Some(env)) => {
                let parts = self.pending.remove(&raw).map_or(0, |p| p.len());
                self.decoded_frames += parts + 1;
                self.summary.messages += 1;
                Outcome::Message(env)
            }
            Ok(None) => {
                let seg = segment_of(frame);
                if seg.map(|(_, index, _, _)| index) == Some(0) {
                    // a first segment starts the transfer afresh
                    self.pending.insert(raw, vec![index]);
                } else {
                    self.pending.entry(raw).or_default().push(index);
                }
                match seg {
                    Some((kind, index, count, transfer)) => Outcome::Segment {
                        kind,
                        index,
                        count,
                        transfer,
                    },
                    None => Outcome::Error(Error::BadSegmentHeader),
                }
            }
            // the incomplete transfer before it is discarded (its frames stay undecoded);
            // this first segment starts a new one
            Err(Error::TransferAborted) => {
                self.pending.insert(raw, vec![index]);
                match segment_of(frame) {
                    Some((kind, index, count, transfer)) => Outcome::Segment {
                        kind,
                        index,
                        count,
                        transfer,
                    },
                    None => Outcome::Error(Error::TransferAborted),
                }
            }
            Err(e) => {
                match e {
                    // ignored, the transfer in progress kept (a mismatch that discarded it
                    // shows at its next segment, an orphan)
                    Error::DuplicateSegment { .. }
                    | Error::NoFreeSlot
                    | Error::TransferMismatch => {}
                    // the transfer in progress (if any) is discarded
                    _ => {
                        self.pending.remove(&raw);
                    }
                }
                Outcome::Error(e)
            }
        };
        Decoded { index, outcome }
    }

    /// The counts so far: every frame not part of a decoded message is undecoded,
    /// segments of transfers still incomplete included.
    pub fn summary(&self) -> Summary {
        Summary {
            undecoded: self.summary.frames - self.decoded_frames,
            ..self.summary
        }
    }

    /// The counts at the end of the log (as [`LogDecoder::summary`]).
    pub fn finish(self) -> Summary {
        self.summary()
    }
}

/// The segment header of a classical frame of a segmented kind: (kind, index, count,
/// transfer id).
fn segment_of(frame: &CanFrame) -> Option<(MessageKind, u8, u8, u8)> {
    let id = CanId::from_raw(frame.raw_id()).ok()?;
    if id.kind.is_single_frame() || frame.is_fd() {
        return None;
    }
    let header = *frame.payload().first()?;
    Some((
        id.kind,
        header & 0x0F,
        segment_count(id.kind) as u8,
        header >> 4,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::segment::Encoder;
    use crate::{BusMode, NodeId, PixelPoint, Stage1Target};

    fn target(trial: u32) -> Envelope {
        let m = Stage1Target {
            trial,
            learn: true,
            grasp: false,
            fine_moves: 3,
            v: [1.0; 8],
        };
        Envelope::new(NodeId::Controller, m.into())
    }

    #[test]
    fn every_frame_of_clean_traffic_is_decoded() {
        let mut enc = Encoder::new(BusMode::Classic);
        let mut dec = LogDecoder::new();
        let hb = Envelope::new(
            NodeId::Controller,
            crate::Heartbeat {
                counter: 1,
                state: crate::NodeState::Operational,
            }
            .into(),
        );
        let mut messages = Vec::new();
        for (t, env) in [target(1), hb, target(2)].into_iter().enumerate() {
            for f in enc.encode(&env).unwrap().iter() {
                if let Outcome::Message(m) = dec.push(f, t as u64 * 10_000).outcome {
                    messages.push(m);
                }
            }
        }
        assert_eq!(messages, vec![target(1), hb, target(2)]);
        let s = dec.finish();
        assert_eq!((s.frames, s.messages, s.undecoded), (15, 3, 0));
    }

    #[test]
    fn lost_and_broken_frames_are_counted_undecoded() {
        let mut enc = Encoder::new(BusMode::Classic);
        let mut dec = LogDecoder::new();
        let frames = enc.encode(&target(1)).unwrap();
        // the last segment lost: the first six never make a message
        for f in frames.iter().take(6) {
            assert!(matches!(dec.push(f, 0).outcome, Outcome::Segment { .. }));
        }
        assert_eq!(dec.summary().undecoded, 6);
        // a later message on the same id replaces the incomplete one: its first segment
        // starts the new transfer
        for (i, f) in enc.encode(&target(2)).unwrap().iter().enumerate() {
            let out = dec.push(f, 1_000).outcome;
            if i == 0 {
                assert!(matches!(out, Outcome::Segment { index: 0, .. }), "{out:?}");
            }
        }
        // a frame of an unknown kind
        let junk = CanFrame::classic(0x7F1, &[1]).unwrap();
        assert!(matches!(dec.push(&junk, 2_000).outcome, Outcome::Error(_)));
        let s = dec.finish();
        assert_eq!((s.frames, s.messages, s.undecoded), (14, 1, 7));
    }

    #[test]
    fn fd_frames_are_whole_messages() {
        let obs =
            crate::Observation::centre(7, PixelPoint::valid(1.0, 2.0), PixelPoint::valid(3.0, 4.0));
        let env = Envelope::new(NodeId::CameraProcessor, obs.into());
        let frames = Encoder::new(BusMode::Fd).encode(&env).unwrap();
        let mut dec = LogDecoder::new();
        assert_eq!(frames.len(), 1);
        assert_eq!(dec.push(&frames[0], 0).outcome, Outcome::Message(env));
        assert_eq!(dec.finish().undecoded, 0);
    }
}
