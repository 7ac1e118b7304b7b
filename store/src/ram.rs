//! [`RamFlash`]: a NOR flash in memory, for a store whose "flash" is RAM: the firmware in
//! QEMU (which has no flash a program can write), the host's in-process controller, tests.
//! It behaves like a NOR part where a store depends on it: a write only clears bits (a word
//! programmed twice holds the AND of both), an erase sets whole pages to 0xFF, and offsets
//! and lengths must be whole write units and pages. It cannot lose power: that is
//! [`crate::sim::SimFlash`]'s business.
//!
//! The memory is any `AsRef<[u8]> + AsMut<[u8]>`: a `&'static mut [u8; N]` on a
//! microcontroller, a `Vec<u8>` on a host. A new `RamFlash` is erased.

use embedded_storage::nor_flash::{
    ErrorType, NorFlash, NorFlashError, NorFlashErrorKind, ReadNorFlash,
};

/// What [`RamFlash`] refused.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RamFlashError {
    /// An offset or length not a multiple of the unit.
    NotAligned,
    /// Beyond the memory.
    OutOfBounds,
}

impl NorFlashError for RamFlashError {
    fn kind(&self) -> NorFlashErrorKind {
        match self {
            RamFlashError::NotAligned => NorFlashErrorKind::NotAligned,
            RamFlashError::OutOfBounds => NorFlashErrorKind::OutOfBounds,
        }
    }
}

/// A NOR flash of `WRITE`-byte write units and `ERASE`-byte pages over the memory `M`.
#[derive(Debug)]
pub struct RamFlash<M, const WRITE: usize, const ERASE: usize> {
    mem: M,
}

impl<M: AsRef<[u8]> + AsMut<[u8]>, const WRITE: usize, const ERASE: usize>
    RamFlash<M, WRITE, ERASE>
{
    /// The flash over `mem`, erased (every byte 0xFF). Only whole pages are used: a tail
    /// shorter than a page is not part of the flash.
    pub fn new(mut mem: M) -> Self {
        mem.as_mut().fill(0xFF);
        RamFlash { mem }
    }

    /// The flash over `mem` as it is (a memory that kept its contents, e.g. a file read
    /// back, or RAM that survived a reset).
    pub fn keeping(mem: M) -> Self {
        RamFlash { mem }
    }

    /// The memory.
    pub fn memory(&self) -> &[u8] {
        self.mem.as_ref()
    }

    /// The memory back.
    pub fn into_memory(self) -> M {
        self.mem
    }

    fn len(&self) -> usize {
        self.mem.as_ref().len() / ERASE * ERASE
    }

    fn check(&self, offset: u32, len: usize, unit: usize) -> Result<usize, RamFlashError> {
        let at = offset as usize;
        if !at.is_multiple_of(unit) || !len.is_multiple_of(unit) {
            return Err(RamFlashError::NotAligned);
        }
        match at.checked_add(len) {
            Some(end) if end <= self.len() => Ok(at),
            _ => Err(RamFlashError::OutOfBounds),
        }
    }
}

impl<M, const WRITE: usize, const ERASE: usize> ErrorType for RamFlash<M, WRITE, ERASE> {
    type Error = RamFlashError;
}

impl<M: AsRef<[u8]> + AsMut<[u8]>, const WRITE: usize, const ERASE: usize> ReadNorFlash
    for RamFlash<M, WRITE, ERASE>
{
    const READ_SIZE: usize = 1;

    fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), RamFlashError> {
        let at = self.check(offset, bytes.len(), 1)?;
        bytes.copy_from_slice(&self.mem.as_ref()[at..at + bytes.len()]);
        Ok(())
    }

    fn capacity(&self) -> usize {
        self.len()
    }
}

impl<M: AsRef<[u8]> + AsMut<[u8]>, const WRITE: usize, const ERASE: usize> NorFlash
    for RamFlash<M, WRITE, ERASE>
{
    const WRITE_SIZE: usize = WRITE;
    const ERASE_SIZE: usize = ERASE;

    fn erase(&mut self, from: u32, to: u32) -> Result<(), RamFlashError> {
        let len = to.checked_sub(from).ok_or(RamFlashError::OutOfBounds)? as usize;
        let at = self.check(from, len, ERASE)?;
        self.mem.as_mut()[at..at + len].fill(0xFF);
        Ok(())
    }

    fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), RamFlashError> {
        let at = self.check(offset, bytes.len(), WRITE)?;
        // programming only clears bits, as on a NOR part
        for (m, b) in self.mem.as_mut()[at..at + bytes.len()]
            .iter_mut()
            .zip(bytes)
        {
            *m &= *b;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    type Flash = RamFlash<Vec<u8>, 4, 64>;

    #[test]
    fn erased_at_first_programs_by_clearing_bits_and_erases_pages() {
        // a tail shorter than a page is not flash
        let mut f = Flash::new(vec![0; 200]);
        assert_eq!(f.capacity(), 192);
        let mut b = [0u8; 4];
        f.read(188, &mut b).unwrap();
        assert_eq!(b, [0xFF; 4]);
        f.write(4, &[0xF0, 0x0F, 0xAA, 0x55]).unwrap();
        f.write(4, &[0x3C, 0xFF, 0xFF, 0x00]).unwrap();
        f.read(4, &mut b).unwrap();
        assert_eq!(b, [0x30, 0x0F, 0xAA, 0x00], "a second program ANDs");
        f.erase(0, 64).unwrap();
        f.read(4, &mut b).unwrap();
        assert_eq!(b, [0xFF; 4]);
    }

    #[test]
    fn misaligned_and_out_of_bounds_are_refused() {
        let mut f = Flash::new(vec![0; 128]);
        assert_eq!(f.write(2, &[0; 4]), Err(RamFlashError::NotAligned));
        assert_eq!(f.write(0, &[0; 3]), Err(RamFlashError::NotAligned));
        assert_eq!(f.erase(0, 32), Err(RamFlashError::NotAligned));
        assert_eq!(f.erase(64, 0), Err(RamFlashError::OutOfBounds));
        assert_eq!(f.write(128, &[0; 4]), Err(RamFlashError::OutOfBounds));
        assert_eq!(
            f.read(u32::MAX, &mut [0; 2]),
            Err(RamFlashError::OutOfBounds)
        );
        // nothing was changed by the refusals
        assert!(f.memory().iter().all(|&b| b == 0xFF));
    }

    /// A store in a RAM flash saves, restores and stages like one in a part's flash.
    #[test]
    fn a_store_round_trips_tables_through_it() {
        use crate::{FlashStore, TableStore};
        use trn_controller::checkpoint::Provenance;
        use trn_controller::{Config, Controller};
        type Big = RamFlash<Vec<u8>, 8, 4096>;
        let slot = FlashStore::<Big>::slot_size_needed();
        let flash = Big::new(vec![0; 2 * slot as usize]);
        let mut store = FlashStore::new(flash, 0, slot).unwrap();
        let mut a = Controller::new(Config::project_default());
        a.init_random(5);
        store.save_begin(&a, Provenance::CUSTOM).unwrap();
        let copy = loop {
            if let Some(c) = store.save_step(&a).unwrap() {
                break c;
            }
        };
        let mut b = Controller::new(Config::project_default());
        b.init_random(6);
        assert_eq!(store.restore(&mut b, None).unwrap(), copy);
        let mut x = vec![0; trn_controller::checkpoint::MAX_SIZE];
        let mut y = x.clone();
        let n = trn_controller::checkpoint::save(&a, Provenance::CUSTOM, &mut x).unwrap();
        trn_controller::checkpoint::save(&b, Provenance::CUSTOM, &mut y).unwrap();
        assert_eq!(x[..n], y[..n]);
    }
}
