//! The QEMU machine's watchdog, as a board's independent watchdog: mps2-an386's CMSDK APB
//! watchdog (at 0x4000_8000, clocked at the machine's 25 MHz, its interrupt wired to the NMI).
//! The node's loop feeds it once a turn ([`feed`]); a loop that stops turning lets it run
//! out: its first time-out raises the NMI, whose handler records the cause in RAM that no
//! reset clears (`.uninit`: the record `trn_node::reset` defines, as a board's panic and
//! fault handlers leave theirs), and its second resets the machine. This part keeps no reset
//! flags a program can read, so the next boot takes its cause from that record alone
//! ([`take_cause`]): the watchdog's, or a power-on when there is none. The cause is printed
//! over semihosting and announced on the bus as a board announces it (`ErrorReport{RESET_CAUSE}`).
#![allow(unsafe_code)]

use core::mem::MaybeUninit;

use cortex_m_rt::exception;
use trn_node::reset::{record, recorded, Record};
use trn_node::ResetCause;

const BASE: usize = 0x4000_8000;
const LOAD: usize = 0x000;
const CONTROL: usize = 0x008;
const INTCLR: usize = 0x00C;
const LOCK: usize = 0xC00;
/// The key that unlocks the registers (any other value written to LOCK locks them).
const UNLOCK: u32 = 0x1ACC_E551;
/// CONTROL: INTEN (the counter runs, the interrupt is raised at zero) and RESEN (a second
/// time-out resets).
const INTEN_RESEN: u32 = 0b11;
/// The watchdog's clock (Hz): the machine's system clock.
const CLOCK_HZ: u32 = 25_000_000;

/// Half the time from the last feed to the reset (ms of the machine's clock): the first
/// time-out (the NMI) comes after it, the reset after twice it. Far above the longest turn of
/// the node's loop (a learning step, well under a millisecond of QEMU's clock here) and the
/// longest stretch without a frame the simulator drives.
pub const HALF_PERIOD_MS: u32 = 100;

fn write(offset: usize, value: u32) {
    // SAFETY: a register of the machine's watchdog, a device nothing else in the firmware
    // touches; single-threaded firmware
    unsafe { core::ptr::write_volatile((BASE + offset) as *mut u32, value) }
}

/// Starts the watchdog: reset after 2 x [`HALF_PERIOD_MS`] without a [`feed`].
pub fn start() {
    write(LOCK, UNLOCK);
    write(LOAD, CLOCK_HZ / 1000 * HALF_PERIOD_MS);
    write(CONTROL, INTEN_RESEN);
    write(LOCK, 0);
}

/// Feeds the watchdog: the counter starts again from its load value.
pub fn feed() {
    write(LOCK, UNLOCK);
    write(INTCLR, 1);
    write(LOCK, 0);
}

/// The record the NMI leaves for the next boot.
#[link_section = ".uninit.trn_reset"]
static mut RECORD: MaybeUninit<Record> = MaybeUninit::uninit();

fn write_record(r: Record) {
    // SAFETY: the record's own words, written volatile by the NMI (the machine resets next)
    // or by the boot before anything else runs; nothing else refers to them
    unsafe {
        let p = core::ptr::addr_of_mut!(RECORD).cast::<u32>();
        for (i, w) in r.iter().enumerate() {
            core::ptr::write_volatile(p.add(i), *w);
        }
    }
}

/// The watchdog's first time-out: the cause recorded; the interrupt is left raised, so the
/// second time-out resets the machine.
#[exception]
unsafe fn NonMaskableInt() {
    write_record(record(ResetCause::Watchdog, 0));
}

/// The cause of the last reset and its detail: the watchdog's record, else a power-on (QEMU
/// zeroes RAM when it starts, so there is no record then); the record is cleared.
pub fn take_cause() -> (ResetCause, u32) {
    let mut r: Record = [0; 4];
    // SAFETY: the record's words, written at the previous boot or by the NMI since (QEMU's
    // RAM starts zeroed, so they are never uninitialised memory here)
    unsafe {
        let p = core::ptr::addr_of!(RECORD).cast::<u32>();
        for (i, w) in r.iter_mut().enumerate() {
            *w = core::ptr::read_volatile(p.add(i));
        }
    }
    write_record([0; 4]);
    recorded(&r).unwrap_or((ResetCause::PowerOn, 0))
}
