//! [`SimFlash`]: a NOR flash in memory that behaves like a real part where a store can go
//! wrong: programming only clears bits and only an erased word may be programmed (as on
//! parts with ECC), erasing works page by page, and power can be lost at any single program
//! (one write unit) or erase (one page) step, optionally tearing that step: a word left
//! with only some of its bits programmed, a page only partly erased. After the cut every
//! operation fails until power is restored ([`SimFlash::restore_power`]), as after a reset.
//!
//! With [`SimFlash::with_ecc`] the flash checks each write unit as a part with ECC does (an
//! STM32H7: a 256-bit flash word and its ECC bits): a word whose program or whose page's
//! erase was torn by a cut holds data and ECC that disagree, and a read that touches it is
//! refused with [`SimFlashError::Ecc`] (on the H7 an uncorrectable double error, a bus fault
//! on a plain read) instead of returning data; the page's next complete erase mends it.
//!
//! With [`SimFlash::with_timing`] the flash also takes time, on a [`SimClock`] the test's
//! loop shares: a blocking erase or a program moves the clock on by its duration (the
//! caller's loop stands still meanwhile), an erase started in the background
//! ([`BackgroundErase`]) only makes the flash busy until its end, and a read or write that
//! meets the flash busy waits (the clock moves to the end of the erase), as a read of a bank
//! under erase stalls on an STM32H7. [`H743Flash`] and [`FlashTiming::H743_X32`] are the
//! STM32H743's sectors and durations.

use std::cell::Cell;
use std::rc::Rc;

use embedded_storage::nor_flash::{
    ErrorType, NorFlash, NorFlashError, NorFlashErrorKind, ReadNorFlash,
};

use crate::BackgroundErase;

/// A simulated clock in microseconds: clones share one time, which only the test's loop
/// and a timed [`SimFlash`] move (the pattern of the host's simulated bus clock).
#[derive(Debug, Clone, Default)]
pub struct SimClock {
    us: Rc<Cell<u64>>,
}

impl SimClock {
    /// A clock at zero.
    pub fn new() -> SimClock {
        SimClock::default()
    }

    /// Now (µs).
    pub fn now_us(&self) -> u64 {
        self.us.get()
    }

    /// Now in milliseconds, wrapping as a node's clock does.
    pub fn now_ms(&self) -> u32 {
        (self.us.get() / 1000) as u32
    }

    /// Moves the clock on by `us`.
    pub fn advance(&self, us: u64) {
        self.us.set(self.us.get() + us);
    }

    /// Moves the clock to `us`; a time in the past leaves it where it is.
    pub fn advance_to(&self, us: u64) {
        if us > self.us.get() {
            self.us.set(us);
        }
    }
}

/// How long a simulated flash takes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FlashTiming {
    /// One page erased (µs).
    pub erase_us: u64,
    /// One write unit programmed (µs).
    pub program_us: u64,
}

impl FlashTiming {
    /// An STM32H743 at x32 parallelism (3.3 V), typical: a 128 KiB sector erased in 1.1 s
    /// (ST's figure for the part), a 256-bit flash word programmed in 130 µs (the
    /// datasheet's typical word programming time at x32, not re-read here).
    pub const H743_X32: FlashTiming = FlashTiming {
        erase_us: 1_100_000,
        program_us: 130,
    };

    /// The same part at its maximum durations: 2.2 s a sector, 260 µs a flash word.
    pub const H743_X32_MAX: FlashTiming = FlashTiming {
        erase_us: 2_200_000,
        program_us: 260,
    };

    /// An STM32G474, typical: a 2 KiB page erased in 22 ms, a double word programmed in
    /// 85 µs (the datasheet's typical figures, not re-read here).
    pub const G474: FlashTiming = FlashTiming {
        erase_us: 22_000,
        program_us: 85,
    };

    /// The same part at its maximum durations: 40 ms a page, 91 µs a double word.
    pub const G474_MAX: FlashTiming = FlashTiming {
        erase_us: 40_000,
        program_us: 91,
    };
}

/// An STM32H743's flash: 32-byte (256-bit) flash words, 128 KiB sectors.
pub type H743Flash = SimFlash<32, 131072>;

/// An STM32G474's flash in dual-bank mode: 8-byte (64-bit) double words, each with its ECC,
/// 2 KiB pages.
pub type G474Flash = SimFlash<8, 2048>;

/// What the simulated flash refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SimFlashError {
    /// An offset or length not a multiple of the unit.
    NotAligned,
    /// Beyond the flash.
    OutOfBounds,
    /// Power was lost (at this step or before it).
    PowerLost,
    /// A word programmed twice without an erase between (or torn, with ECC).
    NotErased,
    /// A read touched a word whose data and ECC disagree (a torn program or erase, with
    /// [`SimFlash::with_ecc`]): the data cannot be read.
    Ecc,
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
    timing: Option<(SimClock, FlashTiming)>,
    /// When the erase under way ends (µs of the clock).
    busy_until: u64,
    /// With ECC: each write unit's data and ECC disagree (`None`: no ECC).
    torn: Option<Vec<bool>>,
    /// Reads refused for a torn word so far.
    ecc_faults: u64,
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
            timing: None,
            busy_until: 0,
            torn: None,
            ecc_faults: 0,
        }
    }

    /// The same flash with ECC (see the module documentation): a torn word is an error to
    /// read, not data.
    pub fn with_ecc(mut self) -> Self {
        self.torn = Some(vec![false; self.mem.len() / WRITE]);
        self
    }

    /// Write units whose data and ECC disagree now (0 without ECC).
    pub fn torn_words(&self) -> usize {
        self.torn
            .as_ref()
            .map_or(0, |t| t.iter().filter(|&&w| w).count())
    }

    /// Leaves the write unit holding `offset` with data and ECC that disagree, as a program
    /// cut short does (with ECC; without it nothing changes).
    pub fn tear_word(&mut self, offset: u32) {
        let word = offset as usize / WRITE;
        self.mark(word..word + 1, true);
    }

    /// Reads refused with [`SimFlashError::Ecc`] so far.
    pub fn ecc_faults(&self) -> u64 {
        self.ecc_faults
    }

    /// Marks the write units `words` torn (with ECC) or whole.
    fn mark(&mut self, words: core::ops::Range<usize>, torn: bool) {
        if let Some(t) = self.torn.as_mut() {
            t[words].fill(torn);
        }
    }

    /// True when a write unit in `at..at + len` is torn (with ECC).
    fn any_torn(&self, at: usize, len: usize) -> bool {
        let Some(t) = self.torn.as_ref() else {
            return false;
        };
        len > 0 && t[at / WRITE..(at + len).div_ceil(WRITE)].iter().any(|&w| w)
    }

    /// The same flash taking time on `clock` (see the module documentation).
    pub fn with_timing(mut self, clock: SimClock, timing: FlashTiming) -> Self {
        self.timing = Some((clock, timing));
        self
    }

    /// True while an erase started in the background runs.
    pub fn busy(&self) -> bool {
        self.timing
            .as_ref()
            .is_some_and(|(c, _)| c.now_us() < self.busy_until)
    }

    /// Waits (moves the clock) until an erase under way ends.
    fn wait(&mut self) {
        if let Some((clock, _)) = &self.timing {
            clock.advance_to(self.busy_until);
        }
    }

    /// Spends `us` of the caller's time.
    fn spend(&self, us: impl Fn(&FlashTiming) -> u64) {
        if let Some((clock, t)) = &self.timing {
            clock.advance(us(t));
        }
    }

    /// Erases page `page` at once (its time spent by the caller); false when power is lost
    /// at this step.
    fn erase_page(&mut self, page: usize) -> bool {
        let range = page * ERASE..(page + 1) * ERASE;
        let words = page * ERASE / WRITE..(page + 1) * ERASE / WRITE;
        if !self.step() {
            if self.tear {
                // an erase cut short: some bytes erased, the others as they were; with ECC
                // every word of the page is left with data and ECC that disagree
                for at in range {
                    if self.random() & 1 == 1 {
                        self.mem[at] = 0xFF;
                    }
                }
                self.mark(words, true);
            }
            return false;
        }
        self.mem[range].fill(0xFF);
        self.mark(words, false);
        self.erases[page] += 1;
        true
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
        self.wait();
        let at = offset as usize;
        if self.any_torn(at, bytes.len()) {
            self.ecc_faults += 1;
            return Err(SimFlashError::Ecc);
        }
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
        self.wait();
        for page in (from as usize / ERASE)..(to as usize / ERASE) {
            self.spend(|t| t.erase_us);
            if !self.erase_page(page) {
                return Err(SimFlashError::PowerLost);
            }
        }
        Ok(())
    }

    fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), SimFlashError> {
        self.check(offset, bytes.len(), WRITE)?;
        self.wait();
        for (k, word) in bytes.chunks_exact(WRITE).enumerate() {
            self.spend(|t| t.program_us);
            let at = offset as usize + k * WRITE;
            if self.mem[at..at + WRITE].iter().any(|&b| b != 0xFF) || self.any_torn(at, WRITE) {
                return Err(SimFlashError::NotErased);
            }
            if !self.step() {
                if self.tear {
                    // a program cut short: some of the bits to clear are cleared, and with
                    // ECC the word's data and ECC disagree
                    for (i, &b) in word.iter().enumerate() {
                        let keep = self.random() as u8;
                        self.mem[at + i] &= b | keep;
                    }
                    self.mark(at / WRITE..at / WRITE + 1, true);
                }
                return Err(SimFlashError::PowerLost);
            }
            self.mem[at..at + WRITE].copy_from_slice(word);
        }
        Ok(())
    }
}

/// A timed flash erases in the background (an untimed one erases at once).
impl<const WRITE: usize, const ERASE: usize> BackgroundErase for SimFlash<WRITE, ERASE> {
    fn erase_start(&mut self, offset: u32) -> Result<(), SimFlashError> {
        self.check(offset, ERASE, ERASE)?;
        self.wait();
        if !self.erase_page(offset as usize / ERASE) {
            return Err(SimFlashError::PowerLost);
        }
        if let Some((clock, t)) = &self.timing {
            self.busy_until = clock.now_us() + t.erase_us;
        }
        Ok(())
    }

    fn erase_done(&mut self) -> Result<bool, SimFlashError> {
        if !self.powered {
            return Err(SimFlashError::PowerLost);
        }
        Ok(!self.busy())
    }

    fn erase_wait(&mut self) -> Result<(), SimFlashError> {
        if !self.powered {
            return Err(SimFlashError::PowerLost);
        }
        self.wait();
        Ok(())
    }
}
