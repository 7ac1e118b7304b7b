//! The TRN controller on a Cortex-M4F (QEMU `mps2-an386`): both networks in static RAM, the
//! same `trn-controller` state machine as the host, and its costs measured.
//!
//! `bench` (the default): stage-1 control steps (rank + coarse output) and learning steps
//! (coarse + two fine moves with all updates) against a small synthetic plant; executed
//! instructions per step from SysTick under `-icount shift=0` (QEMU models no pipeline:
//! instructions are a proxy for cycles), and the stack high-water mark from cortex-m-rt's
//! painted stack. Results go out over semihosting; the exit code says pass or fail.
#![no_std]
#![no_main]

mod count;
#[cfg(feature = "pil")]
mod pil;
#[cfg(feature = "pil")]
mod uart;

use core::panic::PanicInfo;
use cortex_m_rt::entry;
use cortex_m_semihosting::{debug, hprintln};
use trn_controller::presets::{self, Ablation, ImageSize, Preset};
use trn_controller::{Command, Config, Controller, Observation, Task};

/// Both networks and the controller state, all zero bytes at reset: the linker puts it in
/// `.bss` (no flash image). Set up by `main` before use.
static mut CONTROLLER: Controller = Controller::new_zeroed();

const STEPS: u32 = 20;

/// A smooth synthetic plant: 5 pressures to 8 pixel coordinates.
fn plant(p: &[f32; 5]) -> [f32; 8] {
    let mut v = [0.0; 8];
    for (i, x) in v.iter_mut().enumerate() {
        let mut s = 0.0;
        for (j, pj) in p.iter().enumerate() {
            let w = if (i + j) % 3 == 0 { 0.9 } else { 0.25 };
            s += w * libm::tanhf(0.9 * pj);
        }
        *x = if i % 2 == 0 { 512.0 } else { 384.0 } + 150.0 * s;
    }
    v
}

fn pseudo_random(state: &mut u32) -> f32 {
    *state ^= *state << 13;
    *state ^= *state >> 17;
    *state ^= *state << 5;
    (*state >> 8) as f32 / 16_777_216.0 * 1.6 - 0.8
}

#[entry]
fn main() -> ! {
    // SAFETY: the only access to CONTROLLER: single-threaded firmware, no interrupts touch it,
    // and this reference is taken once.
    #[allow(unsafe_code)]
    let ctrl: &'static mut Controller = unsafe { &mut *core::ptr::addr_of_mut!(CONTROLLER) };
    setup(ctrl);
    #[cfg(feature = "pil")]
    pil::run(ctrl, count::Clock::new());
    #[cfg(not(feature = "pil"))]
    bench(ctrl)
}

/// Configures and seeds the controller. Not inlined: the `Config` and the seeding's
/// temporaries live in this frame only, not in `main`'s frame under the whole run (about
/// 1 KiB of stack).
#[inline(never)]
fn setup(ctrl: &mut Controller) {
    if ctrl.set_config(host_config()).is_err() {
        fail("set_config");
    }
    ctrl.init_random(SEED);
}

/// The seed of the initial tables: `trn train --bus slcan:qemu` must use the same `--seed`.
const SEED: u64 = 1;

/// The configuration `trn` gives the host controller for the default simulator
/// (`trn_controller::presets::configure`, the one source both builds use).
fn host_config() -> Config {
    presets::configure(Preset::Project, Ablation::None, ImageSize::DEFAULT)
}

#[cfg_attr(feature = "pil", allow(dead_code))]
fn bench(ctrl: &mut Controller) -> ! {
    let mut counter = count::Counter::new();
    let per_tick = counter.calibrate();

    // stage-1 control steps: rank + coarse output, no learning
    let mut rng = 0x1234_5678u32;
    let (mut ctl_sum, mut ctl_max) = (0u64, 0u64);
    for _ in 0..STEPS {
        let p: [f32; 5] = core::array::from_fn(|_| pseudo_random(&mut rng));
        let v = plant(&p);
        let n = counter.measure(|| {
            let _ = ctrl.stage1_mut().begin(&v, None, false);
            ctrl.stage1_mut().abort();
        });
        ctl_sum += n;
        ctl_max = ctl_max.max(n);
    }

    // stage-1 learning steps: coarse move and two fine moves, with every update
    let (mut learn_sum, mut learn_max) = (0u64, 0u64);
    for step in 0..STEPS {
        let p: [f32; 5] = core::array::from_fn(|_| pseudo_random(&mut rng));
        let v = plant(&p);
        let supervised = if step < 5 { Some(p) } else { None };
        let n = counter.measure(|| {
            let mut cmd = ctrl.begin(Task::Stage1 {
                v,
                supervised,
                learn: true,
            });
            for _ in 0..3 {
                match cmd {
                    Ok(Command::Move { pressures, .. }) => {
                        let mut q = [0.0; 5];
                        q.copy_from_slice(&pressures);
                        cmd = ctrl.observe(Observation::Lights(plant(&q)));
                    }
                    _ => break,
                }
            }
            ctrl.abort();
        });
        learn_sum += n;
        learn_max = learn_max.max(n);
    }
    let finite = ctrl.stage1().net().is_finite();
    let stack = count::stack_high_water_mark();
    hprintln!("trn-firmware bench (QEMU mps2-an386, Cortex-M4F, -icount shift=0)");
    hprintln!(
        "calibration: {} instructions per SysTick tick (x1000)",
        (per_tick * 1000.0) as u32
    );
    hprintln!(
        "stage1 control step (rank + coarse): mean {} max {} instructions",
        ctl_sum / STEPS as u64,
        ctl_max
    );
    hprintln!(
        "stage1 learning step (coarse + 2 fine, all updates): mean {} max {} instructions",
        learn_sum / STEPS as u64,
        learn_max
    );
    hprintln!("stack high-water mark: {} bytes", stack);
    hprintln!("tables finite after learning: {}", finite);
    if !finite {
        fail("non-finite tables");
    }
    debug::exit(debug::EXIT_SUCCESS);
    loop {}
}

fn fail(what: &str) -> ! {
    hprintln!("FAIL: {}", what);
    debug::exit(debug::EXIT_FAILURE);
    loop {}
}

#[panic_handler]
fn panic(info: &PanicInfo) -> ! {
    hprintln!("PANIC: {}", info);
    debug::exit(debug::EXIT_FAILURE);
    loop {}
}
