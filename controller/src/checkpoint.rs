//! Checkpoints of the learned state of both networks.
//!
//! Layout (all little-endian; the header and the tables are postcard-encoded):
//!
//! | bytes | content |
//! |---|---|
//! | 4 | magic `TRNC` |
//! | varies (postcard) | [`Header`]: format version, network shapes, learning steps |
//! | 4 x values (postcard f32) | stage-1 tables, then stage-2 tables: weights, pressures, Jacobians |
//! | 4 | CRC-32 (ISO-HDLC) over everything before it |
//!
//! Restoring checks length, CRC, magic, version and shapes, and decodes into a scratch copy
//! only after all checks pass; a rejected checkpoint leaves the controller untouched.

use crate::controller::Controller;
use crate::error::{Error, Result};
use crate::net::{Stage1Net, Stage2Net};
use serde::{Deserialize, Serialize};

/// The format version this build writes and reads.
pub const VERSION: u16 = 1;
const MAGIC: [u8; 4] = *b"TRNC";
const CRC: crc::Crc<u32> = crc::Crc::<u32>::new(&crc::CRC_32_ISO_HDLC);

/// The checkpoint header.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Header {
    /// Format version.
    pub version: u16,
    /// Stage-1 neurons, input and output dimensions.
    pub shape1: [u16; 3],
    /// Stage-2 neurons, input and output dimensions.
    pub shape2: [u16; 3],
    /// Stage-1 learning steps completed.
    pub t1: u32,
    /// Stage-2 learning steps completed.
    pub t2: u32,
}

const SHAPE1: [u16; 3] = [1000, 8, 5];
const SHAPE2: [u16; 3] = [200, 4, 3];
const VALUES: usize = (Stage1Net::TABLE_BYTES + Stage2Net::TABLE_BYTES) / 4;
/// Upper bound of a header's postcard encoding (u16 + 6 x u16 + 2 x u32 as varints).
const HEADER_MAX: usize = 3 + 6 * 3 + 2 * 5;

/// Upper bound of a checkpoint's size in bytes (for buffers).
pub const MAX_SIZE: usize = 4 + HEADER_MAX + VALUES * 4 + 4;

/// Writes a checkpoint of `ctrl` into `buf` and returns its length.
pub fn save(ctrl: &Controller, buf: &mut [u8]) -> Result<usize> {
    let header = Header {
        version: VERSION,
        shape1: SHAPE1,
        shape2: SHAPE2,
        t1: ctrl.stage1().learning_step(),
        t2: ctrl.stage2().learning_step(),
    };
    if buf.len() < 4 {
        return Err(Error::BufferTooSmall { needed: MAX_SIZE });
    }
    buf[..4].copy_from_slice(&MAGIC);
    let hlen = postcard::to_slice(&header, &mut buf[4..])
        .map_err(|_| Error::BufferTooSmall { needed: MAX_SIZE })?
        .len();
    let mut pos = 4 + hlen;
    let needed = pos + VALUES * 4 + 4;
    if buf.len() < needed {
        return Err(Error::BufferTooSmall { needed });
    }
    let mut put = |x: f32| {
        // postcard encodes an f32 as its 4 little-endian bytes
        let _ = postcard::to_slice(&x, &mut buf[pos..pos + 4]);
        pos += 4;
    };
    ctrl.stage1().net().for_each_value(&mut put);
    ctrl.stage2().net().for_each_value(&mut put);
    let crc = CRC.checksum(&buf[..pos]);
    buf[pos..pos + 4].copy_from_slice(&crc.to_le_bytes());
    Ok(pos + 4)
}

/// Checks a checkpoint without restoring it and returns its header.
pub fn verify(bytes: &[u8]) -> Result<Header> {
    if bytes.len() < 8 {
        return Err(Error::CheckpointLength {
            expected: MAX_SIZE,
            found: bytes.len(),
        });
    }
    if bytes[..4] != MAGIC {
        return Err(Error::CheckpointMagic);
    }
    let (body, crc_bytes) = bytes.split_at(bytes.len() - 4);
    let stored = u32::from_le_bytes([crc_bytes[0], crc_bytes[1], crc_bytes[2], crc_bytes[3]]);
    let (header, rest) =
        postcard::take_from_bytes::<Header>(&body[4..]).map_err(|_| Error::CheckpointLength {
            expected: MAX_SIZE,
            found: bytes.len(),
        })?;
    if header.version != VERSION {
        return Err(Error::CheckpointVersion {
            found: header.version,
        });
    }
    if header.shape1 != SHAPE1 || header.shape2 != SHAPE2 {
        return Err(Error::CheckpointShape);
    }
    if rest.len() != VALUES * 4 {
        let expected = bytes.len() - rest.len() + VALUES * 4;
        return Err(Error::CheckpointLength {
            expected,
            found: bytes.len(),
        });
    }
    let computed = CRC.checksum(body);
    if computed != stored {
        return Err(Error::CheckpointCrc { stored, computed });
    }
    Ok(header)
}

/// Restores both networks from a checkpoint. On any error `ctrl` is left as it was.
pub fn restore(ctrl: &mut Controller, bytes: &[u8]) -> Result<Header> {
    if ctrl.busy() {
        return Err(Error::Busy);
    }
    let header = verify(bytes)?;
    let values = &bytes[bytes.len() - 4 - VALUES * 4..bytes.len() - 4];
    // every value must be finite before anything is written
    let all_finite = values.chunks_exact(4).all(|c| {
        postcard::from_bytes::<f32>(c)
            .map(|x| x.is_finite())
            .unwrap_or(false)
    });
    if !all_finite {
        return Err(Error::CheckpointContents);
    }
    let mut chunks = values.chunks_exact(4);
    let mut next = |x: &mut f32| {
        if let Some(c) = chunks.next() {
            *x = postcard::from_bytes::<f32>(c).unwrap_or(0.0);
        }
    };
    let (s1, s2) = ctrl.parts_mut();
    s1.net_mut().for_each_value_mut(&mut next);
    s2.net_mut().for_each_value_mut(&mut next);
    s1.restore_parts(header.t1);
    s2.restore_parts(header.t2);
    Ok(header)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Config;

    fn trained() -> Box<Controller> {
        let mut c = Box::new(Controller::new(Config::project_default()));
        c.init_random(11);
        c
    }

    #[test]
    fn round_trip_is_bit_exact() {
        let a = trained();
        let mut buf = vec![0u8; MAX_SIZE];
        let n = save(&a, &mut buf).unwrap();
        let mut b = Box::new(Controller::new(Config::project_default()));
        let h = restore(&mut b, &buf[..n]).unwrap();
        assert_eq!(h.shape1, SHAPE1);
        assert!(a.stage1().net() == b.stage1().net());
        assert!(a.stage2().net() == b.stage2().net());
        let mut buf2 = vec![0u8; MAX_SIZE];
        let n2 = save(&b, &mut buf2).unwrap();
        assert_eq!(buf[..n], buf2[..n2]);
    }

    #[test]
    fn corrupt_truncated_and_foreign_checkpoints_are_rejected() {
        let a = trained();
        let mut buf = vec![0u8; MAX_SIZE];
        let n = save(&a, &mut buf).unwrap();
        let good = buf[..n].to_vec();
        let mut target = Box::new(Controller::new(Config::project_default()));
        target.init_random(99);
        let before = target.stage1().net().clone();

        let mut flipped = good.clone();
        flipped[5000] ^= 0x10;
        assert!(matches!(
            restore(&mut target, &flipped),
            Err(Error::CheckpointCrc { .. })
        ));
        assert!(matches!(
            restore(&mut target, &good[..n - 10]),
            Err(Error::CheckpointLength { .. })
        ));
        assert!(matches!(
            restore(&mut target, &good[..3]),
            Err(Error::CheckpointLength { .. })
        ));
        let mut magic = good.clone();
        magic[0] = b'X';
        assert_eq!(restore(&mut target, &magic), Err(Error::CheckpointMagic));
        let mut version = good.clone();
        version[4] = 9;
        assert_eq!(
            restore(&mut target, &version),
            Err(Error::CheckpointVersion { found: 9 })
        );
        let mut shape = good.clone();
        shape[5] = 100; // first varint byte of shape1[0]
        assert!(matches!(
            restore(&mut target, &shape),
            Err(Error::CheckpointShape) | Err(Error::CheckpointLength { .. })
        ));
        // NaN inside with a valid CRC
        let mut nan = good.clone();
        let hl = n - 4 - VALUES * 4;
        nan[hl..hl + 4].copy_from_slice(&f32::NAN.to_le_bytes());
        let crc = CRC.checksum(&nan[..n - 4]);
        nan[n - 4..].copy_from_slice(&crc.to_le_bytes());
        assert_eq!(restore(&mut target, &nan), Err(Error::CheckpointContents));
        assert!(
            target.stage1().net() == &before,
            "a rejected checkpoint changed the tables"
        );
    }

    #[test]
    fn small_buffer_is_an_error() {
        let a = trained();
        let mut buf = vec![0u8; 100];
        assert!(matches!(
            save(&a, &mut buf),
            Err(Error::BufferTooSmall { .. })
        ));
    }
}
