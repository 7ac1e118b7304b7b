//! [`SimFlash`]: a NOR flash in memory that behaves like a real part where a store can go
//! wrong: programming only clears bits and only an erased word may be programmed (as on
//! parts with ECC), erasing works page by page, and power can be lost at any single program
//! (one write unit) or erase (one page) step, optionally tearing that step: a word left
//! with only some of its bits programmed, a page only partly erased. After the cut every
//! operation fails until power is restored ([`SimFlash::restore_power`]), as after a reset.

use embedded_storage::nor_flash::{
    ErrorType, NorFlash, NorFlashError, NorFlashErrorKind, ReadNorFlash,
};

/// What the simulated flash refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SimFlashError {
    /// An offset or length not a multiple of the unit.
    NotAligned,
    /// Beyond the flash.
    OutOfBounds,
    /// Power was lost (at this step or before it).
    PowerLost,
    /// A word programmed twice without an erase between.
    NotErased,
}

impl NorFlashError for SimFlashError {
    fn kind(&self) -> NorFlashErrorKind {
        match self {
            SimFlashError::NotAligned => NorFlashErrorKind::NotAligned,
            SimFlashError::OutOfBounds => NorFlashErrorKind::OutOfBounds,
            _ => NorFlashErrorKind::Other,
        }
    }
}

/// A NOR flash of `WRITE`-byte write units and `ERASE`-byte pages, in memory.
#[derive(Debug, Clone)]
pub struct SimFlash<const WRITE: usize, const ERASE: usize> {
    mem: Vec<u8>,
    steps: u64,
    cut_at: Option<u64>,
    powered: bool,
    tear: bool,
    rng: u64,
    erases: Vec<u32>,
}

impl<const WRITE: usize, const ERASE: usize> SimFlash<WRITE, ERASE> {
    /// An erased flash of `pages` pages.
    pub fn new(pages: usize) -> Self {
        SimFlash {
            mem: vec![0xFF; pages * ERASE],
            steps: 0,
            cut_at: None,
            powered: true,
            tear: false,
            rng: 0x9E37_79B9_7F4A_7C15,
            erases: vec![0; pages],
        }
    }

    /// Loses power at program/erase step number `step` (counted from now, 0 = the next one):
    /// that step does not complete (torn if [`SimFlash::tear`] is set), every operation after
    /// it fails.
    pub fn cut_power_at(&mut self, step: u64) {
        self.steps = 0;
        self.cut_at = Some(step);
    }

    /// Counts steps from now (no cut).
    pub fn reset_steps(&mut self) {
        self.steps = 0;
    }

    /// Whether a cut step is left half done (`seed` drives which bits or bytes).
    pub fn tear(&mut self, tear: bool, seed: u64) {
        self.tear = tear;
        self.rng = seed | 1;
    }

    /// Power back, as after a reset: the memory as the cut left it, no cut pending.
    pub fn restore_power(&mut self) {
        self.powered = true;
        self.cut_at = None;
    }

    /// True when power was lost.
    pub fn power_lost(&self) -> bool {
        !self.powered
    }

    /// Program and erase steps since the last [`SimFlash::cut_power_at`] (or creation).
    pub fn steps(&self) -> u64 {
        self.steps
    }

    /// Erases of each page so far.
    pub fn erase_counts(&self) -> &[u32] {
        &self.erases
    }

    /// The memory.
    pub fn memory(&self) -> &[u8] {
        &self.mem
    }

    /// The memory, to damage it (bit flips).
    pub fn memory_mut(&mut self) -> &mut [u8] {
        &mut self.mem
    }

    fn random(&mut self) -> u64 {
        self.rng ^= self.rng << 13;
        self.rng ^= self.rng >> 7;
        self.rng ^= self.rng << 17;
        self.rng
    }

    /// Counts a step; false when power is lost at it.
    fn step(&mut self) -> bool {
        let cut = self.cut_at == Some(self.steps);
        self.steps += 1;
        if cut {
            self.powered = false;
        }
        !cut
    }

    fn check(&self, offset: u32, len: usize, unit: usize) -> Result<(), SimFlashError> {
        if !self.powered {
            return Err(SimFlashError::PowerLost);
        }
        if !(offset as usize).is_multiple_of(unit) || !len.is_multiple_of(unit) {
            return Err(SimFlashError::NotAligned);
        }
        if offset as usize + len > self.mem.len() {
            return Err(SimFlashError::OutOfBounds);
        }
        Ok(())
    }
}

impl<const WRITE: usize, const ERASE: usize> ErrorType for SimFlash<WRITE, ERASE> {
    type Error = SimFlashError;
}

impl<const WRITE: usize, const ERASE: usize> ReadNorFlash for SimFlash<WRITE, ERASE> {
    const READ_SIZE: usize = 1;

    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), SimFlashError> {
        self.check(offset, bytes.len(), 1)?;
        let at = offset as usize;
        bytes.copy_from_slice(&self.mem[at..at + bytes.len()]);
        Ok(())
    }

    fn capacity(&self) -> usize {
        self.mem.len()
    }
}

impl<const WRITE: usize, const ERASE: usize> NorFlash for SimFlash<WRITE, ERASE> {
    const WRITE_SIZE: usize = WRITE;
    const ERASE_SIZE: usize = ERASE;

    fn erase(&mut self, from: u32, to: u32) -> Result<(), SimFlashError> {
        if to < from {
            return Err(SimFlashError::OutOfBounds);
        }
        self.check(from, (to - from) as usize, ERASE)?;
        for page in (from as usize / ERASE)..(to as usize / ERASE) {
            let range = page * ERASE..(page + 1) * ERASE;
            if !self.step() {
                if self.tear {
                    // an erase cut short: some bytes erased, the others as they were
                    for at in range {
                        if self.random() & 1 == 1 {
                            self.mem[at] = 0xFF;
                        }
                    }
                }
                return Err(SimFlashError::PowerLost);
            }
            self.mem[range].fill(0xFF);
            self.erases[page] += 1;
        }
        Ok(())
    }

    fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), SimFlashError> {
        self.check(offset, bytes.len(), WRITE)?;
        for (k, word) in bytes.chunks_exact(WRITE).enumerate() {
            let at = offset as usize + k * WRITE;
            if self.mem[at..at + WRITE].iter().any(|&b| b != 0xFF) {
                return Err(SimFlashError::NotErased);
            }
            if !self.step() {
                if self.tear {
                    // a program cut short: some of the bits to clear are cleared
                    for (i, &b) in word.iter().enumerate() {
                        let keep = self.random() as u8;
                        self.mem[at + i] &= b | keep;
                    }
                }
                return Err(SimFlashError::PowerLost);
            }
            self.mem[at..at + WRITE].copy_from_slice(word);
        }
        Ok(())
    }
}
