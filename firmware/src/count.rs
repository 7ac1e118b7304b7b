//! Executed-instruction counts from SysTick under QEMU's `-icount shift=0`, and the stack
//! high-water mark from cortex-m-rt's painted stack.

// The bench build uses `Counter`, the PIL build `Clock`.
#![allow(dead_code)]

use cortex_m::peripheral::syst::SystClkSource;
use cortex_m::peripheral::SYST;

const RELOAD: u32 = 0x00FF_FFFF;

/// Takes SysTick (once) and starts it as a free-running 24-bit down-counter of core clocks.
fn free_running_systick() -> SYST {
    let Some(p) = cortex_m::Peripherals::take() else {
        crate::fail("peripherals taken twice")
    };
    let mut syst = p.SYST;
    syst.set_clock_source(SystClkSource::Core);
    syst.set_reload(RELOAD);
    syst.clear_current();
    syst.enable_counter();
    syst
}

/// SysTick as a free-running counter; calibrated against a loop of known length.
pub struct Counter {
    syst: SYST,
    per_tick: f32,
}

impl Counter {
    /// Takes SysTick (once).
    pub fn new() -> Counter {
        Counter {
            syst: free_running_systick(),
            per_tick: 1.0,
        }
    }

    fn now(&self) -> u32 {
        let _ = &self.syst;
        SYST::get_current()
    }

    fn ticks<F: FnOnce()>(&mut self, f: F) -> u32 {
        // every measured region is far below 2^24 ticks (checked by the caller's figures)
        let a = self.now();
        f();
        let b = self.now();
        a.wrapping_sub(b) & RELOAD
    }

    /// Measures a loop of 2 x 400,000 instructions; returns instructions per tick.
    pub fn calibrate(&mut self) -> f32 {
        let n = self.ticks(|| calibration_loop(400_000));
        self.per_tick = 800_000.0 / n.max(1) as f32;
        self.per_tick
    }

    /// Executed instructions of `f` (tick count x calibration).
    pub fn measure<F: FnOnce()>(&mut self, f: F) -> u64 {
        let t = self.ticks(f);
        (t as f32 * self.per_tick) as u64
    }
}

/// Milliseconds from SysTick (25 MHz on the MPS2 boards); read often enough that the 24-bit
/// counter never wraps twice between reads.
pub struct Clock {
    syst: SYST,
    last: u32,
    ticks: u64,
}

/// SysTick ticks per millisecond (the MPS2 system clock, 25 MHz).
const TICKS_PER_MS: u64 = 25_000;

impl Clock {
    /// Takes SysTick (once).
    pub fn new() -> Clock {
        let syst = free_running_systick();
        Clock {
            syst,
            last: SYST::get_current(),
            ticks: 0,
        }
    }

    /// Milliseconds since start (wrapping `u32`, as the node expects).
    pub fn now_ms(&mut self) -> u32 {
        let _ = &self.syst;
        let cur = SYST::get_current();
        self.ticks += (self.last.wrapping_sub(cur) & RELOAD) as u64;
        self.last = cur;
        (self.ticks / TICKS_PER_MS) as u32
    }
}

/// Exactly two instructions per iteration (`subs`, `bne`).
#[inline(never)]
fn calibration_loop(n: u32) {
    // SAFETY: a register-only loop with no memory access.
    #[allow(unsafe_code)]
    unsafe {
        core::arch::asm!(
            "1:",
            "subs {0}, {0}, #1",
            "bne 1b",
            inout(reg) n => _,
            options(nomem, nostack),
        );
    }
}

extern "C" {
    static _stack_start: u32;
    static _stack_end: u32;
}

/// Bytes of stack ever used: cortex-m-rt's `paint-stack` fills the stack with a pattern at
/// reset; the lowest overwritten word marks the high-water mark.
pub fn stack_high_water_mark() -> u32 {
    const PAINT: u32 = 0xCCCC_CCCC;
    // SAFETY: reads words between the end of the static data and the top of the stack,
    // all inside RAM; volatile so the scan is not optimised away.
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
