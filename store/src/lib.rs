//! The learned tables of the TRN controller in a microcontroller's flash, so that a board
//! keeps what it learned across resets.
//!
//! [`FlashStore`] keeps two slots in a region of any `embedded-storage` [`NorFlash`]. A save
//! writes the checkpoint image (`trn_controller::checkpoint`, produced piece by piece from
//! the live tables: no RAM buffer of it) into the slot that does not hold the newest copy,
//! reads it back, and only then programs the slot's header ([`slot::SlotHeader`]: magic,
//! format version, sequence number, length, configuration fingerprint, the image's CRC and a
//! CRC of its own). The header is the commit record: a save cut short at any program or
//! erase step leaves a slot without a valid header, and the other slot, the previous copy,
//! untouched. At boot [`FlashStore::restore`] takes the valid slot with the highest sequence
//! number; a corrupt newest copy falls back to the previous one; a copy in a format or of a
//! configuration this build does not take is refused with a typed error, never half used.
//!
//! A save is a job of small steps (one erase, or a few KiB programmed) that a node runs
//! between bus messages ([`trn_controller::persist::TableStore`]): first the slot's pages
//! are erased, one a step, whether or not a trial runs (the tables are not read); then,
//! only while the controller runs no trial, the image is programmed. On a flash that erases
//! in the background ([`BackgroundErase`], [`FlashStore::with_background_erase`]) a step
//! starts an erase and the following ones poll it, so no step waits for an erase. A save
//! cancelled and begun again resumes: the pages it erased and has not programmed are not
//! erased again, so each page is erased once a save unless a save is cut after it began to
//! program ([`FlashStore::erases_left`]). An incoming image is staged in the same inactive
//! slot and applied only once whole and verified.
//! [`policy`] derives how often to save from the part's flash endurance; [`RamFlash`] is a
//! NOR flash in memory (the firmware in QEMU, a host's in-process controller).
//!
//! [`NorFlash`]: embedded_storage::nor_flash::NorFlash
#![cfg_attr(not(any(test, feature = "std")), no_std)]
#![deny(unsafe_code)]
#![warn(missing_docs)]

mod flash_store;
pub mod policy;
pub mod ram;
#[cfg(feature = "sim")]
pub mod sim;
pub mod slot;

pub use flash_store::{BackgroundErase, FlashStore, LayoutError, RestoreError};
pub use ram::{RamFlash, RamFlashError};
pub use trn_controller::persist::{
    ApplyError, EraseError, Expected, SaveError, StageError, StoredCopy, TableStore,
};
