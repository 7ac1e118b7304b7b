//! Checkpoints in pieces: the image of [`super::save`] produced from the live tables a few
//! bytes at a time ([`ImageCursor`], [`read_at`]), and verified and restored from a source
//! read in pieces ([`verify_from`], [`restore_from`]), so that a microcontroller writes its
//! tables to flash or sends them over the bus without a 227 KB buffer of the image.
//!
//! The bytes are those of [`super::save`], and a source is refused exactly when
//! [`super::restore`] refuses the same bytes, with the same error.

use super::{
    header_of, Encoding, Header, Provenance, ValueLimits, CRC, HEADER_MAX, MAGIC, MAX_SIZE, SHAPE1,
    SHAPE2, T_MAX, VALUES,
};
use crate::controller::Controller;
use crate::error::{Error, Result};
use crate::net::Stage1Net;

/// Bytes of the head: the magic and the longest header encoding.
const HEAD_MAX: usize = 4 + HEADER_MAX;

/// How many bytes a source is read in at a time (on the stack).
const PIECE: usize = 64;

/// The head of an image: the magic and the header's postcard encoding, and the encoding of
/// the values that follow.
#[derive(Debug, Clone, Copy)]
struct Head {
    bytes: [u8; HEAD_MAX],
    len: usize,
    encoding: Encoding,
}

impl Head {
    fn of(header: &Header) -> Head {
        let mut bytes = [0u8; HEAD_MAX];
        bytes[..4].copy_from_slice(&MAGIC);
        // cannot fail: HEADER_MAX bounds every header's encoding
        let len = postcard::to_slice(header, &mut bytes[4..]).map_or(0, |b| b.len());
        Head {
            bytes,
            len: 4 + len,
            encoding: header.encoding(),
        }
    }

    /// Length of the whole image: head, values, CRC.
    fn image_len(&self) -> usize {
        self.len + VALUES * self.encoding.width() + 4
    }
}

/// Value `i` of both networks in checkpoint order.
fn value(ctrl: &Controller, i: usize) -> f32 {
    if i < Stage1Net::VALUES {
        ctrl.stage1().net().value(i)
    } else {
        ctrl.stage2().net().value(i - Stage1Net::VALUES)
    }
    .unwrap_or(0.0)
}

/// Copies the image bytes at `offset..` that lie before the CRC into `buf`; returns how
/// many (fewer than `buf.len()` only where the CRC begins).
fn body_bytes(ctrl: &Controller, head: &Head, offset: usize, buf: &mut [u8]) -> usize {
    let body_end = head.image_len() - 4;
    let mut filled = 0;
    while filled < buf.len() {
        let pos = offset + filled;
        if pos < head.len {
            buf[filled] = head.bytes[pos];
            filled += 1;
        } else if pos < body_end {
            let width = head.encoding.width();
            let (i, within) = ((pos - head.len) / width, (pos - head.len) % width);
            let mut bytes = [0u8; 4];
            head.encoding.encode(i, value(ctrl, i), &mut bytes);
            let n = (width - within).min(buf.len() - filled);
            buf[filled..filled + n].copy_from_slice(&bytes[within..within + n]);
            filled += n;
        } else {
            break;
        }
    }
    filled
}

/// The CRC of an image's body (everything before the CRC): one pass over the tables.
fn body_crc(ctrl: &Controller, head: &Head) -> u32 {
    let mut digest = CRC.digest();
    let mut piece = [0u8; PIECE];
    let mut pos = 0;
    loop {
        let n = body_bytes(ctrl, head, pos, &mut piece);
        if n == 0 {
            return digest.finalize();
        }
        digest.update(&piece[..n]);
        pos += n;
    }
}

/// Bytes `offset..offset + buf.len()` of the checkpoint image of `ctrl` (as [`super::save`]
/// writes it with `provenance`), for a reader that asks for pieces by position; returns how
/// many were written (fewer at the end of the image, 0 beyond it). A range that includes the
/// trailing CRC takes one pass over the tables to compute it. The image is format 2 (f32
/// values), what the bus carries.
pub fn read_at(ctrl: &Controller, provenance: Provenance, offset: usize, buf: &mut [u8]) -> usize {
    let head = Head::of(&header_of(ctrl, provenance, Encoding::F32));
    let len = head.image_len();
    if offset >= len {
        return 0;
    }
    let want = buf.len().min(len - offset);
    let n = body_bytes(ctrl, &head, offset, &mut buf[..want]);
    if n < want {
        let crc = body_crc(ctrl, &head).to_le_bytes();
        let from = offset + n - (len - 4);
        buf[n..want].copy_from_slice(&crc[from..from + want - n]);
    }
    want
}

/// The checkpoint image of a controller, written from its live tables in order, a piece at a
/// time, with a running CRC: what a store programs into flash. The cursor keeps no reference
/// to the controller (a few dozen bytes: the header, not its encoding, which each read
/// makes again): each [`ImageCursor::read`] takes it again, and refuses one whose learning
/// steps or configuration are not those the image began with.
#[derive(Clone)]
pub struct ImageCursor {
    header: Header,
    len: usize,
    pos: usize,
    digest: crc::Digest<'static, u32>,
}

impl core::fmt::Debug for ImageCursor {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.debug_struct("ImageCursor")
            .field("header", &self.header)
            .field("pos", &self.pos)
            .field("len", &self.len())
            .finish()
    }
}

impl ImageCursor {
    /// A cursor at the start of the image of `ctrl`, whose configuration came from
    /// `provenance`, in format 2 (f32 values: [`super::save`]'s bytes).
    pub fn new(ctrl: &Controller, provenance: Provenance) -> ImageCursor {
        ImageCursor::new_as(ctrl, provenance, Encoding::F32)
    }

    /// [`ImageCursor::new`] in `encoding` ([`super::save_as`]'s bytes).
    pub fn new_as(ctrl: &Controller, provenance: Provenance, encoding: Encoding) -> ImageCursor {
        let header = header_of(ctrl, provenance, encoding);
        ImageCursor {
            len: Head::of(&header).image_len(),
            header,
            pos: 0,
            digest: CRC.digest(),
        }
    }

    /// The image's header.
    pub fn header(&self) -> &Header {
        &self.header
    }

    /// The image's length in bytes.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Never true: an image holds at least its magic, header, values and CRC.
    pub fn is_empty(&self) -> bool {
        false
    }

    /// Bytes written so far.
    pub fn position(&self) -> usize {
        self.pos
    }

    /// True when every byte was written.
    pub fn is_done(&self) -> bool {
        self.pos >= self.len()
    }

    /// Writes the next bytes of the image into `buf` and returns how many (fewer only at the
    /// end, 0 after it). [`Error::CheckpointChanged`] when `ctrl`'s learning steps or
    /// configuration differ from those the image began with: its tables changed, the bytes
    /// written so far belong to another image.
    pub fn read(&mut self, ctrl: &Controller, buf: &mut [u8]) -> Result<usize> {
        let head = Head::of(&self.header);
        if header_of(ctrl, self.header.provenance, head.encoding) != self.header {
            return Err(Error::CheckpointChanged);
        }
        let len = self.len;
        let want = buf.len().min(len - self.pos.min(len));
        let n = body_bytes(ctrl, &head, self.pos, &mut buf[..want]);
        self.digest.update(&buf[..n]);
        if n < want {
            let crc = self.digest.clone().finalize().to_le_bytes();
            let from = self.pos + n - (len - 4);
            buf[n..want].copy_from_slice(&crc[from..from + want - n]);
        }
        self.pos += want;
        Ok(want)
    }
}

/// A checkpoint image read in pieces (a flash slot, a staging area): its length, and bytes
/// at a position.
pub trait ImageSource {
    /// What a read can fail with.
    type Error;
    /// The image's length in bytes.
    fn len(&self) -> usize;
    /// True for a source of no bytes (refused as too short).
    fn is_empty(&self) -> bool {
        self.len() == 0
    }
    /// Fills `buf` with the bytes at `offset..offset + buf.len()` (always within `len`).
    fn read(&mut self, offset: usize, buf: &mut [u8]) -> core::result::Result<(), Self::Error>;
}

/// A checkpoint in memory is a source.
impl ImageSource for &[u8] {
    type Error = core::convert::Infallible;

    fn len(&self) -> usize {
        <[u8]>::len(self)
    }

    fn read(&mut self, offset: usize, buf: &mut [u8]) -> core::result::Result<(), Self::Error> {
        buf.copy_from_slice(&self[offset..offset + buf.len()]);
        Ok(())
    }
}

/// Why an image could not be verified or restored from a source.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SourceError<E> {
    /// The source failed to read.
    Read(E),
    /// The image is refused (the error [`super::restore`] gives for the same bytes).
    Checkpoint(Error),
}

impl<E> From<Error> for SourceError<E> {
    fn from(e: Error) -> Self {
        SourceError::Checkpoint(e)
    }
}

type SourceResult<T, E> = core::result::Result<T, SourceError<E>>;

/// The values of an image read in order, a piece at a time, with the CRC of what was read.
struct Values<'s, S> {
    src: &'s mut S,
    encoding: Encoding,
    /// The index of the next value.
    i: usize,
    pos: usize,
    end: usize,
    piece: [u8; PIECE],
    at: usize,
    filled: usize,
    digest: crc::Digest<'static, u32>,
}

impl<'s, S: ImageSource> Values<'s, S> {
    /// Reads `0..head_len` into the CRC; values in `encoding` follow from `head_len` until
    /// the CRC.
    fn new(
        src: &'s mut S,
        head_len: usize,
        encoding: Encoding,
    ) -> core::result::Result<Self, S::Error> {
        let mut digest = CRC.digest();
        let mut head = [0u8; HEAD_MAX];
        src.read(0, &mut head[..head_len])?;
        digest.update(&head[..head_len]);
        let end = src.len() - 4;
        Ok(Values {
            src,
            encoding,
            i: 0,
            pos: head_len,
            end,
            piece: [0; PIECE],
            at: 0,
            filled: 0,
            digest,
        })
    }

    /// The next value; `None` after the last.
    fn next(&mut self) -> Option<core::result::Result<f32, S::Error>> {
        let width = self.encoding.width();
        if self.at == self.filled {
            // whole values: PIECE is a multiple of either width
            let n = PIECE.min(self.end - self.pos);
            if n < width {
                return None;
            }
            if let Err(e) = self.src.read(self.pos, &mut self.piece[..n]) {
                return Some(Err(e));
            }
            self.digest.update(&self.piece[..n]);
            self.pos += n;
            self.at = 0;
            self.filled = n;
        }
        let x = self
            .encoding
            .decode(self.i, &self.piece[self.at..self.at + width]);
        self.at += width;
        self.i += 1;
        Some(Ok(x))
    }

    /// The CRC stored at the end of the image.
    fn stored_crc(&mut self) -> core::result::Result<u32, S::Error> {
        let mut crc = [0u8; 4];
        self.src.read(self.end, &mut crc)?;
        Ok(u32::from_le_bytes(crc))
    }
}

/// Checks the framing of an image (length, magic, header, version, shapes) as
/// [`super::verify`] does; returns the header, the head's length and the values' encoding.
/// The CRC is not read.
fn check_frame<S: ImageSource>(src: &mut S) -> SourceResult<(Header, usize, Encoding), S::Error> {
    let len = src.len();
    let length = Error::CheckpointLength {
        expected: MAX_SIZE,
        found: len,
    };
    if !(8..=MAX_SIZE).contains(&len) {
        return Err(length.into());
    }
    let mut head = [0u8; HEAD_MAX];
    // the header is decoded from the bytes between the magic and the CRC, as in `verify`
    let header_bytes = HEADER_MAX.min(len - 8);
    src.read(0, &mut head[..4 + header_bytes])
        .map_err(SourceError::Read)?;
    if head[..4] != MAGIC {
        return Err(Error::CheckpointMagic.into());
    }
    let (header, rest) = postcard::take_from_bytes::<Header>(&head[4..4 + header_bytes])
        .map_err(|_| SourceError::Checkpoint(length))?;
    let head_len = 4 + header_bytes - rest.len();
    let Some(encoding) = Encoding::of_version(header.version) else {
        return Err(Error::CheckpointVersion {
            found: header.version,
        }
        .into());
    };
    if header.shape1 != SHAPE1 || header.shape2 != SHAPE2 {
        return Err(Error::CheckpointShape.into());
    }
    let values = len - 4 - head_len;
    let expected = VALUES * encoding.width();
    if values != expected {
        return Err(Error::CheckpointLength {
            expected: len - values + expected,
            found: len,
        }
        .into());
    }
    Ok((header, head_len, encoding))
}

/// Reads every value once: the CRC check and whether all values are within their bounds.
fn first_pass<S: ImageSource>(
    src: &mut S,
    header: &Header,
    head_len: usize,
    encoding: Encoding,
) -> SourceResult<bool, S::Error> {
    let limits = ValueLimits::new();
    let mut values = Values::new(src, head_len, encoding).map_err(SourceError::Read)?;
    let mut within = true;
    let mut i = 0;
    while let Some(x) = values.next() {
        within &= limits.holds(i, x.map_err(SourceError::Read)?);
        i += 1;
    }
    let computed = values.digest.clone().finalize();
    let stored = values.stored_crc().map_err(SourceError::Read)?;
    if computed != stored {
        return Err(Error::CheckpointCrc { stored, computed }.into());
    }
    if header.t1 > T_MAX || header.t2 > T_MAX {
        return Err(Error::CheckpointContents.into());
    }
    Ok(within)
}

/// Checks an image read from `src` without restoring it and returns its header: what
/// [`super::verify`] checks (length, magic, version, shapes, CRC, learning steps), reading
/// the source once.
pub fn verify_from<S: ImageSource>(src: &mut S) -> SourceResult<Header, S::Error> {
    let (header, head_len, encoding) = check_frame(src)?;
    first_pass(src, &header, head_len, encoding)?;
    Ok(header)
}

/// Checks an image read from `src` as [`restore_from`] does before it writes anything
/// (everything [`super::restore`] checks: framing, CRC, learning steps, every value), without
/// restoring it; returns its header. A store checks a staged image with it before it makes
/// it the stored copy.
pub fn check_from<S: ImageSource>(src: &mut S) -> SourceResult<Header, S::Error> {
    let (header, head_len, encoding) = check_frame(src)?;
    if !first_pass(src, &header, head_len, encoding)? {
        return Err(Error::CheckpointContents.into());
    }
    Ok(header)
}

/// Every value of both networks in checkpoint order, through `f`. Not generic and not
/// inlined: the six loops over the tables call one body of `f` instead of each inlining a
/// source's reads and the CRC (8 KiB of a firmware's flash when they did).
#[inline(never)]
fn each_value_mut(ctrl: &mut Controller, f: &mut dyn FnMut(&mut f32)) {
    let (s1, s2) = ctrl.parts_mut();
    s1.net_mut().for_each_value_mut(&mut *f);
    s2.net_mut().for_each_value_mut(&mut *f);
}

/// Restores both networks from an image read from `src` in two passes: the first checks
/// everything [`super::restore`] checks (and refuses what it refuses, with the same error)
/// without writing anything; the second reads the image again and writes the tables. A
/// source that reads differently the second time (a CRC or a value that no longer holds)
/// gives [`Error::CheckpointChanged`]: the tables then hold a mix of old and new values, each
/// finite and within its bounds. On every other error `ctrl` is left as it was.
pub fn restore_from<S: ImageSource>(
    ctrl: &mut Controller,
    src: &mut S,
) -> SourceResult<Header, S::Error> {
    if ctrl.busy() {
        return Err(Error::Busy.into());
    }
    let header = check_from(src)?;
    let encoding = header.encoding();
    let head_len = src.len() - 4 - VALUES * encoding.width();
    let limits = ValueLimits::new();
    let mut values = Values::new(src, head_len, encoding).map_err(SourceError::Read)?;
    let mut i = 0;
    let mut changed = false;
    let mut read_error = None;
    let mut next = |x: &mut f32| {
        match values.next() {
            Some(Ok(v)) if !changed && limits.holds(i, v) => *x = v,
            Some(Err(e)) => {
                read_error.get_or_insert(e);
                changed = true;
            }
            _ => changed = true,
        }
        i += 1;
    };
    each_value_mut(ctrl, &mut next);
    let (s1, s2) = ctrl.parts_mut();
    s1.restore_parts(header.t1);
    s2.restore_parts(header.t2);
    if let Some(e) = read_error {
        return Err(SourceError::Read(e));
    }
    let computed = values.digest.clone().finalize();
    let stored = values.stored_crc().map_err(SourceError::Read)?;
    if changed || computed != stored {
        return Err(Error::CheckpointChanged.into());
    }
    Ok(header)
}

#[cfg(test)]
mod tests {
    use super::super::{restore, save, verify};
    use super::*;
    use crate::Config;
    use proptest::prelude::*;

    /// A controller with random tables and non-zero learning steps (multi-byte varints in
    /// the header).
    fn controller(seed: u64) -> Box<Controller> {
        let mut c = Box::new(Controller::new(Config::project_default()));
        c.init_random(seed);
        let (s1, s2) = c.parts_mut();
        s1.restore_parts(1234 + seed as u32);
        s2.restore_parts(77);
        c
    }

    fn saved(c: &Controller, prov: Provenance) -> Vec<u8> {
        let mut buf = vec![0u8; MAX_SIZE];
        let n = save(c, prov, &mut buf).unwrap();
        buf.truncate(n);
        buf
    }

    /// The cursor's bytes are `save`'s, whatever the piece size (a piece that splits a value
    /// or the CRC, one byte, more than the image).
    #[test]
    fn a_cursor_writes_the_bytes_of_save() {
        let c = controller(3);
        let prov = Provenance::of(
            crate::presets::Preset::Paper,
            crate::presets::Ablation::NoPriming,
        );
        let whole = saved(&c, prov);
        for piece in [1usize, 3, 7, 56, 64, 4096, MAX_SIZE + 10] {
            let mut cur = ImageCursor::new(&c, prov);
            assert_eq!(cur.len(), whole.len());
            let mut got = Vec::new();
            let mut buf = vec![0u8; piece];
            loop {
                let n = cur.read(&c, &mut buf).unwrap();
                if n == 0 {
                    break;
                }
                got.extend_from_slice(&buf[..n]);
            }
            assert!(cur.is_done());
            assert!(got == whole, "piece {piece}: the streamed image differs");
        }
    }

    /// Random access gives the same bytes, the CRC included, and nothing beyond the end.
    #[test]
    fn read_at_gives_the_bytes_of_save() {
        let c = controller(4);
        let whole = saved(&c, Provenance::CUSTOM);
        let len = whole.len();
        for (offset, n) in [
            (0, 56),
            (5, 33),
            (40, 56),
            (len - 60, 56),
            (len - 6, 56),
            (len - 3, 2),
            (len - 56, 56),
        ] {
            let mut buf = vec![0xAAu8; n];
            let got = read_at(&c, Provenance::CUSTOM, offset, &mut buf);
            let want = n.min(len - offset);
            assert_eq!(got, want, "offset {offset}");
            assert_eq!(buf[..got], whole[offset..offset + got], "offset {offset}");
        }
        assert_eq!(read_at(&c, Provenance::CUSTOM, len, &mut [0u8; 8]), 0);
    }

    /// A cursor refuses a controller whose tables learned (or were re-seeded) since it began.
    #[test]
    fn a_cursor_refuses_tables_that_changed() {
        let mut c = controller(5);
        let mut cur = ImageCursor::new(&c, Provenance::CUSTOM);
        let mut buf = [0u8; 64];
        cur.read(&c, &mut buf).unwrap();
        c.parts_mut().0.restore_parts(99_999);
        assert_eq!(cur.read(&c, &mut buf), Err(Error::CheckpointChanged));
    }

    /// A source that gives other bytes on the second pass is caught: the tables hold valid
    /// values and the restore says the image changed.
    #[test]
    fn a_source_that_changes_between_passes_is_reported() {
        struct Flaky {
            bytes: Vec<u8>,
            reads_of_crc: u32,
        }
        impl ImageSource for Flaky {
            type Error = ();
            fn len(&self) -> usize {
                self.bytes.len()
            }
            fn read(&mut self, offset: usize, buf: &mut [u8]) -> core::result::Result<(), ()> {
                let crc_at = self.bytes.len() - 4;
                if offset == crc_at {
                    self.reads_of_crc += 1;
                    if self.reads_of_crc == 1 {
                        // after the first pass: one value changes on the medium
                        self.bytes[1000] ^= 0x01;
                    }
                }
                buf.copy_from_slice(&self.bytes[offset..offset + buf.len()]);
                Ok(())
            }
        }
        let a = controller(6);
        let mut src = Flaky {
            bytes: saved(&a, Provenance::CUSTOM),
            reads_of_crc: 0,
        };
        let mut b = controller(7);
        assert_eq!(
            restore_from(&mut b, &mut src),
            Err(SourceError::Checkpoint(Error::CheckpointChanged))
        );
        assert!(b.stage1().net().is_finite() && b.stage2().net().is_finite());
    }

    /// The whole image restored in pieces gives the controller `restore` gives.
    #[test]
    fn a_streamed_restore_is_restore() {
        let a = controller(8);
        let bytes = saved(&a, Provenance::CUSTOM);
        let mut b = controller(9);
        let mut c = controller(9);
        let hb = restore_from(&mut b, &mut bytes.as_slice()).unwrap();
        let hc = restore(&mut c, &bytes).unwrap();
        assert_eq!(hb, hc);
        assert!(b.stage1().net() == a.stage1().net() && b.stage2().net() == a.stage2().net());
        assert_eq!(b.stage1().learning_step(), a.stage1().learning_step());
        assert_eq!(b.stage2().learning_step(), a.stage2().learning_step());
        assert_eq!(saved(&b, Provenance::CUSTOM), bytes);
    }

    /// Re-computes the CRC of an image (to make a corruption pass the CRC check).
    fn fix_crc(bytes: &mut [u8]) {
        let n = bytes.len();
        if n >= 4 {
            let crc = CRC.checksum(&bytes[..n - 4]);
            bytes[n - 4..].copy_from_slice(&crc.to_le_bytes());
        }
    }

    /// The streamed verify and restore refuse exactly what `verify` and `restore` refuse,
    /// with the same error, and leave the tables alike.
    fn same_verdict(bytes: &[u8]) -> core::result::Result<(), TestCaseError> {
        prop_assert_eq!(
            verify_from(&mut &bytes[..]).map_err(|e| match e {
                SourceError::Checkpoint(e) => e,
                SourceError::Read(never) => match never {},
            }),
            verify(bytes)
        );
        let mut streamed = controller(21);
        let mut whole = controller(21);
        let a = restore_from(&mut streamed, &mut &bytes[..]);
        let b = restore(&mut whole, bytes);
        prop_assert_eq!(a, b.map_err(SourceError::Checkpoint));
        prop_assert!(streamed.stage1().net() == whole.stage1().net());
        prop_assert!(streamed.stage2().net() == whole.stage2().net());
        prop_assert_eq!(
            streamed.stage1().learning_step(),
            whole.stage1().learning_step()
        );
        Ok(())
    }

    fn good_image() -> &'static [u8] {
        static IMAGE: std::sync::OnceLock<Vec<u8>> = std::sync::OnceLock::new();
        IMAGE.get_or_init(|| saved(&controller(20), Provenance::CUSTOM))
    }

    proptest! {
        // a fixed seed: the same cases every run
        #![proptest_config(ProptestConfig {
            rng_seed: proptest::test_runner::RngSeed::Fixed(0x57e4),
            ..ProptestConfig::with_cases(64)
        })]

        /// Byte changes anywhere (with the CRC left or made right), truncations and
        /// extensions.
        #[test]
        fn streamed_checks_refuse_what_restore_refuses(
            at in 0usize..(4 + HEADER_MAX + 64),
            from_end in any::<bool>(),
            xor in 1u8..=255,
            fix in any::<bool>(),
            cut in 0usize..(4 + HEADER_MAX + 16),
            kind in 0u8..4,
        ) {
            let good = good_image();
            let mut bytes = good.to_vec();
            match kind {
                0 => {
                    let i = if from_end { bytes.len() - 1 - at } else { at };
                    bytes[i] ^= xor;
                    if fix {
                        fix_crc(&mut bytes);
                    }
                }
                1 => bytes.truncate(cut),
                2 => {
                    bytes.truncate(bytes.len() - cut.min(bytes.len()));
                    if fix {
                        fix_crc(&mut bytes);
                    }
                }
                _ => {
                    bytes.extend(std::iter::repeat_n(xor, cut));
                    if fix {
                        fix_crc(&mut bytes);
                    }
                }
            }
            same_verdict(&bytes)?;
        }

        /// A value of any bits (NaN, huge, beyond a compact build's range) with a valid CRC.
        #[test]
        fn streamed_restore_checks_values_as_restore_does(index in 0usize..VALUES, bits in any::<u32>()) {
            let good = good_image();
            let head = good.len() - 4 - VALUES * 4;
            let mut bytes = good.to_vec();
            bytes[head + 4 * index..head + 4 * index + 4].copy_from_slice(&bits.to_le_bytes());
            fix_crc(&mut bytes);
            same_verdict(&bytes)?;
        }
    }

    fn saved_as(c: &Controller, prov: Provenance, encoding: Encoding) -> Vec<u8> {
        let mut buf = vec![0u8; encoding.max_size()];
        let n = super::super::save_as(c, prov, encoding, &mut buf).unwrap();
        buf.truncate(n);
        buf
    }

    fn compact_image() -> &'static [u8] {
        static IMAGE: std::sync::OnceLock<Vec<u8>> = std::sync::OnceLock::new();
        IMAGE.get_or_init(|| saved_as(&controller(20), Provenance::CUSTOM, Encoding::Compact))
    }

    /// A compact image: format 3, two bytes a value (half an f32 image's values), the
    /// cursor's bytes whatever the piece, restored exactly (a compact build's tables bit for
    /// bit; an f32 build's to the nearest step, so that saving it compact again gives the
    /// same bytes), and streamed or whole alike.
    #[test]
    fn a_compact_image_is_half_the_values_and_restores_to_the_step() {
        let a = controller(12);
        let f32_image = saved(&a, Provenance::CUSTOM);
        let compact = saved_as(&a, Provenance::CUSTOM, Encoding::Compact);
        assert_eq!(compact.len(), f32_image.len() - VALUES * 2);
        assert!(compact.len() <= Encoding::Compact.max_size());
        assert_eq!(
            verify(&compact).unwrap().version,
            super::super::COMPACT_VERSION
        );
        for piece in [1usize, 3, 64, 4096] {
            let mut cur = ImageCursor::new_as(&a, Provenance::CUSTOM, Encoding::Compact);
            assert_eq!(cur.len(), compact.len());
            let mut got = Vec::new();
            let mut buf = vec![0u8; piece];
            while let Ok(n @ 1..) = cur.read(&a, &mut buf) {
                got.extend_from_slice(&buf[..n]);
            }
            assert!(got == compact, "piece {piece}: the streamed image differs");
        }
        let mut b = controller(13);
        restore(&mut b, &compact).unwrap();
        let mut c = controller(14);
        restore_from(&mut c, &mut compact.as_slice()).unwrap();
        assert!(b.stage1().net() == c.stage1().net() && b.stage2().net() == c.stage2().net());
        assert_eq!(saved_as(&b, Provenance::CUSTOM, Encoding::Compact), compact);
        let s = crate::entry::TABLE_SCALES;
        for (i, step) in [(0, s.w.step), (8000, s.p.step), (13_000, s.a.step)] {
            let (x, y) = (value(&a, i), value(&b, i));
            if cfg!(feature = "compact") {
                assert_eq!(x.to_bits(), y.to_bits(), "value {i}");
            } else {
                assert!(
                    (x - y).abs() <= step / 2.0,
                    "value {i}: {x} restored as {y}"
                );
            }
        }
        if cfg!(feature = "compact") {
            assert!(
                b.stage1().net() == a.stage1().net(),
                "a compact build's tables change"
            );
        }
    }

    proptest! {
        // a fixed seed: the same cases every run
        #![proptest_config(ProptestConfig {
            rng_seed: proptest::test_runner::RngSeed::Fixed(0x57e5),
            ..ProptestConfig::with_cases(32)
        })]

        /// A compact image changed anywhere (CRC left or made right), or cut, is refused by
        /// the streamed checks exactly as by `verify` and `restore`.
        #[test]
        fn streamed_checks_refuse_what_restore_refuses_in_a_compact_image(
            at in 0usize..(4 + HEADER_MAX + 64),
            xor in 1u8..=255,
            fix in any::<bool>(),
            cut in 1usize..(4 + HEADER_MAX + 16),
            kind in 0u8..2,
        ) {
            let mut bytes = compact_image().to_vec();
            if kind == 0 {
                bytes[at] ^= xor;
            } else {
                bytes.truncate(bytes.len() - cut);
            }
            if fix {
                fix_crc(&mut bytes);
            }
            same_verdict(&bytes)?;
        }
    }

    #[test]
    fn learning_steps_beyond_the_limit_are_refused_alike() {
        let mut late = controller(1);
        late.parts_mut().1.restore_parts(T_MAX + 1);
        same_verdict(&saved(&late, Provenance::CUSTOM)).unwrap();
        let mut busy = controller(2);
        let bytes = good_image();
        let v = [300.0, 200.0, 310.0, 210.0, 320.0, 220.0, 330.0, 230.0];
        busy.begin(crate::Task::Stage1 {
            v,
            supervised: None,
            learn: true,
        })
        .unwrap();
        assert_eq!(
            restore_from(&mut busy, &mut &bytes[..]),
            Err(SourceError::Checkpoint(Error::Busy))
        );
    }
}
