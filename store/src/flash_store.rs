//! [`FlashStore`]: two slots of a NorFlash region, each a header (the commit record, written
//! last) and a checkpoint image; saving as a job of small steps, staging an incoming image,
//! restoring at boot, erasing.

use embedded_storage::nor_flash::{NorFlash, NorFlashError, NorFlashErrorKind};
use trn_controller::checkpoint::{
    self, Encoding, ImageCursor, ImageSource, Provenance, SourceError,
};
use trn_controller::persist::{
    ApplyError, EraseError, Expected, SaveError, StageError, StoredCopy, TableStore,
};
use trn_controller::{Controller, Error as CkptError};

use crate::slot::{Decoded, SlotHeader, FORMAT, HEADER_LEN};

/// Bytes programmed by one flash write of a save (a multiple of every supported write size).
const PROGRAM: usize = 256;
/// Bytes of an incoming image held until they make whole write units (the write size at
/// most): kept in the store's state, so small (a compact build has little RAM).
const STAGE_UNIT: usize = 64;
/// Bytes read at a time when the flash reads in units larger than a byte.
const READ_PIECE: usize = 64;
/// Flash error code: the image read back differs from what was programmed.
pub const READ_BACK_DIFFERS: u8 = 0xFE;

/// The code of a flash error on the wire (`NorFlashErrorKind`: 1 not aligned, 2 out of
/// bounds, 3 other).
fn code<E: NorFlashError>(e: E) -> u8 {
    match e.kind() {
        NorFlashErrorKind::NotAligned => 1,
        NorFlashErrorKind::OutOfBounds => 2,
        _ => 3,
    }
}

/// True for a read the flash refused for the data it holds (`NorFlashErrorKind::Other`: an
/// ECC error, a torn word on a part with ECC), not for the request (alignment, bounds): what
/// it was reading is damaged, as a CRC that fails.
fn unreadable<E: NorFlashError>(e: &E) -> bool {
    !matches!(
        e.kind(),
        NorFlashErrorKind::NotAligned | NorFlashErrorKind::OutOfBounds
    )
}

/// Why a region cannot hold the store.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LayoutError {
    /// The region's start or slot size is not a multiple of the erase size.
    NotAligned,
    /// A slot is smaller than a header and the largest checkpoint (bytes needed).
    TooSmall {
        /// The smallest slot size that holds them, rounded up to the erase size.
        needed: u32,
    },
    /// The two slots reach beyond the flash.
    OutOfBounds,
    /// The flash's write or read size is not one this store handles (a power of two, at
    /// most 64 bytes for writes and for reads).
    UnitSize,
}

/// Why nothing was restored at boot. The controller is unchanged.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum RestoreError {
    /// Both slots are erased: nothing was ever saved (or the copies were erased).
    NothingStored,
    /// No slot holds a complete, intact copy (torn, bit flips, foreign data).
    AllCorrupt,
    /// The newest copy is in a store format this build does not read.
    Format {
        /// The format version found.
        found: u16,
    },
    /// The newest copy was learned under another configuration than the one required.
    Fingerprint {
        /// The copy's configuration fingerprint.
        stored: u32,
        /// The fingerprint required.
        expected: u32,
    },
    /// The newest copy is intact but not a checkpoint this build restores (another format
    /// version, other network shapes, values beyond what this build's tables hold).
    Image(CkptError),
    /// A trial is running.
    Busy,
    /// The flash refused a read request (alignment, bounds: a layout this flash does not
    /// have). A read refused for the data (an ECC error) makes that copy damaged instead.
    Flash(u8),
}

/// The valid slot headers with their slots, newest first.
type Newest = [Option<(u8, SlotHeader)>; 2];

/// A job in progress.
#[derive(Debug, Clone)]
enum Job {
    None,
    /// A save into `slot`: erasing the slot's pages (the tables are not read), then, while
    /// no trial runs, programming from the cursor (made at the first program step), then the
    /// read-back and the commit.
    Save {
        slot: u8,
        sequence: u32,
        provenance: Provenance,
        len: u32,
        cursor: Option<ImageCursor>,
        programmed: u32,
    },
    /// An incoming image staged into `slot`; `pending` holds the bytes of a write unit not
    /// yet complete.
    Stage {
        slot: u8,
        sequence: u32,
        len: u32,
        received: u32,
        erased: u32,
        pending: [u8; STAGE_UNIT],
        pending_len: usize,
    },
}

/// A flash that erases a page in the background: the erase is started, the caller goes on
/// with its work (on a dual-bank part, running from the other bank), and polls until the
/// erase is done. A [`FlashStore`] made [`FlashStore::with_background_erase`] starts each
/// erase of a save in one step and polls it in the following ones, so no step waits for an
/// erase.
pub trait BackgroundErase: NorFlash {
    /// Starts erasing the page (`ERASE_SIZE` bytes) at `offset` and returns at once.
    fn erase_start(&mut self, offset: u32) -> Result<(), Self::Error>;
    /// True once the erase started last is complete (its error if it failed); true when
    /// none was started.
    fn erase_done(&mut self) -> Result<bool, Self::Error>;
    /// Waits until the erase started last is complete (its error if it failed).
    fn erase_wait(&mut self) -> Result<(), Self::Error>;
}

/// The operations of a [`BackgroundErase`] flash, kept by a store that uses them.
struct Background<F: NorFlash> {
    start: fn(&mut F, u32) -> Result<(), F::Error>,
    done: fn(&mut F) -> Result<bool, F::Error>,
    wait: fn(&mut F) -> Result<(), F::Error>,
}

impl<F: NorFlash> Clone for Background<F> {
    fn clone(&self) -> Self {
        *self
    }
}

impl<F: NorFlash> Copy for Background<F> {}

impl<F: NorFlash> core::fmt::Debug for Background<F> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        f.write_str("Background")
    }
}

/// The erase work of a save kept across a cancel: the slot and sequence number it goes to,
/// the pages of the slot known erased and not programmed since (`from..to`, offsets in the
/// slot), and the page whose erase is under way. A save begun again resumes from it instead
/// of erasing those pages again; a commit, a staged image or an erase of the store drops it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Prepared {
    slot: u8,
    sequence: u32,
    from: u32,
    to: u32,
    pending: Option<u32>,
}

/// The learned tables in two slots of a NorFlash region (see the crate documentation).
#[derive(Debug)]
pub struct FlashStore<F: NorFlash> {
    flash: F,
    base: u32,
    slot_size: u32,
    step_bytes: u32,
    job: Job,
    prepared: Option<Prepared>,
    background: Option<Background<F>>,
    /// Bit `s` set: slot `s`'s header could not be read at its last read (an ECC error).
    unreadable: u8,
    /// How a save encodes the tables' values (a staged image keeps its own).
    encoding: Encoding,
}

/// A slot's image as a checkpoint source.
struct SlotImage<'a, F> {
    flash: &'a mut F,
    at: u32,
    len: usize,
}

impl<F: NorFlash> ImageSource for SlotImage<'_, F> {
    type Error = F::Error;

    fn len(&self) -> usize {
        self.len
    }

    fn read(&mut self, offset: usize, buf: &mut [u8]) -> Result<(), F::Error> {
        read_unaligned(self.flash, self.at + offset as u32, buf)
    }
}

/// Reads `buf.len()` bytes at `at` whatever the flash's read size.
fn read_unaligned<F: NorFlash>(flash: &mut F, at: u32, buf: &mut [u8]) -> Result<(), F::Error> {
    let unit = F::READ_SIZE as u32;
    if unit == 1 {
        return flash.read(at, buf);
    }
    let mut done = 0usize;
    while done < buf.len() {
        let pos = at + done as u32;
        let start = pos - pos % unit;
        let mut piece = [0u8; READ_PIECE];
        let want = (pos - start) as usize + (buf.len() - done);
        let n = want.min(READ_PIECE).div_ceil(unit as usize) * unit as usize;
        flash.read(start, &mut piece[..n])?;
        let from = (pos - start) as usize;
        let take = (n - from).min(buf.len() - done);
        buf[done..done + take].copy_from_slice(&piece[from..from + take]);
        done += take;
    }
    Ok(())
}

/// True for the refusals of a damaged image (the previous copy is taken instead); false for
/// an intact image this build does not take.
fn is_damage(e: &CkptError) -> bool {
    matches!(
        e,
        CkptError::CheckpointLength { .. }
            | CkptError::CheckpointMagic
            | CkptError::CheckpointCrc { .. }
            | CkptError::CheckpointChanged
    )
}

impl<F: NorFlash> FlashStore<F> {
    /// Where the image starts in a slot: after the header, at a write-unit boundary.
    const IMAGE_AT: u32 = if F::WRITE_SIZE > 64 {
        F::WRITE_SIZE as u32
    } else {
        64
    };

    /// The smallest slot size that holds a header and the largest checkpoint (f32 values)
    /// on this flash.
    pub const fn slot_size_needed() -> u32 {
        Self::slot_size_needed_as(Encoding::F32)
    }

    /// The smallest slot size that holds a header and the largest checkpoint in `encoding`
    /// on this flash.
    pub const fn slot_size_needed_as(encoding: Encoding) -> u32 {
        let needed = Self::IMAGE_AT + encoding.max_size() as u32;
        needed.div_ceil(F::ERASE_SIZE as u32) * F::ERASE_SIZE as u32
    }

    /// A store in the two slots `base..base + slot_size` and `base + slot_size..base + 2 *
    /// slot_size` of `flash`, saving f32 images (checkpoint format 2). Nothing is read or
    /// written until asked.
    pub fn new(flash: F, base: u32, slot_size: u32) -> Result<Self, LayoutError> {
        Self::new_as(flash, base, slot_size, Encoding::F32)
    }

    /// [`FlashStore::new`] saving images in `encoding`: [`Encoding::Compact`] (checkpoint
    /// format 3, half the size) for a part whose flash cannot hold two slots of f32 images
    /// beside its program. Either store restores either format; an image staged from the bus
    /// is kept as it came, so a compact store takes only compact images.
    pub fn new_as(
        flash: F,
        base: u32,
        slot_size: u32,
        encoding: Encoding,
    ) -> Result<Self, LayoutError> {
        let (w, r, e) = (F::WRITE_SIZE, F::READ_SIZE, F::ERASE_SIZE as u32);
        if !w.is_power_of_two() || w > STAGE_UNIT || !r.is_power_of_two() || r > READ_PIECE {
            return Err(LayoutError::UnitSize);
        }
        if !base.is_multiple_of(e) || !slot_size.is_multiple_of(e) {
            return Err(LayoutError::NotAligned);
        }
        let needed = Self::slot_size_needed_as(encoding);
        if slot_size < needed {
            return Err(LayoutError::TooSmall { needed });
        }
        let end = base as u64 + 2 * slot_size as u64;
        if end > flash.capacity() as u64 {
            return Err(LayoutError::OutOfBounds);
        }
        Ok(FlashStore {
            flash,
            base,
            slot_size,
            step_bytes: 4096,
            job: Job::None,
            prepared: None,
            background: None,
            unreadable: 0,
            encoding,
        })
    }

    /// How a save encodes the tables' values.
    pub fn encoding(&self) -> Encoding {
        self.encoding
    }

    /// Makes each erase of a save a background erase: one save step starts it, the following
    /// steps poll it (returning at once while it runs), so a step never waits for an erase.
    /// Other operations that meet an erase under way wait for it; staging an image and
    /// [`TableStore::erase`] still wait for each of their erases.
    pub fn with_background_erase(mut self) -> Self
    where
        F: BackgroundErase,
    {
        self.background = Some(Background {
            start: F::erase_start,
            done: F::erase_done,
            wait: F::erase_wait,
        });
        self
    }

    /// Sets how many bytes one save step programs (4 KiB by default): the longest a step
    /// keeps the node's loop from the bus is this many bytes programmed, or one erase unless
    /// the erases run in the background ([`FlashStore::with_background_erase`]).
    pub fn with_step_bytes(mut self, bytes: u32) -> Self {
        self.step_bytes = bytes.max(PROGRAM as u32);
        self
    }

    /// The flash, to inspect it.
    pub fn flash(&self) -> &F {
        &self.flash
    }

    /// The flash back.
    pub fn into_flash(self) -> F {
        self.flash
    }

    /// Waits for an erase under way (a save's, left running by a cancel) before the flash is
    /// read or written otherwise; the page then counts as erased.
    fn settle(&mut self) -> Result<(), F::Error> {
        let Some(p) = self.prepared.as_mut() else {
            return Ok(());
        };
        let Some(page) = p.pending.take() else {
            return Ok(());
        };
        if let Some(b) = self.background {
            if let Err(e) = (b.wait)(&mut self.flash) {
                self.prepared = None;
                return Err(e);
            }
        }
        self.mark_erased(page);
        Ok(())
    }

    /// Page `page` (an offset in the prepared slot) is erased.
    fn mark_erased(&mut self, page: u32) {
        let e = F::ERASE_SIZE as u32;
        let Some(p) = self.prepared.as_mut() else {
            return;
        };
        if p.from == p.to || (page + e != p.from && page != p.to) {
            (p.from, p.to) = (page, page + e);
        } else if page + e == p.from {
            p.from = page;
        } else {
            p.to = page + e;
        }
    }

    /// The next page of the prepared slot to erase so that `0..need` is erased, if any:
    /// below the erased run first, then above it.
    fn next_to_erase(&self, need: u32) -> Option<u32> {
        let e = F::ERASE_SIZE as u32;
        let p = self.prepared?;
        if p.from == p.to {
            Some(0)
        } else if p.from > 0 {
            Some(p.from - e)
        } else if p.to < need {
            Some(p.to)
        } else {
            None
        }
    }

    /// Bytes up to `end` (an offset in the prepared slot) were programmed: their pages are
    /// no longer erased.
    fn mark_programmed(&mut self, end: u32) {
        let e = F::ERASE_SIZE as u32;
        if let Some(p) = self.prepared.as_mut() {
            p.from = p.from.max(end.div_ceil(e) * e);
            if p.from >= p.to {
                (p.from, p.to) = (0, 0);
            }
        }
    }

    /// Erases of the save in progress still to make (pages of its slot not known erased),
    /// the erase under way included; 0 when no save runs.
    pub fn erases_left(&self) -> u32 {
        let Job::Save { slot, len, .. } = self.job else {
            return 0;
        };
        let e = F::ERASE_SIZE as u32;
        let pages = (Self::IMAGE_AT + len).div_ceil(e);
        match self.prepared {
            Some(p) if p.slot == slot => {
                let known = (p.to.min(pages * e) - p.from.min(pages * e)) / e;
                pages - known
            }
            _ => pages,
        }
    }

    fn slot_at(&self, slot: u8) -> u32 {
        self.base + slot as u32 * self.slot_size
    }

    fn capacity(&self) -> u32 {
        self.slot_size - Self::IMAGE_AT
    }

    /// The slots whose header the flash refused to read at its last read (bit `s` for slot
    /// `s`): a word torn by a power cut on a part with ECC. Such a slot holds no copy; the
    /// next save or staged image goes to it and its erase mends the flash.
    pub fn unreadable_slots(&self) -> u8 {
        self.unreadable
    }

    /// Slot `slot`'s header; an unreadable one (an ECC error) is [`Decoded::Invalid`].
    fn header(&mut self, slot: u8) -> Result<Decoded, F::Error> {
        self.settle()?;
        let mut b = [0u8; HEADER_LEN];
        let at = self.slot_at(slot);
        let read = read_unaligned(&mut self.flash, at, &mut b);
        self.unreadable &= !(1 << slot);
        match read {
            Ok(()) => Ok(SlotHeader::decode(&b)),
            Err(e) if unreadable(&e) => {
                self.unreadable |= 1 << slot;
                Ok(Decoded::Invalid)
            }
            Err(e) => Err(e),
        }
    }

    /// The valid headers of both slots, newest first.
    fn by_sequence(&mut self) -> Result<([Decoded; 2], Newest), F::Error> {
        let decoded = [self.header(0)?, self.header(1)?];
        let mut valid = [None, None];
        for (slot, d) in decoded.iter().enumerate() {
            if let Decoded::Valid(h) = d {
                valid[slot] = Some((slot as u8, *h));
            }
        }
        if let [Some((_, a)), Some((_, b))] = valid {
            if b.sequence > a.sequence {
                valid.swap(0, 1);
            }
        } else if valid[0].is_none() {
            valid.swap(0, 1);
        }
        Ok((decoded, valid))
    }

    fn image<'a>(&'a mut self, slot: u8, len: u32) -> SlotImage<'a, F> {
        let at = self.slot_at(slot) + Self::IMAGE_AT;
        SlotImage {
            flash: &mut self.flash,
            at,
            len: len as usize,
        }
    }

    /// True when the image of a valid header is intact: the CRC it names is its last four
    /// bytes and the image checks (an image the flash refuses to read is not).
    fn intact(&mut self, slot: u8, h: &SlotHeader) -> Result<bool, F::Error> {
        if h.len < 8 || h.len > self.capacity() {
            return Ok(false);
        }
        let mut img = self.image(slot, h.len);
        let mut crc = [0u8; 4];
        let verdict = match img.read(h.len as usize - 4, &mut crc) {
            Ok(()) if u32::from_le_bytes(crc) != h.image_crc => return Ok(false),
            Ok(()) => checkpoint::verify_from(&mut img).map(|_| true),
            Err(e) => Err(SourceError::Read(e)),
        };
        match verdict {
            Ok(v) => Ok(v),
            Err(SourceError::Read(e)) if unreadable(&e) => Ok(false),
            Err(SourceError::Read(e)) => Err(e),
            Err(SourceError::Checkpoint(e)) => Ok(!is_damage(&e)),
        }
    }

    /// Where the next copy goes and its sequence number: the slot that does not hold the
    /// copy to keep (the newest intact one, or one this build cannot judge), one above the
    /// highest sequence number.
    fn next_slot(&mut self) -> Result<(u8, u32), F::Error> {
        let (_, valid) = self.by_sequence()?;
        let sequence = valid[0].map_or(0, |(_, h)| h.sequence).wrapping_add(1);
        for (slot, h) in valid.into_iter().flatten() {
            if h.format != FORMAT || self.intact(slot, &h)? {
                return Ok((1 - slot, sequence));
            }
        }
        Ok((0, sequence))
    }

    /// Restores the newest intact copy into `ctrl` (at boot). With `expected`, a copy learned
    /// under another configuration fingerprint is refused. A damaged newest copy falls back
    /// to the previous one (so does a copy the flash refuses to read: an ECC error); an
    /// intact one this build does not take is refused, never replaced by an older one.
    pub fn restore(
        &mut self,
        ctrl: &mut Controller,
        expected: Option<u32>,
    ) -> Result<StoredCopy, RestoreError> {
        if ctrl.busy() {
            return Err(RestoreError::Busy);
        }
        let flash = |e: F::Error| RestoreError::Flash(code(e));
        let (decoded, valid) = self.by_sequence().map_err(flash)?;
        if valid[0].is_none() {
            return Err(if decoded.iter().all(|d| *d == Decoded::Erased) {
                RestoreError::NothingStored
            } else {
                RestoreError::AllCorrupt
            });
        }
        for (slot, h) in valid.into_iter().flatten() {
            if h.format != FORMAT {
                return Err(RestoreError::Format { found: h.format });
            }
            if let Some(expected) = expected.filter(|e| *e != h.fingerprint) {
                return Err(RestoreError::Fingerprint {
                    stored: h.fingerprint,
                    expected,
                });
            }
            if h.len < 8 || h.len > self.capacity() {
                continue;
            }
            let mut img = self.image(slot, h.len);
            let mut crc = [0u8; 4];
            let restored = match img.read(h.len as usize - 4, &mut crc) {
                Ok(()) if u32::from_le_bytes(crc) != h.image_crc => continue,
                Ok(()) => checkpoint::restore_from(ctrl, &mut img),
                Err(e) => Err(SourceError::Read(e)),
            };
            match restored {
                Ok(header) => return Ok(StoredCopy::of(h.sequence, &header, h.len)),
                Err(SourceError::Read(e)) if unreadable(&e) => continue,
                Err(SourceError::Read(e)) => return Err(flash(e)),
                Err(SourceError::Checkpoint(e)) if is_damage(&e) => continue,
                Err(SourceError::Checkpoint(e)) => return Err(RestoreError::Image(e)),
            }
        }
        Err(RestoreError::AllCorrupt)
    }

    /// Erases the slot's pages from `*erased` on, one page, if `upto` bytes of it are not
    /// erased yet; true when it erased one.
    fn erase_towards(&mut self, slot: u8, erased: &mut u32, upto: u32) -> Result<bool, F::Error> {
        if *erased >= upto {
            return Ok(false);
        }
        let at = self.slot_at(slot) + *erased;
        self.erase_page(at)?;
        *erased += F::ERASE_SIZE as u32;
        Ok(true)
    }

    /// Erases the page at `at` and waits until it is erased.
    fn erase_page(&mut self, at: u32) -> Result<(), F::Error> {
        match self.background {
            Some(b) => {
                (b.start)(&mut self.flash, at)?;
                (b.wait)(&mut self.flash)
            }
            None => self.flash.erase(at, at + F::ERASE_SIZE as u32),
        }
    }

    /// Programs `bytes` (padded with 0xFF to whole write units) at `offset` of the slot's
    /// image, erasing the pages it reaches first.
    fn program(
        &mut self,
        slot: u8,
        erased: &mut u32,
        offset: u32,
        bytes: &[u8],
    ) -> Result<(), F::Error> {
        let unit = F::WRITE_SIZE;
        let padded = bytes.len().div_ceil(unit) * unit;
        let end = Self::IMAGE_AT + offset + padded as u32;
        while self.erase_towards(slot, erased, end)? {}
        self.write_image(slot, offset, bytes)
    }

    /// Programs `bytes` (padded with 0xFF to whole write units) at `offset` of the slot's
    /// image, which is erased.
    fn write_image(&mut self, slot: u8, offset: u32, bytes: &[u8]) -> Result<(), F::Error> {
        let unit = F::WRITE_SIZE;
        let padded = bytes.len().div_ceil(unit) * unit;
        let mut buf = [0xFFu8; PROGRAM];
        buf[..bytes.len()].copy_from_slice(bytes);
        let at = self.slot_at(slot) + Self::IMAGE_AT + offset;
        self.flash.write(at, &buf[..padded])
    }

    /// Programs a slot's header: the commit record that makes its image a stored copy.
    fn commit(&mut self, slot: u8, h: &SlotHeader) -> Result<(), F::Error> {
        let unit = F::WRITE_SIZE;
        let mut buf = [0xFFu8; PROGRAM];
        buf[..HEADER_LEN].copy_from_slice(&h.encode());
        let at = self.slot_at(slot);
        self.flash
            .write(at, &buf[..HEADER_LEN.div_ceil(unit) * unit])
    }

    /// The header of a verified image in `slot`.
    fn header_for(sequence: u32, header: &checkpoint::Header, len: u32, crc: u32) -> SlotHeader {
        SlotHeader {
            format: FORMAT,
            provenance: (header.provenance.preset, header.provenance.ablation),
            sequence,
            len,
            fingerprint: header.config_fingerprint,
            image_crc: crc,
            steps: (header.t1, header.t2),
        }
    }

    /// Reads a programmed image back: its header and CRC when it checks.
    fn read_back(&mut self, slot: u8, len: u32) -> Result<(checkpoint::Header, u32), SaveError> {
        let mut img = self.image(slot, len);
        let header = match checkpoint::verify_from(&mut img) {
            Ok(h) => h,
            Err(SourceError::Read(e)) => return Err(SaveError::Flash(code(e))),
            Err(SourceError::Checkpoint(_)) => return Err(SaveError::Flash(READ_BACK_DIFFERS)),
        };
        let mut crc = [0u8; 4];
        img.read(len as usize - 4, &mut crc)
            .map_err(|e| SaveError::Flash(code(e)))?;
        Ok((header, u32::from_le_bytes(crc)))
    }

    fn save_step_inner(&mut self, ctrl: &Controller) -> Result<Option<StoredCopy>, SaveError> {
        let Job::Save {
            slot,
            sequence,
            provenance,
            len,
            mut cursor,
            mut programmed,
        } = core::mem::replace(&mut self.job, Job::None)
        else {
            return Err(SaveError::NotStarted);
        };
        let flash = |e: F::Error| SaveError::Flash(code(e));
        let keep = |cursor, programmed| Job::Save {
            slot,
            sequence,
            provenance,
            len,
            cursor,
            programmed,
        };
        let e = F::ERASE_SIZE as u32;
        // the erase under way: polled, the step returns while it runs
        let pending = self.prepared.and_then(|p| p.pending);
        if let Some(page) = pending {
            let done = match self.background {
                Some(b) => (b.done)(&mut self.flash),
                None => Ok(true),
            };
            match done {
                Ok(false) => {
                    self.job = keep(cursor, programmed);
                    return Ok(None);
                }
                Ok(true) => {
                    if let Some(p) = self.prepared.as_mut() {
                        p.pending = None;
                    }
                    self.mark_erased(page);
                }
                Err(err) => {
                    self.prepared = None;
                    return Err(flash(err));
                }
            }
        }
        // the slot's pages first, one erase a step, whether or not a trial runs (the tables
        // are not read); none once the image is being programmed
        let next = match cursor {
            None => self.next_to_erase(Self::IMAGE_AT + len),
            Some(_) => None,
        };
        if let Some(page) = next {
            let at = self.slot_at(slot) + page;
            let started = match self.background {
                Some(b) => (b.start)(&mut self.flash, at).map(|_| false),
                None => self.flash.erase(at, at + e).map(|_| true),
            };
            match started {
                Ok(done) => {
                    if done {
                        self.mark_erased(page);
                    } else if let Some(p) = self.prepared.as_mut() {
                        p.pending = Some(page);
                    }
                }
                Err(err) => {
                    self.prepared = None;
                    return Err(flash(err));
                }
            }
            self.job = keep(cursor, programmed);
            return Ok(None);
        }
        // then the image, never while a trial runs: the tables may change under it
        if ctrl.busy() {
            self.job = keep(cursor, programmed);
            return Ok(None);
        }
        let encoding = self.encoding;
        let cur = cursor.get_or_insert_with(|| ImageCursor::new_as(ctrl, provenance, encoding));
        if cur.len() as u32 != len {
            return Err(SaveError::Changed);
        }
        let mut budget = self.step_bytes;
        let mut progressed = false;
        while budget > 0 && !cur.is_done() {
            let mut piece = [0u8; PROGRAM];
            // the cursor's only refusal: the tables changed since the save began
            let n = cur.read(ctrl, &mut piece).map_err(|_| SaveError::Changed)?;
            let padded = n.div_ceil(F::WRITE_SIZE) * F::WRITE_SIZE;
            self.mark_programmed(Self::IMAGE_AT + programmed + padded as u32);
            self.write_image(slot, programmed, &piece[..n])
                .map_err(flash)?;
            programmed += n as u32;
            budget = budget.saturating_sub(PROGRAM as u32);
            progressed = true;
        }
        if progressed {
            self.job = keep(cursor, programmed);
            return Ok(None);
        }
        let expected = *cur.header();
        let (header, crc) = self.read_back(slot, len)?;
        if header != expected {
            return Err(SaveError::Flash(READ_BACK_DIFFERS));
        }
        let h = Self::header_for(sequence, &header, len, crc);
        self.prepared = None;
        self.commit(slot, &h).map_err(flash)?;
        Ok(Some(StoredCopy::of(sequence, &header, len)))
    }

    fn stage_write_inner(&mut self, offset: u32, bytes: &[u8]) -> Result<(), StageError> {
        let flash = |e: F::Error| StageError::Flash(code(e));
        let Job::Stage {
            slot,
            len,
            received,
            erased,
            pending,
            pending_len,
            ..
        } = &mut self.job
        else {
            return Err(StageError::NotStarted);
        };
        if offset != *received {
            return Err(StageError::OutOfOrder);
        }
        if *received as u64 + bytes.len() as u64 > *len as u64 {
            return Err(StageError::TooLarge);
        }
        let (slot, len) = (*slot, *len);
        let mut erased_now = *erased;
        let mut buf = *pending;
        let mut held = *pending_len;
        // bytes programmed so far: everything received but the pending tail
        let mut at = *received - held as u32;
        let mut rest = bytes;
        while !rest.is_empty() {
            let take = rest.len().min(STAGE_UNIT - held);
            buf[held..held + take].copy_from_slice(&rest[..take]);
            held += take;
            rest = &rest[take..];
            // a full buffer (whole write units), or the image's last bytes (padded)
            let last = at + held as u32 == len;
            let n = if last { held } else { STAGE_UNIT };
            if held == STAGE_UNIT || last {
                self.program(slot, &mut erased_now, at, &buf[..n])
                    .map_err(flash)?;
                buf.copy_within(n..held, 0);
                held -= n;
                at += n as u32;
            }
        }
        if let Job::Stage {
            received,
            erased,
            pending,
            pending_len,
            ..
        } = &mut self.job
        {
            *received += bytes.len() as u32;
            *erased = erased_now;
            *pending = buf;
            *pending_len = held;
        }
        Ok(())
    }

    fn stage_apply_inner(
        &mut self,
        ctrl: &mut Controller,
        expected: Expected,
    ) -> Result<StoredCopy, ApplyError> {
        let Job::Stage {
            slot,
            sequence,
            len,
            received,
            ..
        } = self.job
        else {
            return Err(ApplyError::Incomplete);
        };
        if received != len {
            return Err(ApplyError::Incomplete);
        }
        self.job = Job::None;
        let flash = |e: F::Error| ApplyError::Flash(code(e));
        let mut img = self.image(slot, len);
        let header = match checkpoint::check_from(&mut img) {
            Ok(h) => h,
            Err(SourceError::Read(e)) => return Err(flash(e)),
            Err(SourceError::Checkpoint(e)) => return Err(ApplyError::Image(e)),
        };
        let mut crc = [0u8; 4];
        img.read(len as usize - 4, &mut crc).map_err(flash)?;
        let crc = u32::from_le_bytes(crc);
        if crc != expected.crc {
            return Err(ApplyError::CrcMismatch);
        }
        if header.config_fingerprint != expected.fingerprint {
            return Err(ApplyError::FingerprintMismatch);
        }
        if ctrl.busy() {
            return Err(ApplyError::Busy);
        }
        let h = Self::header_for(sequence, &header, len, crc);
        self.commit(slot, &h).map_err(flash)?;
        match checkpoint::restore_from(ctrl, &mut self.image(slot, len)) {
            Ok(header) => Ok(StoredCopy::of(sequence, &header, len)),
            Err(SourceError::Read(e)) => Err(flash(e)),
            Err(SourceError::Checkpoint(e)) => Err(ApplyError::Image(e)),
        }
    }
}

impl<F: NorFlash> TableStore for FlashStore<F> {
    fn stored(&mut self) -> Option<StoredCopy> {
        let (_, valid) = self.by_sequence().ok()?;
        let (_, h) = valid[0]?;
        (h.format == FORMAT).then_some(StoredCopy {
            sequence: h.sequence,
            steps: h.steps,
            fingerprint: h.fingerprint,
            provenance: Provenance {
                preset: h.provenance.0,
                ablation: h.provenance.1,
            },
            len: h.len,
        })
    }

    /// Starts a save; a save cancelled before (nothing committed, staged or erased since)
    /// is resumed: its slot, its sequence number and the pages it erased are kept, its erase
    /// under way goes on.
    fn save_begin(&mut self, ctrl: &Controller, provenance: Provenance) -> Result<(), SaveError> {
        self.job = Job::None;
        let len = ImageCursor::new_as(ctrl, provenance, self.encoding).len() as u32;
        if len > self.capacity() {
            return Err(SaveError::TooLarge);
        }
        let (slot, sequence) = match self.prepared {
            Some(p) => (p.slot, p.sequence),
            None => {
                let (slot, sequence) = self.next_slot().map_err(|e| SaveError::Flash(code(e)))?;
                self.prepared = Some(Prepared {
                    slot,
                    sequence,
                    from: 0,
                    to: 0,
                    pending: None,
                });
                (slot, sequence)
            }
        };
        self.job = Job::Save {
            slot,
            sequence,
            provenance,
            len,
            cursor: None,
            programmed: 0,
        };
        Ok(())
    }

    fn save_step(&mut self, ctrl: &Controller) -> Result<Option<StoredCopy>, SaveError> {
        self.save_step_inner(ctrl)
    }

    fn saving(&self) -> bool {
        matches!(self.job, Job::Save { .. })
    }

    fn save_cancel(&mut self) {
        if self.saving() {
            self.job = Job::None;
        }
    }

    fn stage_begin(&mut self, len: u32) -> Result<(), StageError> {
        self.job = Job::None;
        let settled = self.settle();
        self.prepared = None;
        settled.map_err(|e| StageError::Flash(code(e)))?;
        if len < 8 || len > self.capacity() || len as usize > checkpoint::MAX_SIZE {
            return Err(StageError::TooLarge);
        }
        let (slot, sequence) = self.next_slot().map_err(|e| StageError::Flash(code(e)))?;
        self.job = Job::Stage {
            slot,
            sequence,
            len,
            received: 0,
            erased: 0,
            pending: [0; STAGE_UNIT],
            pending_len: 0,
        };
        Ok(())
    }

    fn stage_write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), StageError> {
        let r = self.stage_write_inner(offset, bytes);
        if matches!(r, Err(StageError::Flash(_))) {
            self.job = Job::None;
        }
        r
    }

    fn stage_apply(
        &mut self,
        ctrl: &mut Controller,
        expected: Expected,
    ) -> Result<StoredCopy, ApplyError> {
        self.stage_apply_inner(ctrl, expected)
    }

    fn erase(&mut self) -> Result<(), EraseError> {
        self.job = Job::None;
        let page = F::ERASE_SIZE as u32;
        let flash = |e: F::Error| EraseError::Flash(code(e));
        let settled = self.settle();
        self.prepared = None;
        settled.map_err(flash)?;
        // both headers first: from then on neither slot holds a copy
        for slot in 0..2 {
            let at = self.slot_at(slot);
            self.flash.erase(at, at + page).map_err(flash)?;
        }
        for slot in 0..2 {
            let at = self.slot_at(slot);
            self.flash
                .erase(at + page, at + self.slot_size)
                .map_err(flash)?;
        }
        Ok(())
    }
}
