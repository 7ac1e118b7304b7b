//! One slot's header, the commit record of a stored copy: its byte layout, encoding and
//! checks. The header is programmed last, after the image was written and read back.
//!
//! | bytes | field |
//! |---|---|
//! | 0..4 | magic `TRNS` |
//! | 4..6 | store format version (u16 LE, [`FORMAT`]) |
//! | 6 | preset code of the tables' provenance |
//! | 7 | ablation code |
//! | 8..12 | sequence number (u32 LE): one above the newest copy when written |
//! | 12..16 | image length in bytes (u32 LE) |
//! | 16..20 | configuration fingerprint of the image's header (u32 LE) |
//! | 20..24 | the image's CRC-32 (its last four bytes) |
//! | 24..28 | stage-1 learning steps (u32 LE) |
//! | 28..32 | stage-2 learning steps (u32 LE) |
//! | 32..36 | CRC-32/ISO-HDLC of bytes 0..32 |
//!
//! The image follows at [`crate::FlashStore`]'s image offset in the same slot.

/// The magic that starts a slot header.
pub const MAGIC: [u8; 4] = *b"TRNS";
/// The store format this build writes and reads.
pub const FORMAT: u16 = 1;
/// Encoded length of a header.
pub const HEADER_LEN: usize = 36;

/// CRC-32/ISO-HDLC, the checkpoint's own (one table of 1 KiB in a firmware, not two).
fn crc(bytes: &[u8]) -> u32 {
    trn_controller::checkpoint::crc32(bytes)
}

/// A slot's header.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SlotHeader {
    /// Store format version.
    pub format: u16,
    /// Preset and ablation codes of the tables' configuration.
    pub provenance: (u8, u8),
    /// Sequence number.
    pub sequence: u32,
    /// Image length in bytes.
    pub len: u32,
    /// Configuration fingerprint of the image.
    pub fingerprint: u32,
    /// The image's CRC-32 (its trailing four bytes).
    pub image_crc: u32,
    /// Stage-1 and stage-2 learning steps of the image.
    pub steps: (u32, u32),
}

/// What a slot's header area holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Decoded {
    /// Erased (every byte 0xFF): no copy.
    Erased,
    /// Not a complete header: a torn write, a bit flip, another use of the flash.
    Invalid,
    /// A complete header.
    Valid(SlotHeader),
}

fn u32_at(b: &[u8], at: usize) -> u32 {
    u32::from_le_bytes([b[at], b[at + 1], b[at + 2], b[at + 3]])
}

impl SlotHeader {
    /// The header's bytes.
    pub fn encode(&self) -> [u8; HEADER_LEN] {
        let mut b = [0u8; HEADER_LEN];
        b[0..4].copy_from_slice(&MAGIC);
        b[4..6].copy_from_slice(&self.format.to_le_bytes());
        b[6] = self.provenance.0;
        b[7] = self.provenance.1;
        for (at, v) in [
            (8, self.sequence),
            (12, self.len),
            (16, self.fingerprint),
            (20, self.image_crc),
            (24, self.steps.0),
            (28, self.steps.1),
        ] {
            b[at..at + 4].copy_from_slice(&v.to_le_bytes());
        }
        let crc = crc(&b[..32]);
        b[32..36].copy_from_slice(&crc.to_le_bytes());
        b
    }

    /// Reads a header area: erased, invalid (wrong magic or CRC), or a header (of any format
    /// version: the caller refuses one it does not read).
    pub fn decode(b: &[u8; HEADER_LEN]) -> Decoded {
        if b.iter().all(|&x| x == 0xFF) {
            return Decoded::Erased;
        }
        if b[0..4] != MAGIC || crc(&b[..32]) != u32_at(b, 32) {
            return Decoded::Invalid;
        }
        Decoded::Valid(SlotHeader {
            format: u16::from_le_bytes([b[4], b[5]]),
            provenance: (b[6], b[7]),
            sequence: u32_at(b, 8),
            len: u32_at(b, 12),
            fingerprint: u32_at(b, 16),
            image_crc: u32_at(b, 20),
            steps: (u32_at(b, 24), u32_at(b, 28)),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn header() -> SlotHeader {
        SlotHeader {
            format: FORMAT,
            provenance: (0, 2),
            sequence: 7,
            len: 227_239,
            fingerprint: 0xDEAD_BEEF,
            image_crc: 0x1234_5678,
            steps: (1500, 700),
        }
    }

    #[test]
    fn a_header_round_trips() {
        assert_eq!(
            SlotHeader::decode(&header().encode()),
            Decoded::Valid(header())
        );
        assert_eq!(SlotHeader::decode(&[0xFF; HEADER_LEN]), Decoded::Erased);
    }

    /// Any single bit flip, and any torn write (a prefix programmed, the rest erased), is
    /// told apart from a header.
    #[test]
    fn flips_and_torn_writes_are_invalid() {
        let good = header().encode();
        for i in 0..HEADER_LEN * 8 {
            let mut b = good;
            b[i / 8] ^= 1 << (i % 8);
            assert_eq!(SlotHeader::decode(&b), Decoded::Invalid, "bit {i}");
        }
        for cut in 1..HEADER_LEN {
            let mut b = [0xFF; HEADER_LEN];
            b[..cut].copy_from_slice(&good[..cut]);
            assert_eq!(SlotHeader::decode(&b), Decoded::Invalid, "cut at {cut}");
        }
    }
}
