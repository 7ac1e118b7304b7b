//! What brings a stuck board back: a panic or a hard fault logs its cause and resets the
//! part (instead of spinning until someone power-cycles it), and the loop feeds the
//! board's independent watchdog once a turn ([`run`](crate::run)), so a loop that stops
//! turning resets it too.
//!
//! The defmt log goes over RTT in non-blocking mode (defmt-rtt's `disable-blocking-mode`): a
//! board left running without a probe attached loses log lines rather than stopping at the
//! next one with its interrupts masked.
#![allow(unsafe_code)]

use cortex_m::peripheral::SCB;
use cortex_m_rt::{exception, ExceptionFrame};

/// The bound on a wait for the HSE to start ([`hse_started`]): polls of its ready flag, each
/// a few cycles of the reset clock (an STM32's HSI, 16-64 MHz): from tens of milliseconds to
/// well under a second, far above a crystal's start-up time (a few ms) or a bypass clock's.
pub const HSE_START_TURNS: u32 = 1_000_000;

/// Waits until `ready` says the HSE runs, at most [`HSE_START_TURNS`] turns: true when it
/// started. embassy's clock setup waits for the HSE without a bound; a board calls this
/// (with the HSE switched on) before it, and falls back on its internal oscillator when
/// the HSE does not start.
pub fn hse_started(mut ready: impl FnMut() -> bool) -> bool {
    (0..HSE_START_TURNS).any(|_| ready())
}

/// A panic: its message logged, then the part reset.
#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    defmt::error!("panic: {}: reset", defmt::Display2Format(info));
    SCB::sys_reset()
}

/// A hard fault (a bus, memory or usage fault escalated): where it struck logged, then the
/// part reset.
#[exception]
unsafe fn HardFault(frame: &ExceptionFrame) -> ! {
    defmt::error!("hard fault at pc 0x{:08x}: reset", frame.pc());
    SCB::sys_reset()
}
