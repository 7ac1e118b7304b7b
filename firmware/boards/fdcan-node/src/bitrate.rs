//! The CAN bit rates of a board image, a build-time setting, and their FDCAN bit timings.
//!
//! `TRN_CAN_BITRATE` (bit/s, default 500,000: the rate `trn` opens a serial adapter at) sets
//! the nominal (arbitration) rate; `TRN_CAN_DATA_BITRATE` (bit/s, default 2,000,000) the
//! data phase of CAN FD frames (bit-rate switching). Both are read when the image is built:
//!
//! ```sh
//! TRN_CAN_BITRATE=250000 TRN_CAN_DATA_BITRATE=1000000 cargo build --release
//! ```
//!
//! [`timings`] turns them into the FDCAN's bit timings for the board's kernel clock at
//! compile time: a rate the clock cannot make exactly (an integer number of time quanta per
//! bit, 8 at least), a malformed value or one out of range stops the build with the reason.
//! Sample points: 87.5 % nominal (CiA 601-3's recommendation up to 500 kbit/s), 75 % in the
//! data phase; resynchronisation jump width = phase segment 2; the same prescaler in both
//! phases where the clock allows (CiA 601-3). The data phase is limited to 2 Mbit/s: no
//! transceiver delay compensation is configured, which faster data phases need.

use core::num::{NonZeroU16, NonZeroU8};

use embassy_stm32::can::config::{DataBitTiming, NominalBitTiming};

/// Nominal bit rate (bit/s): `TRN_CAN_BITRATE` when the image was built, else 500,000.
pub const NOMINAL: u32 = parse(option_env!("TRN_CAN_BITRATE"), 500_000, 10_000, 1_000_000);

/// CAN FD data-phase bit rate (bit/s): `TRN_CAN_DATA_BITRATE` when the image was built, else
/// 2,000,000; at least the nominal rate.
pub const DATA: u32 = parse(
    option_env!("TRN_CAN_DATA_BITRATE"),
    2_000_000,
    NOMINAL,
    2_000_000,
);

/// The bit timings of both phases for one FDCAN kernel clock.
#[derive(Clone, Copy)]
pub struct Timings {
    /// Arbitration phase (and classical frames).
    pub nominal: NominalBitTiming,
    /// Data phase of CAN FD frames with bit-rate switching.
    pub data: DataBitTiming,
}

/// The timings of [`NOMINAL`] and [`DATA`] for an FDCAN kernel clock of `clock_hz`; fails
/// the build (in a `const`) when the clock cannot make either rate exactly.
pub const fn timings(clock_hz: u32) -> Timings {
    let n = nominal_segments(clock_hz, NOMINAL);
    let d = data_segments(clock_hz, DATA);
    Timings {
        nominal: NominalBitTiming {
            prescaler: nonzero16(n.prescaler),
            seg1: nonzero8(n.seg1),
            seg2: nonzero8(n.seg2),
            sync_jump_width: nonzero8(n.seg2),
        },
        data: DataBitTiming {
            transceiver_delay_compensation: false,
            prescaler: nonzero16(d.prescaler),
            seg1: nonzero8(d.seg1),
            seg2: nonzero8(d.seg2),
            sync_jump_width: nonzero8(d.seg2),
        },
    }
}

/// The nominal phase: at most 80 quanta, sample point 87.5 %; NBRP 1..=511, NTSEG1 1..=255,
/// NTSEG2 1..=127 (what embassy's register fields hold).
const fn nominal_segments(clock_hz: u32, bitrate: u32) -> Segments {
    segments(clock_hz, bitrate, 80, 511, 875, 255, 127)
}

/// The data phase: at most 25 quanta, sample point 75 %; DBRP 1..=31, DTSEG1 1..=31,
/// DTSEG2 1..=15.
const fn data_segments(clock_hz: u32, bitrate: u32) -> Segments {
    segments(clock_hz, bitrate, 25, 31, 750, 31, 15)
}

/// One phase's bit: `prescaler` kernel clocks per time quantum, the sync segment (1 quantum),
/// `seg1` quanta to the sample point, `seg2` after it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Segments {
    prescaler: u32,
    seg1: u32,
    seg2: u32,
}

/// The most time quanta per bit (at most `max_quanta`, at least 8) that divide the clock
/// into `bitrate` exactly with a prescaler of at most `max_prescaler`, split at
/// `sample_permille`.
const fn segments(
    clock_hz: u32,
    bitrate: u32,
    max_quanta: u32,
    max_prescaler: u32,
    sample_permille: u32,
    max_seg1: u32,
    max_seg2: u32,
) -> Segments {
    if !clock_hz.is_multiple_of(bitrate) {
        panic!("the FDCAN kernel clock is not a multiple of the CAN bit rate");
    }
    let clocks_per_bit = clock_hz / bitrate;
    let mut quanta = if clocks_per_bit < max_quanta {
        clocks_per_bit
    } else {
        max_quanta
    };
    while quanta >= 8 {
        if clocks_per_bit.is_multiple_of(quanta) && clocks_per_bit / quanta <= max_prescaler {
            break;
        }
        quanta -= 1;
    }
    if quanta < 8 {
        panic!("no bit timing of 8 or more time quanta gives this CAN bit rate from the FDCAN kernel clock");
    }
    let seg1 = (quanta * sample_permille + 500) / 1000 - 1;
    let seg2 = quanta - 1 - seg1;
    if seg1 > max_seg1 || seg2 > max_seg2 || seg2 == 0 {
        panic!("the bit timing's segments are out of the FDCAN's range");
    }
    Segments {
        prescaler: clocks_per_bit / quanta,
        seg1,
        seg2,
    }
}

const fn nonzero8(x: u32) -> NonZeroU8 {
    if x > u8::MAX as u32 {
        panic!("a bit timing segment above 255");
    }
    match NonZeroU8::new(x as u8) {
        Some(v) => v,
        None => panic!("a bit timing segment of 0"),
    }
}

const fn nonzero16(x: u32) -> NonZeroU16 {
    if x > u16::MAX as u32 {
        panic!("a prescaler above 65535");
    }
    match NonZeroU16::new(x as u16) {
        Some(v) => v,
        None => panic!("a prescaler of 0"),
    }
}

/// A decimal bit rate from the build's environment, `default` when unset; the build fails on
/// anything else than digits or a value outside `min..=max`.
const fn parse(value: Option<&str>, default: u32, min: u32, max: u32) -> u32 {
    let Some(text) = value else {
        return default;
    };
    let digits = text.as_bytes();
    if digits.is_empty() {
        panic!("TRN_CAN_BITRATE / TRN_CAN_DATA_BITRATE: empty (bit/s, e.g. 500000)");
    }
    let mut n: u64 = 0;
    let mut i = 0;
    while i < digits.len() {
        let d = digits[i];
        if !d.is_ascii_digit() {
            panic!("TRN_CAN_BITRATE / TRN_CAN_DATA_BITRATE: digits only (bit/s, e.g. 500000)");
        }
        n = n * 10 + (d - b'0') as u64;
        if n > u32::MAX as u64 {
            panic!("TRN_CAN_BITRATE / TRN_CAN_DATA_BITRATE: too large");
        }
        i += 1;
    }
    let n = n as u32;
    if n < min || n > max {
        panic!("TRN_CAN_BITRATE must be 10000..=1000000 and TRN_CAN_DATA_BITRATE from it to 2000000 (bit/s)");
    }
    n
}

/// Checked when this crate is built: the timings of the boards' kernel clocks at the
/// defaults and two other rates, each bit exactly `clock / bitrate` kernel clocks long.
const _: () = {
    // (clock, bitrate, data phase?, prescaler, seg1, seg2)
    const CASES: [(u32, u32, bool, u32, u32, u32); 6] = [
        // STM32H743 board, 80 MHz: 500 kbit/s (87.5 %), 2 Mbit/s data (75 %), prescaler 2
        (80_000_000, 500_000, false, 2, 69, 10),
        (80_000_000, 2_000_000, true, 2, 14, 5),
        // STM32G474 board, 24 MHz (HSE): prescaler 1 in both phases
        (24_000_000, 500_000, false, 1, 41, 6),
        (24_000_000, 2_000_000, true, 1, 8, 3),
        // 1 Mbit/s from 80 MHz: 80 quanta; 125 kbit/s: prescaler 8
        (80_000_000, 1_000_000, false, 1, 69, 10),
        (80_000_000, 125_000, false, 8, 69, 10),
    ];
    let mut i = 0;
    while i < CASES.len() {
        let (clock, bitrate, data, prescaler, seg1, seg2) = CASES[i];
        let s = if data {
            data_segments(clock, bitrate)
        } else {
            nominal_segments(clock, bitrate)
        };
        assert!(s.prescaler == prescaler && s.seg1 == seg1 && s.seg2 == seg2);
        assert!(s.prescaler * (1 + s.seg1 + s.seg2) == clock / bitrate);
        i += 1;
    }
};
