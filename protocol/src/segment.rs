//! Encoding messages into frames: single classical frames, whole FD frames, and the
//! segmentation of long messages on CAN 2.0.
//!
//! Layouts (see SPEC.md):
//! * short kind (payload ≤ 8 bytes): the payload, in a classical frame (or FD frame on an
//!   FD bus), DLC = payload length;
//! * long kind on FD: `payload ‖ crc32_le`, zero-padded to the next FD length;
//! * long kind on CAN 2.0: the stream `payload ‖ crc32_le` split into segments. Byte 0 of
//!   each segment is `transfer_id << 4 | index`; segment 0 carries the payload length in
//!   byte 1 and 6 stream bytes, later segments 7 stream bytes; every segment but the last
//!   is 8 bytes long, the last exactly as long as needed.
//!
//! The CRC-32 (ISO-HDLC) covers the 11-bit id (2 bytes, little endian) and the payload.

use crate::envelope::{BusMode, Envelope};
use crate::error::{Error, Result};
use crate::frame::{fd_len_for, CanFrame, FD_MAX};
use crate::kind::MessageKind;
use crate::message::MESSAGE_BUDGET;

/// Length of the trailing CRC of long messages.
pub const CRC_LEN: usize = 4;
/// Longest stream (payload + CRC) of a long message: one FD frame. So a long kind's
/// payload may be at most 60 bytes (asserted per kind in `message.rs`), stricter than the
/// 62-byte [`MESSAGE_BUDGET`] on the postcard encoding.
pub const STREAM_MAX: usize = FD_MAX;
const _: () = assert!(MESSAGE_BUDGET <= FD_MAX);
/// Stream bytes in the first segment.
pub const FIRST_DATA: usize = 6;
/// Stream bytes in every later segment.
pub const NEXT_DATA: usize = 7;
/// Most frames one message can need.
pub const MAX_SEGMENTS: usize = 1 + (STREAM_MAX - FIRST_DATA).div_ceil(NEXT_DATA);

const _: () = assert!(MAX_SEGMENTS <= 16, "segment index is 4 bits");

/// Frames of one encoded message.
pub type Frames = heapless::Vec<CanFrame, MAX_SEGMENTS>;

const CRC32: crc::Crc<u32> = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC);

/// CRC-32 over the raw id (LE) and the payload.
pub(crate) fn message_crc(raw_id: u16, payload: &[u8]) -> u32 {
    let mut d = CRC32.digest();
    d.update(&raw_id.to_le_bytes());
    d.update(payload);
    d.finalize()
}

/// Number of segments a long kind needs on CAN 2.0.
pub const fn segment_count(kind: MessageKind) -> usize {
    let stream = kind.wire_len() + CRC_LEN;
    1 + (stream - FIRST_DATA).div_ceil(NEXT_DATA)
}

/// Required frame length of segment `index` of a long kind.
pub const fn segment_len(kind: MessageKind, index: usize) -> usize {
    let stream = kind.wire_len() + CRC_LEN;
    let count = segment_count(kind);
    if index + 1 < count {
        8
    } else if index == 0 {
        2 + stream
    } else {
        1 + (stream - FIRST_DATA - (count - 2) * NEXT_DATA)
    }
}

/// Encodes `env` for a bus in `mode` into `out` (cleared first). `transfer_id` (low 4 bits
/// used) tags the segments of a segmented message; use [`Encoder`] to get a rolling id.
///
/// ```
/// use trn_protocol::{encode, BusMode, Envelope, Frames, Message, NodeId, PressureCommand};
/// let env = Envelope::new(NodeId::servo(0)?, Message::PressureCommand(PressureCommand { seq: 1, raw: 2048 }));
/// let mut frames = Frames::new();
/// encode(&env, BusMode::Classic, 0, &mut frames)?;
/// assert_eq!(frames.len(), 1);
/// assert_eq!(frames[0].raw_id(), 0x082);
/// assert_eq!(frames[0].payload(), &[1, 0, 0x00, 0x08]);
/// # Ok::<(), trn_protocol::Error>(())
/// ```
pub fn encode(env: &Envelope, mode: BusMode, transfer_id: u8, out: &mut Frames) -> Result<()> {
    out.clear();
    let id = env.can_id()?;
    env.msg.validate()?;
    let raw_id = id.raw();
    let kind = id.kind;
    let mut stream = [0u8; STREAM_MAX];
    let len = env.msg.encode_payload(&mut stream)?;
    let push = |out: &mut Frames, f: CanFrame| out.push(f).map_err(|_| Error::Encode);
    if kind.is_single_frame() {
        let f = CanFrame::new_checked(raw_id, &stream[..len], mode == BusMode::Fd)?;
        return push(out, f);
    }
    let crc = message_crc(raw_id, &stream[..len]);
    stream[len..len + CRC_LEN].copy_from_slice(&crc.to_le_bytes());
    let total = len + CRC_LEN;
    match mode {
        BusMode::Fd => {
            let padded = fd_len_for(total).ok_or(Error::Encode)?;
            // stream is zero beyond `total`, so the padding is zero.
            let mut buf = [0u8; FD_MAX];
            buf[..total].copy_from_slice(&stream[..total]);
            push(out, CanFrame::fd(raw_id, &buf[..padded])?)
        }
        BusMode::Classic => {
            let tid = (transfer_id & 0x0F) << 4;
            let mut buf = [0u8; 8];
            buf[0] = tid;
            buf[1] = len as u8;
            let first = total.min(FIRST_DATA);
            buf[2..2 + first].copy_from_slice(&stream[..first]);
            push(out, CanFrame::classic(raw_id, &buf[..2 + first])?)?;
            let mut pos = first;
            let mut index = 1u8;
            while pos < total {
                let n = (total - pos).min(NEXT_DATA);
                buf[0] = tid | index;
                buf[1..1 + n].copy_from_slice(&stream[pos..pos + n]);
                push(out, CanFrame::classic(raw_id, &buf[..1 + n])?)?;
                pos += n;
                index += 1;
            }
            Ok(())
        }
    }
}

/// Encodes messages with a rolling 4-bit transfer id.
#[derive(Debug, Clone)]
pub struct Encoder {
    mode: BusMode,
    next_transfer: u8,
}

impl Encoder {
    /// An encoder for a bus in `mode`.
    pub const fn new(mode: BusMode) -> Encoder {
        Encoder {
            mode,
            next_transfer: 0,
        }
    }

    /// Switches the bus mode for the messages encoded from now on (the transfer id goes on
    /// counting).
    pub fn set_mode(&mut self, mode: BusMode) {
        self.mode = mode;
    }

    /// The bus mode.
    pub const fn mode(&self) -> BusMode {
        self.mode
    }

    /// Encodes one message into its frames.
    pub fn encode(&mut self, env: &Envelope) -> Result<Frames> {
        let mut out = Frames::new();
        encode(env, self.mode, self.next_transfer, &mut out)?;
        if out.len() > 1 {
            self.next_transfer = (self.next_transfer + 1) & 0x0F;
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn segment_lengths_add_up() {
        for &kind in MessageKind::ALL {
            if kind.is_single_frame() {
                continue;
            }
            let count = segment_count(kind);
            assert!(count <= MAX_SEGMENTS);
            let carried: usize = (0..count)
                .map(|i| segment_len(kind, i) - if i == 0 { 2 } else { 1 })
                .sum();
            assert_eq!(carried, kind.wire_len() + CRC_LEN, "{kind:?}");
            for i in 0..count {
                assert!(segment_len(kind, i) <= 8 && segment_len(kind, i) >= 2);
            }
        }
        assert_eq!(MAX_SEGMENTS, 10);
    }
}
