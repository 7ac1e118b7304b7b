//! What the boards' stores of their learned tables share: the error of a board's flash
//! ([`FlashError`]: embassy's, or an ECC double error met by a read), how often a board saves
//! ([`SAVE_EVERY_STEPS`], [`NODE_CONFIG`]) and the restore at boot with its log
//! ([`restore_at_boot`]). Each board has its own flash wrapper (the H743's bus-fault-masked
//! reads and bank-2 sector erase, the G474's NMI-guarded reads and bank-2 page erase).

use embassy_stm32::flash::Error;
use embedded_storage::nor_flash::{NorFlash, NorFlashError, NorFlashErrorKind};
use trn_controller::persist::StoredCopy;
use trn_controller::Controller;
use trn_node::NodeConfig;
use trn_store::policy::{steps_between_saves, Endurance};
use trn_store::{FlashStore, RestoreError};

/// What a board's store flash refused: embassy's error, or a read that met a flash word whose
/// ECC found a double error (a word torn by a power cut), which the store takes for a damaged
/// copy (kind `Other`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FlashError {
    /// embassy's flash driver refused.
    Flash(Error),
    /// A read met an uncorrectable ECC error.
    Ecc,
}

impl From<Error> for FlashError {
    fn from(e: Error) -> Self {
        FlashError::Flash(e)
    }
}

impl NorFlashError for FlashError {
    fn kind(&self) -> NorFlashErrorKind {
        match self {
            FlashError::Flash(e) => e.kind(),
            FlashError::Ecc => NorFlashErrorKind::Other,
        }
    }
}

/// Learning steps between two saves by steps (2,887): what both parts' flash (10,000 erase
/// cycles per sector or page) allows for ten years of 5,000 learning steps and one other save
/// a day (`trn_store::policy`).
pub const SAVE_EVERY_STEPS: u32 = steps_between_saves(&Endurance {
    erase_cycles: 10_000,
    years: 10,
    steps_per_day: 5_000,
    other_saves_per_day: 1,
});

/// The node's settings on a board with a store: saves every [`SAVE_EVERY_STEPS`].
pub const NODE_CONFIG: NodeConfig = NodeConfig {
    save_every_steps: SAVE_EVERY_STEPS,
    ..NodeConfig::DEFAULT
};

/// Restores the newest intact copy of the tables into `ctrl` and logs what it restored, or
/// why nothing (as the host's `board::restore_problem`), and any slot a torn flash word made
/// unreadable; the copy, for the node to announce.
pub fn restore_at_boot<F: NorFlash>(
    store: &mut FlashStore<F>,
    ctrl: &mut Controller,
) -> Option<StoredCopy> {
    let restored = match store.restore(ctrl, None) {
        Ok(copy) => {
            defmt::info!(
                "tables restored from flash: copy {}, {} + {} learning steps, {} B",
                copy.sequence,
                copy.steps.0,
                copy.steps.1,
                copy.len
            );
            Some(copy)
        }
        Err(e) => {
            restore_problem(&e);
            None
        }
    };
    let torn = store.unreadable_slots();
    if torn != 0 {
        defmt::warn!(
            "store slots {=u8:b}: a flash word torn by a power cut (ECC); no copy there, the next save erases it",
            torn
        );
    }
    restored
}

/// What a boot that restored nothing logs.
fn restore_problem(e: &RestoreError) {
    match e {
        RestoreError::NothingStored => defmt::info!("no tables stored: the tables start zeroed"),
        RestoreError::AllCorrupt => {
            defmt::warn!("no intact copy of the tables is stored: the tables start zeroed")
        }
        RestoreError::Format { found } => defmt::warn!(
            "the stored tables are in store format {}, which this build does not read",
            found
        ),
        RestoreError::Image(_) => defmt::warn!("the stored tables are refused (checkpoint)"),
        RestoreError::Fingerprint { .. } | RestoreError::Busy => {
            defmt::warn!("the stored tables could not be restored")
        }
        RestoreError::Flash(code) => {
            defmt::warn!("the stored tables could not be read (flash error {})", code)
        }
    }
}
