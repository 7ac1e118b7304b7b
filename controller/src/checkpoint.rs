//! Checkpoints of the learned state of both networks.
//!
//! Layout (all little-endian; the header and the tables are postcard-encoded):
//!
//! | bytes | content |
//! |---|---|
//! | 4 | magic `TRNC` |
//! | varies (postcard) | [`Header`]: format version, network shapes, learning steps, preset, ablation, configuration fingerprint |
//! | 4 x values (postcard f32) | stage-1 tables, then stage-2 tables: weights, pressures, Jacobians |
//! | 4 | CRC-32 (ISO-HDLC) over everything before it |
//!
//! Restoring checks length, CRC, magic, version and shapes, the learning-step counters and
//! every value (finite, within [`VALUE_LIMITS`] and what the build's tables hold) before
//! anything is written; a rejected checkpoint leaves the controller untouched. The header's
//! preset, ablation and configuration fingerprint let the caller refuse tables learned under
//! another configuration ([`Header::config_matches`]). The values are f32 in every build: a
//! compact build (i16 tables) reads and writes the same format, rounding on restore.
//!
//! [`save`] and [`restore`] take the whole image in memory (the host). A microcontroller
//! has no RAM for it: [`ImageCursor`] and [`read_at`] produce the same bytes piece by piece
//! from the live tables, and [`restore_from`] restores from an [`ImageSource`] read in pieces
//! (a flash slot), in two passes (`stream.rs`).

use crate::controller::Controller;
use crate::error::{Error, Result};
use crate::net::{Stage1Net, Stage2Net};
use serde::{Deserialize, Serialize};

mod stream;
pub use stream::{
    check_from, read_at, restore_from, verify_from, ImageCursor, ImageSource, SourceError,
};

/// The format version this build writes and reads (2: provenance in the header).
pub const VERSION: u16 = 2;

/// The largest learning-step counter a checkpoint may hold: ten times more trials than any
/// run makes, and far from `u32::MAX`, so that continuing can never wrap.
pub const T_MAX: u32 = 100_000_000;

/// Bounds on the table values a checkpoint may hold (weights in pixels, pressures, Jacobian
/// entries): far beyond what learning produces, far below where f32 arithmetic overflows.
pub const VALUE_LIMITS: (f32, f32, f32) = (1.0e5, 1.0e3, 1.0e3);

/// Where a controller's configuration came from: the wire codes of
/// [`crate::presets::Preset`] and [`crate::presets::Ablation`], [`Provenance::CUSTOM`]
/// for a configuration built by hand (tuning, tests).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct Provenance {
    /// Preset code.
    pub preset: u8,
    /// Ablation code.
    pub ablation: u8,
}

impl Provenance {
    /// A configuration not made by a preset.
    pub const CUSTOM: Provenance = Provenance {
        preset: 0xFF,
        ablation: 0xFF,
    };

    /// The provenance of a preset and an ablation.
    pub const fn of(preset: crate::presets::Preset, ablation: crate::presets::Ablation) -> Self {
        Provenance {
            preset: preset as u8,
            ablation: ablation as u8,
        }
    }
}
const MAGIC: [u8; 4] = *b"TRNC";
use crate::crc::CRC;

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
    /// The preset and ablation the tables were learned with.
    pub provenance: Provenance,
    /// [`crate::Config::fingerprint`] of the configuration they were learned with.
    pub config_fingerprint: u32,
}

impl Header {
    /// True when the tables were learned under `cfg`.
    pub fn config_matches(&self, cfg: &crate::Config) -> bool {
        self.config_fingerprint == cfg.fingerprint()
    }
}

pub use crate::crc::crc32;

const SHAPE1: [u16; 3] = [1000, 8, 5];
const SHAPE2: [u16; 3] = [200, 4, 3];
const VALUES: usize = Stage1Net::VALUES + Stage2Net::VALUES;
/// Upper bound of a header's postcard encoding (u16 + 6 x u16 + 3 x u32 as varints + 2 u8).
const HEADER_MAX: usize = 3 + 6 * 3 + 3 * 5 + 2;

/// Upper bound of a checkpoint's size in bytes (for buffers).
pub const MAX_SIZE: usize = 4 + HEADER_MAX + VALUES * 4 + 4;

/// The header a checkpoint of `ctrl` carries.
fn header_of(ctrl: &Controller, provenance: Provenance) -> Header {
    Header {
        version: VERSION,
        shape1: SHAPE1,
        shape2: SHAPE2,
        t1: ctrl.stage1().learning_step(),
        t2: ctrl.stage2().learning_step(),
        provenance,
        config_fingerprint: ctrl.config().fingerprint(),
    }
}

/// Writes a checkpoint of `ctrl`, whose configuration came from `provenance`, into `buf`
/// and returns its length. [`ImageCursor`] writes the same bytes piece by piece.
pub fn save(ctrl: &Controller, provenance: Provenance, buf: &mut [u8]) -> Result<usize> {
    let header = header_of(ctrl, provenance);
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
    if bytes.len() < 8 || bytes.len() > MAX_SIZE {
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
    if header.t1 > T_MAX || header.t2 > T_MAX {
        return Err(Error::CheckpointContents);
    }
    Ok(header)
}

/// Each table's values within [`VALUE_LIMITS`] and within what this build's tables hold
/// (a compact build's fixed-point range, [`crate::entry::TABLE_SCALES`]), in checkpoint
/// order (stage 1's weights, pressures, Jacobians, then stage 2's). The format is f32 in
/// either build, so a checkpoint moves between them; a compact build rounds on restore.
fn values_within_limits(values: &[u8]) -> bool {
    let limits = ValueLimits::new();
    values
        .chunks_exact(4)
        .enumerate()
        .all(|(i, c)| limits.holds(i, value_of(c)))
}

/// The f32 a checkpoint stores in 4 bytes (postcard: little endian).
fn value_of(bytes: &[u8]) -> f32 {
    postcard::from_bytes::<f32>(bytes).unwrap_or(f32::NAN)
}

/// The bound of every value in checkpoint order: [`VALUE_LIMITS`] within what this build's
/// tables hold.
struct ValueLimits {
    /// (end index, bound) of the six tables: stage 1's weights, pressures, Jacobians, then
    /// stage 2's.
    tables: [(usize, f32); 6],
}

impl ValueLimits {
    fn new() -> Self {
        use crate::entry::{Entry, Table, TABLE_SCALES};
        let held = |limit: f32, scale| limit.min(Table::max_abs(scale));
        let (w, p, a) = VALUE_LIMITS;
        let (w, p, a) = (
            held(w, TABLE_SCALES.w),
            held(p, TABLE_SCALES.p),
            held(a, TABLE_SCALES.a),
        );
        let sizes = [
            (1000 * 8, w),
            (1000 * 5, p),
            (1000 * 5 * 8, a),
            (200 * 4, w),
            (200 * 3, p),
            (200 * 3 * 4, a),
        ];
        let mut end = 0;
        ValueLimits {
            tables: sizes.map(|(count, limit)| {
                end += count;
                (end, limit)
            }),
        }
    }

    /// True when value `i` (checkpoint order) may be `x`: finite and within its table's bound.
    fn holds(&self, i: usize, x: f32) -> bool {
        match self.tables.iter().find(|(end, _)| i < *end) {
            Some(&(_, limit)) => x.is_finite() && x.abs() <= limit,
            None => false,
        }
    }
}

/// Restores both networks from a checkpoint. On any error `ctrl` is left as it was.
pub fn restore(ctrl: &mut Controller, bytes: &[u8]) -> Result<Header> {
    if ctrl.busy() {
        return Err(Error::Busy);
    }
    let header = verify(bytes)?;
    let values = &bytes[bytes.len() - 4 - VALUES * 4..bytes.len() - 4];
    // every value must be finite and within its table's bounds before anything is written
    if !values_within_limits(values) {
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
        let n = save(&a, Provenance::CUSTOM, &mut buf).unwrap();
        let mut b = Box::new(Controller::new(Config::project_default()));
        let h = restore(&mut b, &buf[..n]).unwrap();
        assert_eq!(h.shape1, SHAPE1);
        assert!(a.stage1().net() == b.stage1().net());
        assert!(a.stage2().net() == b.stage2().net());
        let mut buf2 = vec![0u8; MAX_SIZE];
        let n2 = save(&b, Provenance::CUSTOM, &mut buf2).unwrap();
        assert_eq!(buf[..n], buf2[..n2]);
    }

    #[test]
    fn corrupt_truncated_and_foreign_checkpoints_are_rejected() {
        let a = trained();
        let mut buf = vec![0u8; MAX_SIZE];
        let n = save(&a, Provenance::CUSTOM, &mut buf).unwrap();
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
        // absurd but finite values (3e38) with a valid CRC
        let mut huge = good.clone();
        huge[hl..hl + 4].copy_from_slice(&3.0e38f32.to_le_bytes());
        let crc = CRC.checksum(&huge[..n - 4]);
        huge[n - 4..].copy_from_slice(&crc.to_le_bytes());
        assert_eq!(restore(&mut target, &huge), Err(Error::CheckpointContents));
        // a Jacobian entry of 0.5: a valid f32 checkpoint, beyond a compact build's range
        // (±0.125): refused there, restored by the f32 build
        let mut wide = good.clone();
        let first_jacobian = hl + (1000 * 8 + 1000 * 5) * 4;
        wide[first_jacobian..first_jacobian + 4].copy_from_slice(&0.5f32.to_le_bytes());
        let crc = CRC.checksum(&wide[..n - 4]);
        wide[n - 4..].copy_from_slice(&crc.to_le_bytes());
        if cfg!(feature = "compact") {
            assert_eq!(restore(&mut target, &wide), Err(Error::CheckpointContents));
        } else {
            let mut other = Box::new(Controller::new(Config::project_default()));
            assert!(restore(&mut other, &wide).is_ok());
            assert_eq!(other.stage1().net().jacobian(0)[0][0], 0.5);
        }
        // a learning step that would wrap when continued
        let mut late = Box::new(Controller::new(Config::project_default()));
        late.init_random(11);
        late.parts_mut().0.restore_parts(u32::MAX);
        let mut lbuf = vec![0u8; MAX_SIZE];
        let ln = save(&late, Provenance::CUSTOM, &mut lbuf).unwrap();
        assert_eq!(
            restore(&mut target, &lbuf[..ln]),
            Err(Error::CheckpointContents)
        );
        // longer than any checkpoint
        assert!(matches!(
            restore(&mut target, &vec![0u8; MAX_SIZE + 1]),
            Err(Error::CheckpointLength { .. })
        ));
        assert!(
            target.stage1().net() == &before,
            "a rejected checkpoint changed the tables"
        );
    }

    #[test]
    fn the_header_records_provenance_and_configuration() {
        let a = trained();
        let mut buf = vec![0u8; MAX_SIZE];
        let prov = Provenance::of(
            crate::presets::Preset::Lifelong,
            crate::presets::Ablation::NoPriming,
        );
        let n = save(&a, prov, &mut buf).unwrap();
        let h = verify(&buf[..n]).unwrap();
        assert_eq!(h.provenance, prov);
        assert!(h.config_matches(a.config()));
        assert!(
            !h.config_matches(&Config::paper()),
            "another configuration is told apart"
        );
    }

    #[test]
    fn small_buffer_is_an_error() {
        let a = trained();
        let mut buf = vec![0u8; 100];
        assert!(matches!(
            save(&a, Provenance::CUSTOM, &mut buf),
            Err(Error::BufferTooSmall { .. })
        ));
    }
}
