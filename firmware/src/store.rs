//! The PIL firmware's store of its learned tables and the seed of its guard.
//!
//! QEMU's mps2-an386 has no flash a program can write, so the store's "flash" is RAM: a
//! [`RamFlash`] over the memory memory.x reserves from `__tables_flash` (the last MiB of the
//! data SSRAM, outside RAM, `.data` and `.bss`, so the RAM budget of the firmware is not
//! charged for what a board keeps in flash: two slots of 229,376 B). It is erased at every
//! boot, as a board's flash would be after a fresh programming: a PIL run starts from
//! nothing stored. Only the f32 build has it: the compact build has no RAM to spare for the
//! store's state (its node serves the tables without a store: reads, no writes or saves).
//!
//! The guard's seed comes from the host through semihosting (`/dev/urandom` of the machine
//! QEMU runs on), as a board takes it from its RNG; if that fails the guard stays unseeded
//! and the node never replaces learned tables over the bus (SPEC 3.4).

#[cfg(not(feature = "compact"))]
use trn_controller::checkpoint;
#[cfg(not(feature = "compact"))]
use trn_store::{FlashStore, RamFlash};

/// Bytes of a program unit and of a page of the emulated flash.
#[cfg(not(feature = "compact"))]
const WRITE: usize = 8;
#[cfg(not(feature = "compact"))]
const ERASE: usize = 4096;

/// A slot: the header (64 bytes) and the largest checkpoint, in whole pages.
#[cfg(not(feature = "compact"))]
const SLOT: usize = (64 + checkpoint::MAX_SIZE).div_ceil(ERASE) * ERASE;

#[cfg(not(feature = "compact"))]
extern "C" {
    /// The memory memory.x reserves for the emulated flash: its first byte, and the byte
    /// past its end.
    static mut __tables_flash: [u8; 2 * SLOT];
    static __tables_flash_end: u8;
}

/// The emulated flash of the store.
#[cfg(not(feature = "compact"))]
pub type Flash = RamFlash<&'static mut [u8], WRITE, ERASE>;

/// The store of the tables.
#[cfg(not(feature = "compact"))]
pub type Store = FlashStore<Flash>;

/// The store over the emulated flash, erased. Called once, at boot.
#[cfg(not(feature = "compact"))]
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
    let Ok(store) = FlashStore::new(RamFlash::new(mem), 0, SLOT as u32) else {
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
