//! [`Reassembler`]: turns received frames back into [`Envelope`]s.
//!
//! Bounded: a fixed number of slots (one per CAN id with a transfer in progress), each a
//! fixed buffer; nothing grows. The crate never reads a clock: the caller passes `now_ms`.

use crate::envelope::Envelope;
use crate::error::{Error, Result};
use crate::frame::{fd_len_for, CanFrame};
use crate::message::Message;
use crate::segment::{
    message_crc, segment_count, segment_len, CRC_LEN, FIRST_DATA, NEXT_DATA, STREAM_MAX,
};
use crate::{id::CanId, kind::MessageKind};

/// Default stale timeout for an incomplete transfer, ms.
pub const DEFAULT_STALE_MS: u32 = 100;

#[derive(Debug, Clone)]
struct Slot {
    id: u16,
    kind: MessageKind,
    transfer: u8,
    next: u8,
    filled: usize,
    last_ms: u32,
    buf: [u8; STREAM_MAX],
}

/// Reassembles segmented messages and decodes single frames.
///
/// `SLOTS` transfers (distinct CAN ids) can be in progress at once. A first segment that
/// finds every slot busy evicts a stale transfer if there is one, else it is dropped with
/// [`Error::NoFreeSlot`].
///
/// ```
/// use trn_protocol::*;
/// let obs = Observation::centre(7, PixelPoint::valid(10.0, 20.0), PixelPoint::valid(30.0, 40.0));
/// let env = Envelope::new(NodeId::CameraProcessor, obs.into());
/// let frames = Encoder::new(BusMode::Classic).encode(&env)?;
/// assert_eq!(frames.len(), 7);
/// let mut rx: Reassembler = Reassembler::new(DEFAULT_STALE_MS);
/// let mut got = None;
/// for f in &frames {
///     got = rx.push(f, 0)?;
/// }
/// assert_eq!(got, Some(env));
/// # Ok::<(), trn_protocol::Error>(())
/// ```
#[derive(Debug, Clone)]
pub struct Reassembler<const SLOTS: usize = 8> {
    slots: heapless::Vec<Slot, SLOTS>,
    stale_ms: u32,
}

impl<const SLOTS: usize> Reassembler<SLOTS> {
    /// A reassembler discarding transfers with no progress for more than `stale_ms`.
    pub const fn new(stale_ms: u32) -> Self {
        Reassembler {
            slots: heapless::Vec::new(),
            stale_ms,
        }
    }

    /// Number of transfers in progress.
    pub fn in_progress(&self) -> usize {
        self.slots.len()
    }

    fn is_stale(&self, slot: &Slot, now_ms: u32) -> bool {
        now_ms.wrapping_sub(slot.last_ms) > self.stale_ms
    }

    /// Discards every stale transfer, returning how many were discarded.
    pub fn expire(&mut self, now_ms: u32) -> usize {
        let before = self.slots.len();
        let stale_ms = self.stale_ms;
        self.slots
            .retain(|s| now_ms.wrapping_sub(s.last_ms) <= stale_ms);
        before - self.slots.len()
    }

    /// Feeds one received frame. Returns `Ok(Some(envelope))` when a message is complete,
    /// `Ok(None)` when a segment was accepted, or a typed error for a malformed, lost,
    /// duplicated, reordered, truncated, corrupt or stale input. A failed frame never
    /// corrupts another transfer's state.
    pub fn push(&mut self, frame: &CanFrame, now_ms: u32) -> Result<Option<Envelope>> {
        let id = CanId::from_raw(frame.raw_id())?;
        let kind = id.kind;
        let data = frame.payload();
        if kind.is_single_frame() {
            let msg = Message::decode_payload(kind, data)?;
            return Ok(Some(Envelope::new(id.node, msg)));
        }
        if frame.is_fd() {
            return decode_whole_fd(id, data).map(Some);
        }
        self.push_segment(id, data, now_ms)
    }

    fn push_segment(&mut self, id: CanId, data: &[u8], now_ms: u32) -> Result<Option<Envelope>> {
        let kind = id.kind;
        let raw_id = id.raw();
        let header = *data.first().ok_or(Error::WrongLength {
            expected: 2,
            got: 0,
        })?;
        let transfer = header >> 4;
        let index = header & 0x0F;
        let count = segment_count(kind);
        if index as usize >= count {
            return Err(Error::BadSegmentHeader);
        }
        let expected = segment_len(kind, index as usize);
        if data.len() != expected {
            return Err(Error::WrongLength {
                expected,
                got: data.len(),
            });
        }
        let existing = self.slots.iter().position(|s| s.id == raw_id);
        // A transfer that made no progress for too long is discarded first.
        let mut stale = false;
        if let Some(i) = existing {
            if self.is_stale(&self.slots[i], now_ms) {
                self.slots.swap_remove(i);
                stale = true;
            }
        }
        let existing = if stale { None } else { existing };

        if index == 0 {
            if data[1] as usize != kind.wire_len() {
                return Err(Error::BadSegmentHeader);
            }
            let mut aborted = false;
            let slot_index = match existing {
                Some(i) => {
                    let s = &self.slots[i];
                    // A true duplicate repeats the stored bytes; the same transfer id
                    // with other bytes is a later transfer after the id wrapped.
                    if s.transfer == transfer && s.buf[..FIRST_DATA] == data[2..] {
                        return Err(Error::DuplicateSegment { index: 0 });
                    }
                    aborted = true;
                    i
                }
                None => self.allocate(now_ms)?,
            };
            let s = &mut self.slots[slot_index];
            s.id = raw_id;
            s.kind = kind;
            s.transfer = transfer;
            s.next = 1;
            s.last_ms = now_ms;
            s.buf[..FIRST_DATA].copy_from_slice(&data[2..2 + FIRST_DATA]);
            s.filled = FIRST_DATA;
            return if stale {
                Err(Error::Stale)
            } else if aborted {
                Err(Error::TransferAborted)
            } else {
                Ok(None)
            };
        }

        let Some(i) = existing else {
            return Err(if stale {
                Error::Stale
            } else {
                Error::OrphanSegment
            });
        };
        let s = &mut self.slots[i];
        if s.transfer != transfer {
            // A stray segment of another transfer: ignore it, keep the transfer.
            return Err(Error::TransferMismatch);
        }
        if index < s.next {
            let at = FIRST_DATA + (index as usize - 1) * NEXT_DATA;
            if s.buf[at..at + data.len() - 1] == data[1..] {
                return Err(Error::DuplicateSegment { index });
            }
            // Same transfer id, other bytes: the transfer we hold is not the sender's
            // current one. Discard it.
            self.slots.swap_remove(i);
            return Err(Error::TransferMismatch);
        }
        if index > s.next {
            let expected = s.next;
            self.slots.swap_remove(i);
            return Err(Error::SequenceGap {
                expected,
                got: index,
            });
        }
        let n = data.len() - 1;
        s.buf[s.filled..s.filled + n].copy_from_slice(&data[1..]);
        s.filled += n;
        s.next += 1;
        s.last_ms = now_ms;
        if (s.next as usize) < count {
            return Ok(None);
        }
        let slot = self.slots.swap_remove(i);
        let len = kind.wire_len();
        debug_assert_eq!(slot.filled, len + CRC_LEN);
        check_crc(raw_id, &slot.buf[..len], &slot.buf[len..len + CRC_LEN])?;
        let msg = Message::decode_payload(kind, &slot.buf[..len])?;
        Ok(Some(Envelope::new(id.node, msg)))
    }

    fn allocate(&mut self, now_ms: u32) -> Result<usize> {
        let blank = Slot {
            id: 0,
            kind: MessageKind::Heartbeat,
            transfer: 0,
            next: 0,
            filled: 0,
            last_ms: now_ms,
            buf: [0; STREAM_MAX],
        };
        if self.slots.push(blank.clone()).is_ok() {
            return Ok(self.slots.len() - 1);
        }
        let stale = self.slots.iter().position(|s| self.is_stale(s, now_ms));
        match stale {
            Some(i) => {
                self.slots[i] = blank;
                Ok(i)
            }
            None => Err(Error::NoFreeSlot),
        }
    }
}

fn check_crc(raw_id: u16, payload: &[u8], crc_bytes: &[u8]) -> Result<()> {
    let mut b = [0u8; CRC_LEN];
    b.copy_from_slice(crc_bytes);
    let received = u32::from_le_bytes(b);
    let computed = message_crc(raw_id, payload);
    if received == computed {
        Ok(())
    } else {
        Err(Error::Checksum { received, computed })
    }
}

fn decode_whole_fd(id: CanId, data: &[u8]) -> Result<Envelope> {
    let len = id.kind.wire_len();
    let total = len + CRC_LEN;
    let expected = fd_len_for(total).ok_or(Error::Encode)?;
    if data.len() != expected {
        return Err(Error::WrongLength {
            expected,
            got: data.len(),
        });
    }
    if data[total..].iter().any(|&b| b != 0) {
        return Err(Error::BadPadding);
    }
    check_crc(id.raw(), &data[..len], &data[len..total])?;
    let msg = Message::decode_payload(id.kind, &data[..len])?;
    Ok(Envelope::new(id.node, msg))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::envelope::BusMode;
    use crate::message::*;
    use crate::node::NodeId;
    use crate::segment::{Encoder, Frames};

    fn long_env(trial: u32) -> Envelope {
        Envelope::new(
            NodeId::Controller,
            Message::Stage1Target(Stage1Target {
                trial,
                learn: true,
                grasp: false,
                fine_moves: crate::FINE_MOVES_POLICY,
                v: [1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0],
            }),
        )
    }

    fn frames(enc: &mut Encoder, trial: u32) -> Frames {
        enc.encode(&long_env(trial)).unwrap()
    }

    #[test]
    fn in_order_segments_complete() {
        let mut enc = Encoder::new(BusMode::Classic);
        let fs = frames(&mut enc, 1);
        assert_eq!(fs.len(), 7);
        let mut rx: Reassembler = Reassembler::new(100);
        for f in &fs[..6] {
            assert_eq!(rx.push(f, 0), Ok(None));
        }
        assert_eq!(rx.push(&fs[6], 0), Ok(Some(long_env(1))));
        assert_eq!(rx.in_progress(), 0);
    }

    #[test]
    fn lost_segment_is_a_gap() {
        let mut enc = Encoder::new(BusMode::Classic);
        let fs = frames(&mut enc, 1);
        let mut rx: Reassembler = Reassembler::new(100);
        rx.push(&fs[0], 0).unwrap();
        rx.push(&fs[1], 0).unwrap();
        assert_eq!(
            rx.push(&fs[3], 0),
            Err(Error::SequenceGap {
                expected: 2,
                got: 3
            })
        );
        assert_eq!(rx.push(&fs[4], 0), Err(Error::OrphanSegment));
    }

    #[test]
    fn duplicate_is_ignored_and_transfer_continues() {
        let mut enc = Encoder::new(BusMode::Classic);
        let fs = frames(&mut enc, 1);
        let mut rx: Reassembler = Reassembler::new(100);
        rx.push(&fs[0], 0).unwrap();
        assert_eq!(
            rx.push(&fs[0], 0),
            Err(Error::DuplicateSegment { index: 0 })
        );
        rx.push(&fs[1], 0).unwrap();
        assert_eq!(
            rx.push(&fs[1], 0),
            Err(Error::DuplicateSegment { index: 1 })
        );
        for f in &fs[2..6] {
            rx.push(f, 0).unwrap();
        }
        assert_eq!(rx.push(&fs[6], 0), Ok(Some(long_env(1))));
    }

    #[test]
    fn lost_tail_then_new_transfer_aborts_old() {
        let mut enc = Encoder::new(BusMode::Classic);
        let a = frames(&mut enc, 1);
        let b = frames(&mut enc, 2);
        let mut rx: Reassembler = Reassembler::new(100);
        rx.push(&a[0], 0).unwrap();
        assert_eq!(rx.push(&b[0], 0), Err(Error::TransferAborted));
        assert_eq!(rx.push(&a[1], 0), Err(Error::TransferMismatch));
        for f in &b[1..6] {
            rx.push(f, 0).unwrap();
        }
        assert_eq!(rx.push(&b[6], 0), Ok(Some(long_env(2))));
    }

    #[test]
    fn truncated_and_corrupt_segments() {
        let mut enc = Encoder::new(BusMode::Classic);
        let fs = frames(&mut enc, 1);
        let mut rx: Reassembler = Reassembler::new(100);
        let short = CanFrame::classic(fs[1].raw_id(), &fs[1].payload()[..5]).unwrap();
        rx.push(&fs[0], 0).unwrap();
        assert_eq!(
            rx.push(&short, 0),
            Err(Error::WrongLength {
                expected: 8,
                got: 5
            })
        );
        let mut bytes = [0u8; 8];
        bytes.copy_from_slice(fs[1].payload());
        bytes[4] ^= 0x40;
        let bad = CanFrame::classic(fs[1].raw_id(), &bytes).unwrap();
        rx.push(&bad, 0).unwrap();
        for f in &fs[2..6] {
            rx.push(f, 0).unwrap();
        }
        assert!(matches!(rx.push(&fs[6], 0), Err(Error::Checksum { .. })));
    }

    #[test]
    fn stale_transfer_is_reported_and_wrapping_time_works() {
        let mut enc = Encoder::new(BusMode::Classic);
        let fs = frames(&mut enc, 1);
        let mut rx: Reassembler = Reassembler::new(100);
        let t0 = u32::MAX - 10;
        rx.push(&fs[0], t0).unwrap();
        rx.push(&fs[1], t0.wrapping_add(50)).unwrap();
        assert_eq!(rx.push(&fs[2], t0.wrapping_add(200)), Err(Error::Stale));
        assert_eq!(rx.in_progress(), 0);
        rx.push(&fs[0], 0).unwrap();
        assert_eq!(rx.expire(50), 0);
        assert_eq!(rx.expire(101), 1);
    }

    #[test]
    fn slots_are_bounded() {
        let mut rx: Reassembler<2> = Reassembler::new(100);
        let mk = |kind_env: Envelope| Encoder::new(BusMode::Classic).encode(&kind_env).unwrap();
        let a = mk(long_env(1));
        let b = mk(Envelope::new(
            NodeId::Controller,
            Message::Stage2Target(Stage2Target {
                trial: 1,
                learn: false,
                grasp: true,
                fine_moves: crate::FINE_MOVES_POLICY,
                c: [0.0; 4],
            }),
        ));
        let c = mk(Envelope::new(
            NodeId::Controller,
            Message::SupervisedPressure(SupervisedPressure {
                trial: 1,
                p: [0.0; 5],
            }),
        ));
        rx.push(&a[0], 0).unwrap();
        rx.push(&b[0], 0).unwrap();
        assert_eq!(rx.push(&c[0], 10), Err(Error::NoFreeSlot));
        // Once stale, a slot is reused.
        assert_eq!(rx.push(&c[0], 500), Ok(None));
        assert_eq!(rx.in_progress(), 2);
    }

    #[test]
    fn fd_whole_frame_checks_crc_and_padding() {
        let env = long_env(3);
        let fs = Encoder::new(BusMode::Fd).encode(&env).unwrap();
        assert_eq!(fs.len(), 1);
        assert!(fs[0].is_fd());
        assert_eq!(fs[0].len(), 48);
        let mut rx: Reassembler = Reassembler::new(100);
        assert_eq!(rx.push(&fs[0], 0), Ok(Some(env)));
        let mut bytes = [0u8; 48];
        bytes.copy_from_slice(fs[0].payload());
        bytes[47] = 1;
        let f = CanFrame::fd(fs[0].raw_id(), &bytes).unwrap();
        assert_eq!(rx.push(&f, 0), Err(Error::BadPadding));
        bytes[47] = 0;
        bytes[10] ^= 1;
        let f = CanFrame::fd(fs[0].raw_id(), &bytes).unwrap();
        assert!(matches!(rx.push(&f, 0), Err(Error::Checksum { .. })));
    }
}
