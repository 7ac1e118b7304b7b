//! Checkpoints of the learned state of both networks.
//!
//! Layout (all little-endian; the header and the tables are postcard-encoded):
//!
//! | bytes | content |
//! |---|---|
//! | 4 | magic `TRNC` |
//! | varies (postcard) | [`Header`]: format version, network shapes, learning steps, preset, ablation, configuration fingerprint |
//! | 4 x values (format 2) or 2 x values (format 3) | stage-1 tables, then stage-2 tables: weights, pressures, Jacobians |
//! | 4 | CRC-32 (ISO-HDLC) over everything before it |
//!
//! The format version says how the values are encoded ([`Encoding`]): format 2 ([`VERSION`])
//! holds each as an f32 (postcard: 4 little-endian bytes), what files and the bus carry;
//! format 3 ([`COMPACT_VERSION`]) each as the compact build's i16 fixed point in its table's
//! step ([`crate::entry::TABLE_SCALES`]), 2 little-endian bytes: half the size, what a part
//! with little flash keeps (the STM32G474's store). A
//! compact build writes format 3 without loss; an f32 build rounds to the table's step and
//! saturates at its range. Either build reads either format.
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

/// The format version of an image of f32 values (2: provenance in the header): what
/// [`save`], files and the bus carry.
pub const VERSION: u16 = 2;

/// The format version of a compact image: format 2's layout with each value an i16 in its
/// table's fixed-point step ([`Encoding::Compact`]).
pub const COMPACT_VERSION: u16 = 3;

/// How an image encodes the table values; its header's format version names it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Encoding {
    /// Each value an f32, 4 bytes (format [`VERSION`]).
    F32,
    /// Each value the compact build's i16 in its table's step (weights 2^-5 px, pressures
    /// 2^-13, Jacobian entries 2^-18: [`crate::entry::TABLE_SCALES`]), 2 bytes, little
    /// endian (format [`COMPACT_VERSION`]). Written from f32 tables, a value is rounded to
    /// the nearest step (ties to even) and saturated at the i16 range.
    Compact,
}

impl Encoding {
    /// The format version of an image in this encoding.
    pub const fn version(self) -> u16 {
        match self {
            Encoding::F32 => VERSION,
            Encoding::Compact => COMPACT_VERSION,
        }
    }

    /// The encoding of an image of format `version`; `None` for a format this build does
    /// not read.
    pub const fn of_version(version: u16) -> Option<Encoding> {
        match version {
            VERSION => Some(Encoding::F32),
            COMPACT_VERSION => Some(Encoding::Compact),
            _ => None,
        }
    }

    /// Bytes of one value.
    pub const fn width(self) -> usize {
        match self {
            Encoding::F32 => 4,
            Encoding::Compact => 2,
        }
    }

    /// Upper bound of an image's size in this encoding (for buffers and flash slots).
    pub const fn max_size(self) -> usize {
        4 + HEADER_MAX + VALUES * self.width() + 4
    }

    /// The length of the same image (the same header) in `to`, from its length `len` in
    /// this encoding: a reader of a controller's tables gets them in format 2 whatever the
    /// encoding they were written in.
    pub const fn len_as(self, len: usize, to: Encoding) -> usize {
        len - VALUES * self.width() + VALUES * to.width()
    }

    /// Writes value `i` (checkpoint order) into `out[..self.width()]`.
    fn encode(self, i: usize, x: f32, out: &mut [u8]) {
        match self {
            // postcard encodes an f32 as its 4 little-endian bytes
            Encoding::F32 => out[..4].copy_from_slice(&x.to_le_bytes()),
            Encoding::Compact => {
                use crate::entry::Entry;
                out[..2].copy_from_slice(&i16::put(x, scale_of(i)).to_le_bytes())
            }
        }
    }

    /// Value `i` (checkpoint order) from its `self.width()` bytes.
    fn decode(self, i: usize, bytes: &[u8]) -> f32 {
        match self {
            Encoding::F32 => value_of(bytes),
            Encoding::Compact => {
                use crate::entry::Entry;
                i16::from_le_bytes([bytes[0], bytes[1]]).get(scale_of(i))
            }
        }
    }
}

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
    /// How the image's values are encoded: the encoding its format version names (a header
    /// [`verify`] accepted names one; any other version reads as [`Encoding::F32`]).
    pub fn encoding(&self) -> Encoding {
        Encoding::of_version(self.version).unwrap_or(Encoding::F32)
    }

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

/// Upper bound of a checkpoint's size in bytes, in either encoding (for buffers).
pub const MAX_SIZE: usize = Encoding::F32.max_size();

/// Values in each table, in checkpoint order: stage 1's weights, pressures, Jacobians, then
/// stage 2's.
const TABLE_SIZES: [usize; 6] = [
    1000 * 8,
    1000 * 5,
    1000 * 5 * 8,
    200 * 4,
    200 * 3,
    200 * 3 * 4,
];

/// The table (index into [`TABLE_SIZES`]) of value `i`; 6 beyond the last.
fn table_of(i: usize) -> usize {
    let mut end = 0;
    for (t, n) in TABLE_SIZES.iter().enumerate() {
        end += n;
        if i < end {
            return t;
        }
    }
    TABLE_SIZES.len()
}

/// The fixed-point step of value `i`'s table (a compact image's unit).
fn scale_of(i: usize) -> crate::entry::Scale {
    let s = crate::entry::TABLE_SCALES;
    match table_of(i) % 3 {
        0 => s.w,
        1 => s.p,
        _ => s.a,
    }
}

/// The header a checkpoint of `ctrl` carries in `encoding`.
fn header_of(ctrl: &Controller, provenance: Provenance, encoding: Encoding) -> Header {
    Header {
        version: encoding.version(),
        shape1: SHAPE1,
        shape2: SHAPE2,
        t1: ctrl.stage1().learning_step(),
        t2: ctrl.stage2().learning_step(),
        provenance,
        config_fingerprint: ctrl.config().fingerprint(),
    }
}

/// Writes a checkpoint of `ctrl`, whose configuration came from `provenance`, into `buf`
/// and returns its length (format 2, f32 values). [`ImageCursor`] writes the same bytes
/// piece by piece.
pub fn save(ctrl: &Controller, provenance: Provenance, buf: &mut [u8]) -> Result<usize> {
    save_as(ctrl, provenance, Encoding::F32, buf)
}

/// [`save`] in `encoding`.
pub fn save_as(
    ctrl: &Controller,
    provenance: Provenance,
    encoding: Encoding,
    buf: &mut [u8],
) -> Result<usize> {
    let header = header_of(ctrl, provenance, encoding);
    let width = encoding.width();
    if buf.len() < 4 {
        return Err(Error::BufferTooSmall { needed: MAX_SIZE });
    }
    buf[..4].copy_from_slice(&MAGIC);
    let hlen = postcard::to_slice(&header, &mut buf[4..])
        .map_err(|_| Error::BufferTooSmall { needed: MAX_SIZE })?
        .len();
    let mut pos = 4 + hlen;
    let needed = pos + VALUES * width + 4;
    if buf.len() < needed {
        return Err(Error::BufferTooSmall { needed });
    }
    let mut i = 0;
    let mut put = |x: f32| {
        encoding.encode(i, x, &mut buf[pos..pos + width]);
        pos += width;
        i += 1;
    };
    ctrl.stage1().net().for_each_value(&mut put);
    ctrl.stage2().net().for_each_value(&mut put);
    let crc = CRC.checksum(&buf[..pos]);
    buf[pos..pos + 4].copy_from_slice(&crc.to_le_bytes());
    Ok(pos + 4)
}

/// Writes `image` (a checkpoint in either encoding, checked as [`verify`] checks it) into
/// `out` in `encoding` and returns its length: the same header (learning steps,
/// provenance, configuration fingerprint) in the new format version, each value
/// re-encoded (rounded to its table's step and saturated when the new encoding is
/// [`Encoding::Compact`]), a new CRC. For a writer whose controller keeps compact images
/// only (a part with little flash).
pub fn transcode(image: &[u8], encoding: Encoding, out: &mut [u8]) -> Result<usize> {
    let header = verify(image)?;
    let from = header.encoding();
    let (wf, wt) = (from.width(), encoding.width());
    let values = &image[image.len() - 4 - VALUES * wf..image.len() - 4];
    let header = Header {
        version: encoding.version(),
        ..header
    };
    if out.len() < 4 {
        return Err(Error::BufferTooSmall {
            needed: encoding.max_size(),
        });
    }
    out[..4].copy_from_slice(&MAGIC);
    let hlen = postcard::to_slice(&header, &mut out[4..])
        .map_err(|_| Error::BufferTooSmall {
            needed: encoding.max_size(),
        })?
        .len();
    let mut pos = 4 + hlen;
    let needed = pos + VALUES * wt + 4;
    if out.len() < needed {
        return Err(Error::BufferTooSmall { needed });
    }
    for (i, c) in values.chunks_exact(wf).enumerate() {
        encoding.encode(i, from.decode(i, c), &mut out[pos..pos + wt]);
        pos += wt;
    }
    let crc = CRC.checksum(&out[..pos]);
    out[pos..pos + 4].copy_from_slice(&crc.to_le_bytes());
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
    let Some(encoding) = Encoding::of_version(header.version) else {
        return Err(Error::CheckpointVersion {
            found: header.version,
        });
    };
    if header.shape1 != SHAPE1 || header.shape2 != SHAPE2 {
        return Err(Error::CheckpointShape);
    }
    let values = VALUES * encoding.width();
    if rest.len() != values {
        let expected = bytes.len() - rest.len() + values;
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
/// order (stage 1's weights, pressures, Jacobians, then stage 2's). Either build reads
/// either encoding, so a checkpoint moves between them; a compact build rounds an f32 image
/// on restore.
fn values_within_limits(values: &[u8], encoding: Encoding) -> bool {
    let limits = ValueLimits::new();
    values
        .chunks_exact(encoding.width())
        .enumerate()
        .all(|(i, c)| limits.holds(i, encoding.decode(i, c)))
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
        let bounds = [w, p, a, w, p, a];
        let mut end = 0;
        let mut t = 0;
        ValueLimits {
            tables: TABLE_SIZES.map(|count| {
                end += count;
                t += 1;
                (end, bounds[t - 1])
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
    let encoding = header.encoding();
    let width = encoding.width();
    let values = &bytes[bytes.len() - 4 - VALUES * width..bytes.len() - 4];
    // every value must be finite and within its table's bounds before anything is written
    if !values_within_limits(values, encoding) {
        return Err(Error::CheckpointContents);
    }
    let mut chunks = values.chunks_exact(width).enumerate();
    let mut next = |x: &mut f32| {
        if let Some((i, c)) = chunks.next() {
            *x = encoding.decode(i, c);
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

    /// An f32 image transcoded to compact is the compact image of the same tables, and back
    /// the f32 image of the rounded tables; a damaged image is refused.
    #[test]
    fn transcoding_gives_the_image_of_the_other_encoding() {
        let a = trained();
        let mut f = vec![0u8; MAX_SIZE];
        let n = save(&a, Provenance::CUSTOM, &mut f).unwrap();
        let mut direct = vec![0u8; MAX_SIZE];
        let nd = save_as(&a, Provenance::CUSTOM, Encoding::Compact, &mut direct).unwrap();
        let mut c = vec![0u8; MAX_SIZE];
        let nc = transcode(&f[..n], Encoding::Compact, &mut c).unwrap();
        assert_eq!(c[..nc], direct[..nd]);
        assert_eq!(Encoding::Compact.len_as(nc, Encoding::F32), n);
        assert_eq!(Encoding::F32.len_as(n, Encoding::Compact), nc);
        let mut back = vec![0u8; MAX_SIZE];
        let nb = transcode(&c[..nc], Encoding::F32, &mut back).unwrap();
        let mut b = Box::new(Controller::new(Config::project_default()));
        restore(&mut b, &c[..nc]).unwrap();
        let mut rounded = vec![0u8; MAX_SIZE];
        let nr = save(&b, Provenance::CUSTOM, &mut rounded).unwrap();
        assert_eq!(back[..nb], rounded[..nr]);
        assert_eq!(
            verify(&back[..nb]).unwrap().config_fingerprint,
            a.config().fingerprint()
        );
        f[100] ^= 1;
        assert!(matches!(
            transcode(&f[..n], Encoding::Compact, &mut c),
            Err(Error::CheckpointCrc { .. })
        ));
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
