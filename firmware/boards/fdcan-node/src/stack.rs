//! The stack on a board: its high-water mark from cortex-m-rt's painted stack (the board
//! packages enable its `paint-stack` feature), logged by the node's loop (the figure QEMU
//! cannot measure for a board image), and a guard at its bottom ([`guard`]).
//!
//! The stack grows down from the top of RAM towards the end of the static data
//! (`_stack_end`): without a guard, an overflow would silently overwrite the last statics
//! (the controller's tables, the node's state). The guard is an MPU region of 32 bytes at
//! the stack's bottom that nothing may read or write: a push into it is a memory fault,
//! escalated to the hard fault that records its cause and resets the part
//! ([`crate::recover`]). When the fault's own stacking also falls into the guard, the core
//! locks up, and the independent watchdog resets it: either way the board comes back, and
//! nothing past the stack was written.

extern "C" {
    static _stack_start: u32;
    static _stack_end: u32;
}

/// Bytes of the guard region (the MPU's smallest, aligned to its size).
pub const GUARD: usize = 32;

/// The guard's first byte: `_stack_end` rounded up to [`GUARD`].
fn guard_start() -> usize {
    let end = core::ptr::addr_of!(_stack_end) as usize;
    end.next_multiple_of(GUARD)
}

/// Bytes of stack ever used: cortex-m-rt fills the stack with a pattern at reset; the lowest
/// overwritten word above the guard marks the high-water mark.
pub fn stack_high_water_mark() -> u32 {
    const PAINT: u32 = 0xCCCC_CCCC;
    // SAFETY: reads the words between the guard's end and the top of the stack (the linker
    // script's symbols), all inside RAM and outside the guard; volatile, so the scan is not
    // optimised away.
    #[allow(unsafe_code)]
    unsafe {
        let top = core::ptr::addr_of!(_stack_start) as usize;
        let mut p = guard_start() + GUARD;
        while p < top && core::ptr::read_volatile(p as *const u32) == PAINT {
            p += 4;
        }
        (top - p) as u32
    }
}

/// Puts the guard at the stack's bottom: MPU region 7 (the highest number wins where regions
/// overlap) of [`GUARD`] bytes, no access, never executed; the default memory map stays in
/// force elsewhere (PRIVDEFENA), so nothing else changes. Called once at boot, before the
/// node runs. The stack's usable size shrinks by the guard and its alignment (at most 60
/// bytes), which `scripts/cross/budget.sh` charges to the board's RAM.
pub fn guard() {
    /// RASR: enable, SIZE = log2(32) - 1, AP = no access, XN.
    const RASR: u32 = 1 | (4 << 1) | (1 << 28);
    /// CTRL: ENABLE and PRIVDEFENA.
    const CTRL: u32 = 1 | (1 << 2);
    // SAFETY: the MPU's registers, written once at boot by the only code running; region 7
    // is used by nothing else (no other code in the images touches the MPU); the guard lies
    // between the static data and the stack pointer, which is far above it at boot
    #[allow(unsafe_code)]
    unsafe {
        let mpu = &*cortex_m::peripheral::MPU::PTR;
        cortex_m::asm::dsb();
        mpu.rnr.write(7);
        mpu.rbar.write(guard_start() as u32);
        mpu.rasr.write(RASR);
        mpu.ctrl.write(CTRL);
        cortex_m::asm::dsb();
        cortex_m::asm::isb();
    }
}
