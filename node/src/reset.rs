//! Why the part last reset, without I/O: the reset flags a board reads from its clock
//! controller and the record its panic or hard-fault handler left in RAM that no reset
//! clears ([`record`], [`recorded`]) make one [`ResetCause`], which the board announces on
//! the bus at boot with `ErrorReport{RESET_CAUSE}` ([`reset_report`]; protocol/SPEC.md
//! section 7).

use trn_protocol::ErrorReport;

use crate::codes;

/// Why the part last reset (the high byte of `RESET_CAUSE`'s detail).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub enum ResetCause {
    /// No flag the board knows (or none read).
    Unknown = 0,
    /// Power-on or brown-out.
    PowerOn = 1,
    /// The reset pin (a button, a debug probe).
    Pin = 2,
    /// The independent watchdog: the node's loop stopped turning.
    Watchdog = 3,
    /// A panic (detail: the panic's source line).
    Panic = 4,
    /// A hard fault (detail: the low 24 bits of the faulting instruction's address).
    HardFault = 5,
    /// A software reset the handlers did not record (a debugger's, a reset over the probe).
    Software = 6,
}

/// The reset flags a board reads from its clock controller (STM32: RCC RSR or CSR),
/// before clearing them.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct ResetFlags {
    /// Power-on or brown-out reset.
    pub power_on: bool,
    /// The reset pin.
    pub pin: bool,
    /// The independent (or window) watchdog.
    pub watchdog: bool,
    /// A software reset (SCB AIRCR SYSRESETREQ: the panic and fault handlers', a debugger's).
    pub software: bool,
}

/// The words of a record in RAM that survives a reset: a marker, the cause, its detail and
/// a check word, so that RAM that merely holds old or random values is not taken for one.
pub type Record = [u32; 4];

const MARKER: u32 = 0x5452_4E52;

/// The record a panic (`detail`: its source line) or a hard fault (`detail`: the faulting
/// instruction's address) leaves before resetting the part, or a watchdog's early warning on
/// a part that keeps no reset flags of its own (the QEMU machine's CMSDK watchdog). Any other
/// cause records nothing: the reset flags tell it.
pub fn record(cause: ResetCause, detail: u32) -> Record {
    let cause = cause as u32;
    [
        MARKER,
        cause,
        detail,
        MARKER ^ cause.rotate_left(8) ^ detail.rotate_left(16),
    ]
}

/// The cause and detail of a record, if it is one a handler left (marker and check word
/// right, a panic, a hard fault or a watchdog's warning); `None` for anything else.
pub fn recorded(r: &Record) -> Option<(ResetCause, u32)> {
    if r[0] != MARKER || r[3] != MARKER ^ r[1].rotate_left(8) ^ r[2].rotate_left(16) {
        return None;
    }
    match r[1] {
        c if c == ResetCause::Panic as u32 => Some((ResetCause::Panic, r[2])),
        c if c == ResetCause::HardFault as u32 => Some((ResetCause::HardFault, r[2])),
        c if c == ResetCause::Watchdog as u32 => Some((ResetCause::Watchdog, r[2])),
        _ => None,
    }
}

/// The cause of the last reset, and its detail: a handler's record when the flags say a
/// software reset followed it (its own reset), else the flags, most telling first
/// (a power-on also sets the pin flag, a watchdog reset pulls the pin on some parts).
pub fn reset_cause(flags: ResetFlags, record: Option<(ResetCause, u32)>) -> (ResetCause, u32) {
    match record {
        Some(r) if flags.software && !flags.power_on => r,
        _ if flags.power_on => (ResetCause::PowerOn, 0),
        _ if flags.watchdog => (ResetCause::Watchdog, 0),
        _ if flags.software => (ResetCause::Software, 0),
        _ if flags.pin => (ResetCause::Pin, 0),
        _ => (ResetCause::Unknown, 0),
    }
}

/// `ErrorReport{RESET_CAUSE}`: detail `cause << 24 | detail` (the detail's low 24 bits).
pub fn reset_report(cause: ResetCause, detail: u32) -> ErrorReport {
    ErrorReport {
        code: codes::RESET_CAUSE,
        detail: (cause as u32) << 24 | (detail & 0x00FF_FFFF),
    }
}
