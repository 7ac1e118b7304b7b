//! What brings a stuck board back: a panic or a hard fault logs its cause and resets the
//! part (instead of spinning until someone power-cycles it), and the loop feeds the
//! board's independent watchdog once a turn ([`run`](crate::run)), so a loop that stops
//! turning resets it too.
//!
//! Each handler leaves a record of its cause in RAM that no reset clears (`.uninit`), which
//! the next boot reads ([`take_record`]) for the cause the node announces on the bus
//! (`trn_node::reset`).
//!
//! The defmt log goes over RTT in non-blocking mode (defmt-rtt's `disable-blocking-mode`): a
//! board left running without a probe attached loses log lines rather than stopping at the
//! next one with its interrupts masked.
#![allow(unsafe_code)]

use core::mem::MaybeUninit;

use cortex_m::peripheral::SCB;
use cortex_m_rt::{exception, ExceptionFrame};
use trn_node::reset::{record, recorded, Record};
use trn_node::ResetCause;

/// The handlers' record: in `.uninit`, which the start-up code neither zeroes nor
/// initialises, so it survives the reset the handler makes.
#[link_section = ".uninit.trn_reset"]
static mut RECORD: MaybeUninit<Record> = MaybeUninit::uninit();

fn write_record(r: Record) {
    // SAFETY: the record's own words, written volatile by a handler that resets next (or by
    // the boot before anything else runs); nothing else refers to them
    unsafe {
        let p = core::ptr::addr_of_mut!(RECORD).cast::<u32>();
        for (i, w) in r.iter().enumerate() {
            core::ptr::write_volatile(p.add(i), *w);
        }
    }
}

/// The cause a panic or hard-fault handler recorded before the last reset, and its detail,
/// then the record cleared. After a power-on (`power_on`, from the reset flags) the RAM holds
/// nothing a handler wrote and is not read: on parts with ECC on their RAM (the H743) a read
/// of RAM never written may be an ECC error; it is written (cleared) at every boot, so every
/// later boot reads what the one before left.
pub fn take_record(power_on: bool) -> Option<(ResetCause, u32)> {
    let found = if power_on {
        None
    } else {
        let mut r: Record = [0; 4];
        // SAFETY: the record's words, written at the previous boot or by a handler since
        unsafe {
            let p = core::ptr::addr_of!(RECORD).cast::<u32>();
            for (i, w) in r.iter_mut().enumerate() {
                *w = core::ptr::read_volatile(p.add(i));
            }
        }
        recorded(&r)
    };
    write_record([0; 4]);
    found
}

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

/// A panic: its message logged and its source line recorded, then the part reset.
#[panic_handler]
fn panic(info: &core::panic::PanicInfo) -> ! {
    let line = info.location().map_or(0, |l| l.line());
    write_record(record(ResetCause::Panic, line));
    defmt::error!("panic: {}: reset", defmt::Display2Format(info));
    SCB::sys_reset()
}

/// A hard fault (a bus, memory or usage fault escalated): where it struck logged and
/// recorded, then the part reset.
#[exception]
unsafe fn HardFault(frame: &ExceptionFrame) -> ! {
    write_record(record(ResetCause::HardFault, frame.pc()));
    defmt::error!("hard fault at pc 0x{:08x}: reset", frame.pc());
    SCB::sys_reset()
}
