//! The PIL firmware's store of its learned tables and the seed of its guard.
//!
//! QEMU's mps2-an386 has no flash a program can write, so the store's "flash" is RAM: a
//! [`RamFlash`] over the memory memory.x reserves from `__tables_flash` (the last MiB of the
//! data SSRAM, outside RAM, `.data` and `.bss`, so the RAM budget of the firmware is not
//! charged for what a board keeps in flash). It is erased at every boot, as a board's flash
//! would be after a fresh programming: a PIL run starts from nothing stored. The f32 build
//! keeps f32 images (checkpoint format 2); the compact build keeps compact images (format 3,
//! half the size), as the STM32G474 board does, so that its RAM and stack budgets include
//! the store's state and its deepest calls.
//!
//! The guard's seed comes from the host through semihosting (`/dev/urandom` of the machine
//! QEMU runs on), as a board takes it from its RNG; if that fails the guard stays unseeded
//! and the node never replaces learned tables over the bus (SPEC 3.4).

use trn_controller::checkpoint::Encoding;
use trn_store::{FlashStore, RamFlash};

/// Bytes of a program unit and of a page of the emulated flash.
const WRITE: usize = 8;
const ERASE: usize = 4096;

/// How the store encodes the tables: as this build holds them.
const ENCODING: Encoding = if cfg!(feature = "compact") {
    Encoding::Compact
} else {
    Encoding::F32
};

/// A slot: the header (64 bytes) and the largest checkpoint, in whole pages.
const SLOT: usize = (64 + ENCODING.max_size()).div_ceil(ERASE) * ERASE;

extern "C" {
    /// The memory memory.x reserves for the emulated flash: its first byte, and the byte
    /// past its end.
    static mut __tables_flash: [u8; 2 * SLOT];
    static __tables_flash_end: u8;
}

/// The emulated flash of the store.
pub type Flash = RamFlash<&'static mut [u8], WRITE, ERASE>;

/// The store of the tables.
pub type Store = FlashStore<Flash>;

/// The store over the emulated flash, erased. Called once, at boot.
pub fn store() -> Store {
    // SAFETY: memory.x reserves the region for this buffer alone (no section is linked
    // there); the only reference to it, taken once at boot; single-threaded firmware, no
    // interrupts. Its size is checked against the region first.
    #[allow(unsafe_code)]
    let mem: &'static mut [u8] = unsafe {
        let start = core::ptr::addr_of!(__tables_flash) as usize;
        let end = core::ptr::addr_of!(__tables_flash_end) as usize;
        if end.saturating_sub(start) < 2 * SLOT {
            crate::fail("the emulated flash is smaller than two slots");
        }
        &mut *core::ptr::addr_of_mut!(__tables_flash)
    };
    let Ok(store) = FlashStore::new_as(RamFlash::new(mem), 0, SLOT as u32, ENCODING) else {
        crate::fail("the store's layout")
    };
    store
}

/// 16 bytes of the host's `/dev/urandom` through semihosting, or zeros (an unseeded guard)
/// when the host gives none.
pub fn entropy() -> [u8; 16] {
    use cortex_m_semihosting::{nr, syscall};
    let mut seed = [0u8; 16];
    let path = b"/dev/urandom\0";
    // SAFETY: semihosting calls with a NUL-terminated path and a buffer of the length given.
    #[allow(unsafe_code)]
    unsafe {
        let fd = syscall!(OPEN, path.as_ptr(), nr::open::R_BINARY, path.len() - 1) as isize;
        if fd < 0 {
            return [0; 16];
        }
        // READ returns the number of bytes not read
        let missing = syscall!(READ, fd, seed.as_mut_ptr(), seed.len());
        syscall!(CLOSE, fd);
        if missing != 0 {
            return [0; 16];
        }
    }
    seed
}
