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
mod store;
#[cfg(feature = "pil")]
mod uart;
#[cfg(feature = "pil")]
mod watchdog;

use core::panic::PanicInfo;
use cortex_m_rt::entry;
use cortex_m_semihosting::{debug, hprintln};
use trn_controller::entry::{Entry, Table, TABLE_SCALES};
use trn_controller::presets::{self, Ablation, ImageSize, Preset};
use trn_controller::rank::{RankMode, RankScratch, Ranking};
use trn_controller::rules::{self, Falloff};
use trn_controller::{Command, Config, Controller, Observation, Task, RANKS};

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

/// The seed of the tables at reset. In a session over the bus (`pil`) the runner's
/// `SessionConfig` sets the configuration and re-seeds the tables with its own seed.
const SEED: u64 = 1;

/// The configuration at reset: the one `trn` gives the host controller for the default
/// simulator (`trn_controller::presets::configure`, the one source both builds use).
fn host_config() -> Config {
    presets::configure(Preset::Project, Ablation::None, ImageSize::DEFAULT)
}

/// Mean and max of a series of instruction counts.
#[cfg_attr(feature = "pil", allow(dead_code))]
#[derive(Clone, Copy)]
struct Stat {
    sum: u64,
    max: u64,
    n: u64,
}

#[cfg_attr(feature = "pil", allow(dead_code))]
impl Stat {
    const fn new() -> Stat {
        Stat {
            sum: 0,
            max: 0,
            n: 0,
        }
    }

    fn add(&mut self, x: u64) {
        self.sum += x;
        self.max = self.max.max(x);
        self.n += 1;
    }

    fn mean(&self) -> u64 {
        self.sum / self.n.max(1)
    }

    fn print(&self, what: &str) {
        hprintln!(
            "phase {}: mean {} max {} instructions",
            what,
            self.mean(),
            self.max
        );
    }
}

/// All `N` squared distances to `u`, the plain loop (no selection, no early exit), folded
/// into one value so that nothing is optimised away: the cost of the distances alone.
#[cfg_attr(feature = "pil", allow(dead_code))]
#[inline(never)]
fn all_distances(w: &[[Table; 8]; 1000], u: &[f32; 8]) -> f32 {
    let mut least = f32::INFINITY;
    for wk in w.iter() {
        let mut s = 0.0;
        for d in 0..8 {
            let diff = u[d] - wk[d].get(TABLE_SCALES.w);
            s += diff * diff;
        }
        least = least.min(s);
    }
    least
}

/// Per-phase costs, measured by calling the pure functions on the controller's tables
/// (`rank`, `rules`), before the stateful step that does the same work.
#[cfg_attr(feature = "pil", allow(dead_code))]
struct Phases {
    distances: Stat,
    rank: Stat,
    selection: Stat,
    coarse: Stat,
    mean_jacobian_fine: Stat,
    secant_fine: Stat,
    falloff: Stat,
}

#[cfg_attr(feature = "pil", allow(dead_code))]
impl Phases {
    const fn new() -> Phases {
        Phases {
            distances: Stat::new(),
            rank: Stat::new(),
            selection: Stat::new(),
            coarse: Stat::new(),
            mean_jacobian_fine: Stat::new(),
            secant_fine: Stat::new(),
            falloff: Stat::new(),
        }
    }

    /// Measures the pure phases at target `v`; returns (rank + coarse, mean Jacobian + fine).
    fn measure(
        &mut self,
        counter: &mut count::Counter,
        ctrl: &Controller,
        ranking: &mut Ranking<RANKS>,
        v: &[f32; 8],
    ) -> (u64, u64) {
        let stage = ctrl.stage1();
        let net = stage.net();
        let cfg = stage.config();
        let alpha = Falloff::<RANKS>::compute(cfg.alpha_range);
        let n_dist = counter.measure(|| {
            core::hint::black_box(all_distances(
                core::hint::black_box(net.weights()),
                core::hint::black_box(v),
            ));
        });
        // SAFETY: the bench is single-threaded; RANK_SCRATCH is only used here.
        #[allow(unsafe_code)]
        let scratch = unsafe { &mut *core::ptr::addr_of_mut!(RANK_SCRATCH) };
        let n_rank = counter.measure(|| {
            ranking.compute(
                net.weights(),
                core::hint::black_box(v),
                scratch,
                RankMode::PartialSelect,
            );
        });
        let n_coarse = counter.measure(|| {
            core::hint::black_box(rules::coarse_output(
                net,
                ranking,
                &alpha,
                core::hint::black_box(v),
                cfg.coarse_ranks as usize,
            ));
        });
        let mut seen = *v;
        seen[0] += 20.0;
        let n_mj = counter.measure(|| {
            let a_bar = rules::mean_jacobian(net, ranking, &alpha, cfg.fine_ranks as usize);
            core::hint::black_box(rules::fine_output(
                &[0.1; 5],
                &a_bar,
                v,
                core::hint::black_box(&seen),
                cfg.pressure_limit,
            ));
        });
        // a mature fine move after the first: the trial's average corrected by the last
        // move's secant (StageConfig::trial_secant), then the fine output
        let mut a_bar = rules::mean_jacobian(net, ranking, &alpha, cfg.fine_ranks as usize);
        let dp = [0.02, -0.01, 0.015, 0.0, -0.02];
        let n_secant = counter.measure(|| {
            let _ = rules::secant_update(
                &mut a_bar,
                cfg.trial_secant,
                core::hint::black_box(&dp),
                core::hint::black_box(&seen),
                cfg.dv_rule(),
            );
            core::hint::black_box(rules::fine_output(
                &[0.1; 5],
                &a_bar,
                v,
                core::hint::black_box(&seen),
                cfg.pressure_limit,
            ));
        });
        self.secant_fine.add(n_secant);
        let t = stage.learning_step() + 1;
        let n_falloff = counter.measure(|| {
            core::hint::black_box(Falloff::<RANKS>::compute_by_blocks(core::hint::black_box(
                cfg.sigma_at(t),
            )));
        });
        self.falloff.add(n_falloff);
        self.distances.add(n_dist);
        self.rank.add(n_rank);
        self.selection.add(n_rank.saturating_sub(n_dist));
        self.coarse.add(n_coarse);
        self.mean_jacobian_fine.add(n_mj);
        (n_rank + n_coarse, n_mj)
    }

    fn print(&self) {
        self.distances
            .print("rank: distances, all N (plain loop, reference)");
        self.rank
            .print("rank: Ranking::compute (distances + selection + sort of K)");
        self.selection
            .print("rank: selection + sort of K (compute - plain distances)");
        self.coarse.print("coarse output (rules::coarse_output)");
        self.mean_jacobian_fine
            .print("mean Jacobian + fine output (rules::mean_jacobian + fine_output)");
        self.secant_fine.print(
            "secant correction + fine output (mature fine moves after the first: rules::secant_update + fine_output)",
        );
        self.falloff.print(
            "neighbourhood falloff (rules::Falloff::compute_by_blocks, each learning begin: sigma varies)",
        );
    }
}

/// Scratch for the bench's own ranking and its direct calls of the stage (the controller's
/// is private to it).
#[cfg_attr(feature = "pil", allow(dead_code))]
static mut RANK_SCRATCH: RankScratch = RankScratch::new();

#[cfg_attr(feature = "pil", allow(dead_code))]
fn bench(ctrl: &mut Controller) -> ! {
    let mut counter = count::Counter::new();
    let per_tick = counter.calibrate();
    let mut phases = Phases::new();
    let mut ranking = Ranking::<RANKS>::new();

    // stage-1 control steps: rank + coarse output, no learning
    let mut rng = 0x1234_5678u32;
    let (mut ctl_sum, mut ctl_max) = (0u64, 0u64);
    for _ in 0..STEPS {
        let p: [f32; 5] = core::array::from_fn(|_| pseudo_random(&mut rng));
        let v = plant(&p);
        phases.measure(&mut counter, ctrl, &mut ranking, &v);
        // SAFETY: the bench is single-threaded; RANK_SCRATCH is used by one call at a time.
        #[allow(unsafe_code)]
        let scratch = unsafe { &mut *core::ptr::addr_of_mut!(RANK_SCRATCH) };
        let n = counter.measure(|| {
            let _ = ctrl.stage1_mut().begin(&v, None, false, scratch);
            ctrl.stage1_mut().abort();
        });
        ctl_sum += n;
        ctl_max = ctl_max.max(n);
    }

    // stage-1 learning steps: coarse move and two fine moves, with every update. Each call
    // of the state machine is timed; the updates' costs are derived from those by
    // subtracting the pure phases measured just before on the same tables.
    let (mut learn_sum, mut learn_max) = (0u64, 0u64);
    let mut weights = Stat::new(); // begin - (rank + coarse), unsupervised steps
    let mut weights_sup = Stat::new(); // the same, supervised: + pressures (8.18)
    let mut pressures = Stat::new(); // first observe - (mean Jacobian + fine), unsupervised
    let mut jacobians = Stat::new(); // later observes that moved - (mean Jacobian + fine)
    let mut plant_cost = Stat::new();
    for step in 0..STEPS {
        let p: [f32; 5] = core::array::from_fn(|_| pseudo_random(&mut rng));
        let v = plant(&p);
        let supervised = if step < 5 { Some(p) } else { None };
        let (rank_coarse, mj_fine) = phases.measure(&mut counter, ctrl, &mut ranking, &v);
        // each call of the state machine timed on its own; the step is their sum (the
        // synthetic plant between the calls is not part of it: timed apart)
        let mut calls = [0u64; 4];
        let mut moved = [false; 4]; // the call answered with a move (a fine move was computed)
        let mut ncalls = 1;
        let mut cmd = None;
        calls[0] = counter.measure(|| {
            cmd = Some(ctrl.begin(Task::Stage1 {
                v,
                supervised,
                learn: true,
            }));
        });
        for i in 1..calls.len() {
            let c = &mut calls[i];
            let Some(Ok(Command::Move { pressures, .. })) = cmd else {
                break;
            };
            let mut q = [0.0; 5];
            q.copy_from_slice(&pressures);
            let mut seen = [0.0; 8];
            plant_cost.add(counter.measure(|| seen = plant(&q)));
            *c = counter.measure(|| {
                cmd = Some(ctrl.observe(Observation::Lights(seen)));
            });
            moved[ncalls] = matches!(cmd, Some(Ok(Command::Move { .. })));
            ncalls += 1;
        }
        let n = calls.iter().sum::<u64>() + counter.measure(|| ctrl.abort());
        learn_sum += n;
        learn_max = learn_max.max(n);
        let derived = |x: u64, y: u64| x.saturating_sub(y);
        if supervised.is_some() {
            weights_sup.add(derived(calls[0], rank_coarse));
        } else {
            weights.add(derived(calls[0], rank_coarse));
            if ncalls > 1 && moved[1] {
                pressures.add(derived(calls[1], mj_fine));
            }
        }
        for i in 2..ncalls {
            if moved[i] {
                jacobians.add(derived(calls[i], mj_fine));
            }
        }
    }
    let finite = ctrl.stage1().net().is_finite();
    #[cfg(feature = "broyden")]
    let broyden = bench_broyden(ctrl, &mut counter, &mut rng);
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
    phases.print();
    weights.print("update weights (derived: learning begin - rank - coarse, unsupervised)");
    weights_sup
        .print("update weights + pressures (derived: learning begin - rank - coarse, supervised)");
    pressures.print("update pressures (derived: 1st observe - mean Jacobian - fine)");
    jacobians.print("update Jacobians (derived: later observes that move - mean Jacobian - fine)");
    plant_cost.print("synthetic plant, per call (between the calls, not in the step)");
    #[cfg(feature = "broyden")]
    broyden.print("broyden servo step (Broyden update + damped least squares, stage 1)");
    hprintln!("stack high-water mark: {} bytes", stack);
    hprintln!("tables finite after learning: {}", finite);
    if !finite {
        fail("non-finite tables");
    }
    debug::exit(debug::EXIT_SUCCESS);
    loop {}
}

/// The Broyden servo baseline's stage-1 servo steps (`Law::Broyden`: one Broyden update and
/// one damped-least-squares solve per observation), on the synthetic plant; the first trial
/// measures its Jacobian (exploration, not counted). Restores the TRN configuration.
#[cfg(feature = "broyden")]
#[cfg_attr(feature = "pil", allow(dead_code))]
#[inline(never)]
fn bench_broyden(ctrl: &mut Controller, counter: &mut count::Counter, rng: &mut u32) -> Stat {
    let trn = *ctrl.config();
    let cfg = Config {
        law: trn_controller::Law::Broyden,
        ..trn
    };
    if ctrl.set_config(cfg).is_err() {
        fail("set_config broyden");
    }
    let mut steps = Stat::new();
    for trial in 0..STEPS {
        let p: [f32; 5] = core::array::from_fn(|_| pseudo_random(rng));
        let target = plant(&p);
        let task = Task::Stage1 {
            v: target,
            supervised: None,
            learn: false,
        };
        let mut cmd = ctrl.begin_with(task, trn_controller::FineMoves::Exactly(8));
        let mut calls = 0;
        while let Ok(Command::Move { pressures, .. }) = cmd {
            let seen = plant(&pressures);
            let n = counter.measure(|| cmd = ctrl.observe(Observation::Lights(seen)));
            calls += 1;
            // the home move's observation and the exploration are not servo steps
            if trial > 0 && calls > 1 {
                steps.add(n);
            }
        }
    }
    if ctrl.set_config(trn).is_err() {
        fail("set_config trn");
    }
    steps
}

fn fail(what: &str) -> ! {
    hprintln!("FAIL: {}", what);
    debug::exit(debug::EXIT_FAILURE);
    loop {}
}

/// Prints where the panic happened, not its message: formatting the message would keep
/// `core::fmt`'s float formatting in flash (23,860 B in the benchmark image, for messages of
/// checks that cannot fail in this image); the location finds the check.
#[panic_handler]
fn panic(info: &PanicInfo) -> ! {
    match info.location() {
        Some(l) => hprintln!("PANIC at {}:{}", l.file(), l.line()),
        None => hprintln!("PANIC"),
    }
    debug::exit(debug::EXIT_FAILURE);
    loop {}
}
