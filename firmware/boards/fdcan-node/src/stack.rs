//! The stack's high-water mark on a board, from cortex-m-rt's painted stack (the board
//! packages enable its `paint-stack` feature), logged by the node's loop: the figure QEMU
//! cannot measure for a board image.

extern "C" {
    static _stack_start: u32;
    static _stack_end: u32;
}

/// Bytes of stack ever used: cortex-m-rt fills the stack with a pattern at reset; the lowest
/// overwritten word marks the high-water mark.
pub fn stack_high_water_mark() -> u32 {
    const PAINT: u32 = 0xCCCC_CCCC;
    // SAFETY: reads the words between the end of the static data and the top of the stack
    // (the linker script's symbols), all inside RAM; volatile, so the scan is not optimised
    // away.
    #[allow(unsafe_code)]
    unsafe {
        let top = core::ptr::addr_of!(_stack_start) as usize;
        let mut p = core::ptr::addr_of!(_stack_end) as usize;
        while p < top && core::ptr::read_volatile(p as *const u32) == PAINT {
            p += 4;
        }
        (top - p) as u32
    }
}
