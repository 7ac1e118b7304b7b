//! The seam between a controller node and the place that keeps its learned tables (a
//! microcontroller's flash, a file, memory): [`TableStore`], the operations a node asks of a
//! store, each with its own error enum. A controller and its store reach the node as one
//! [`crate::Control`] ([`crate::control::WithStore`], [`crate::Control::tables`]).

use crate::checkpoint::{Header, Provenance};
use crate::controller::Controller;
use crate::error::Error;

/// A complete stored copy of the tables.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StoredCopy {
    /// The copy's sequence number: each save numbers its copy one above the newest.
    pub sequence: u32,
    /// Stage-1 and stage-2 learning steps of the tables.
    pub steps: (u32, u32),
    /// The configuration fingerprint they were learned under.
    pub fingerprint: u32,
    /// The preset and ablation they were learned with.
    pub provenance: Provenance,
    /// The image's length in bytes.
    pub len: u32,
}

impl StoredCopy {
    /// The copy described by an image's header.
    pub fn of(sequence: u32, header: &Header, len: u32) -> StoredCopy {
        StoredCopy {
            sequence,
            steps: (header.t1, header.t2),
            fingerprint: header.config_fingerprint,
            provenance: header.provenance,
            len,
        }
    }
}

/// What a staged image must be before it is applied: the writer announces both before the
/// first chunk, and the store compares them with the image it received.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Expected {
    /// The image's CRC-32 (its last four bytes, little endian).
    pub crc: u32,
    /// The configuration fingerprint in its header.
    pub fingerprint: u32,
}

/// Why a save failed. The previous stored copy stays the newest.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SaveError {
    /// No save is in progress (a step without a begin, or after the last).
    NotStarted,
    /// The image does not fit a slot.
    TooLarge,
    /// The tables changed while they were being written (the save is abandoned).
    Changed,
    /// The flash refused an operation (its `NorFlashErrorKind` as a code).
    Flash(u8),
}

/// Why a piece of an incoming image was refused; nothing is applied.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum StageError {
    /// No transfer was begun.
    NotStarted,
    /// The announced image is longer than a slot (or than any checkpoint).
    TooLarge,
    /// A piece that is not the next one (pieces are written in order, once).
    OutOfOrder,
    /// The flash refused an operation.
    Flash(u8),
}

/// Why a staged image was not applied; the tables and the stored copies are unchanged.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ApplyError {
    /// Not every byte announced was received.
    Incomplete,
    /// The image is not a checkpoint this build restores (the reason).
    Image(Error),
    /// Its CRC is not the one announced.
    CrcMismatch,
    /// Its configuration fingerprint is not the one announced.
    FingerprintMismatch,
    /// A trial is running.
    Busy,
    /// The flash refused an operation.
    Flash(u8),
}

/// Why erasing the stored copies failed (some may be left, each complete or invalid).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EraseError {
    /// The flash refused an operation.
    Flash(u8),
}

/// The operations a node asks of the place that keeps its tables. A save is a job of small
/// steps (one flash operation each) so that the node's loop keeps serving the bus; an
/// incoming image is staged apart from the newest stored copy and applied only once whole
/// and verified.
pub trait TableStore {
    /// The newest complete stored copy, if any.
    fn stored(&mut self) -> Option<StoredCopy>;
    /// Starts saving the tables of `ctrl` (learned under a configuration from
    /// `provenance`); a save in progress is abandoned.
    fn save_begin(
        &mut self,
        ctrl: &Controller,
        provenance: Provenance,
    ) -> core::result::Result<(), SaveError>;
    /// One step of the save in progress; the copy when it is complete and committed.
    fn save_step(
        &mut self,
        ctrl: &Controller,
    ) -> core::result::Result<Option<StoredCopy>, SaveError>;
    /// True while a save is in progress.
    fn saving(&self) -> bool;
    /// Abandons the save in progress: the newest copy stays the newest.
    fn save_cancel(&mut self);
    /// Starts staging an image of `len` bytes (a transfer in); one in progress is abandoned.
    fn stage_begin(&mut self, len: u32) -> core::result::Result<(), StageError>;
    /// Stages the bytes at `offset` (the next ones: pieces come in order).
    fn stage_write(&mut self, offset: u32, bytes: &[u8]) -> core::result::Result<(), StageError>;
    /// Verifies the staged image (everything [`crate::checkpoint::restore`] checks, and
    /// `expected`), restores it into `ctrl` and makes it the newest stored copy.
    fn stage_apply(
        &mut self,
        ctrl: &mut Controller,
        expected: Expected,
    ) -> core::result::Result<StoredCopy, ApplyError>;
    /// Erases every stored copy.
    fn erase(&mut self) -> core::result::Result<(), EraseError>;
}

impl<S: TableStore + ?Sized> TableStore for &mut S {
    fn stored(&mut self) -> Option<StoredCopy> {
        (**self).stored()
    }
    fn save_begin(
        &mut self,
        ctrl: &Controller,
        provenance: Provenance,
    ) -> core::result::Result<(), SaveError> {
        (**self).save_begin(ctrl, provenance)
    }
    fn save_step(
        &mut self,
        ctrl: &Controller,
    ) -> core::result::Result<Option<StoredCopy>, SaveError> {
        (**self).save_step(ctrl)
    }
    fn saving(&self) -> bool {
        (**self).saving()
    }
    fn save_cancel(&mut self) {
        (**self).save_cancel()
    }
    fn stage_begin(&mut self, len: u32) -> core::result::Result<(), StageError> {
        (**self).stage_begin(len)
    }
    fn stage_write(&mut self, offset: u32, bytes: &[u8]) -> core::result::Result<(), StageError> {
        (**self).stage_write(offset, bytes)
    }
    fn stage_apply(
        &mut self,
        ctrl: &mut Controller,
        expected: Expected,
    ) -> core::result::Result<StoredCopy, ApplyError> {
        (**self).stage_apply(ctrl, expected)
    }
    fn erase(&mut self) -> core::result::Result<(), EraseError> {
        (**self).erase()
    }
}
