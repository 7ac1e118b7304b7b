//! The TRN controller node on an STM32G474 (NUCLEO-G474RE): the compact build (i16 tables,
//! no Broyden servo) in its 128 KiB of RAM, FDCAN1 on PA11 (RX) / PA12 (TX) to a CAN
//! transceiver, CAN 2.0 or CAN FD as the session asks. 170 MHz from the board's 24 MHz
//! crystal (HSE), FDCAN kernel clock the HSE itself. Logs over RTT (defmt, non-blocking).
//!
//! The independent watchdog resets the part when the node's loop stops turning for
//! [`WATCHDOG_US`]; a panic or a hard fault resets it at once (`trn_fdcan_node::recover`).
//! The HSE's start is bounded: a crystal that does not start leaves the part on its HSI,
//! where the FDCAN cannot make its bit rates, so the node says so and does not start (the
//! watchdog then resets the part to try again).
#![no_std]
#![no_main]

use defmt_rtt as _;
use embassy_executor::Spawner;
use embassy_stm32::can::{self, RxFdBuf, TxFdBuf};
use embassy_stm32::peripherals::{self, FDCAN1};
use embassy_stm32::rng::{self, Rng};
use embassy_stm32::time::Hertz;
use embassy_stm32::wdg::IndependentWatchdog;
use embassy_stm32::{bind_interrupts, rcc};
use static_cell::ConstStaticCell;
use trn_controller::Controller;
use trn_fdcan_node::{bitrate, recover, KernelClock, NodeState, ResetFlags};

bind_interrupts!(struct Irqs {
    FDCAN1_IT0 => can::IT0InterruptHandler<FDCAN1>;
    FDCAN1_IT1 => can::IT1InterruptHandler<FDCAN1>;
    RNG => rng::InterruptHandler<peripherals::RNG>;
});

/// The FDCAN kernel clock of `clocks()`: the 24 MHz crystal.
const FDCAN_CLOCK: KernelClock = KernelClock::new(24_000_000);

/// Frames the receive interrupt can hold before the loop takes them, and frames waiting to
/// be sent: sized for this part's RAM (each frame buffer is about 80 bytes); the largest
/// burst of one turn is about a dozen frames.
const RX_FRAMES: usize = 8;
const TX_FRAMES: usize = 16;

/// Both networks, zeroed (in `.bss`) until a `SessionConfig` configures and seeds them.
static CONTROLLER: ConstStaticCell<Controller> = ConstStaticCell::new(Controller::new_zeroed());
static NODE: ConstStaticCell<NodeState> = ConstStaticCell::new(NodeState::new());
static RX_BUFFER: ConstStaticCell<RxFdBuf<RX_FRAMES>> = ConstStaticCell::new(RxFdBuf::new());
static TX_BUFFER: ConstStaticCell<TxFdBuf<TX_FRAMES>> = ConstStaticCell::new(TxFdBuf::new());

/// The watchdog's period: far above the longest turn of the loop (a learning step, about
/// 2.4 ms; this board has no flash store to erase).
const WATCHDOG_US: u32 = 2_000_000;

/// Switches the HSE crystal on and waits for it, bounded: true when it runs.
fn hse_starts() -> bool {
    use embassy_stm32::pac::RCC;
    RCC.cr().modify(|w| w.set_hseon(true));
    let started = recover::hse_started(|| RCC.cr().read().hserdy());
    if !started {
        RCC.cr().modify(|w| w.set_hseon(false));
    }
    started
}

/// 170 MHz system clock (boost mode) from the 24 MHz HSE crystal through the PLL
/// (24 / 6 * 85 / 2); the FDCAN straight from the HSE. Without the HSE (`hse` false): the
/// same from the 16 MHz HSI (16 / 4 * 85 / 2), the FDCAN from PCLK1, which the start then
/// refuses (not the bit timings' clock).
fn clocks(hse: bool) -> embassy_stm32::Config {
    use rcc::*;
    let mut config = embassy_stm32::Config::default();
    if hse {
        config.rcc.hse = Some(Hse {
            freq: Hertz(24_000_000),
            mode: HseMode::Oscillator,
        });
    }
    config.rcc.pll = Some(Pll {
        source: if hse { PllSource::HSE } else { PllSource::HSI },
        prediv: if hse {
            PllPreDiv::DIV6
        } else {
            PllPreDiv::DIV4
        },
        mul: PllMul::MUL85,
        divp: None,
        divq: None,
        divr: Some(PllRDiv::DIV2),
    });
    config.rcc.sys = Sysclk::PLL1_R;
    config.rcc.boost = true;
    config.rcc.mux.fdcansel = if hse {
        mux::Fdcansel::HSE
    } else {
        mux::Fdcansel::PCLK1
    };
    config
}

/// The reset flags (RCC CSR: a power-on also sets the brown-out flag), then cleared.
fn reset_flags() -> ResetFlags {
    use embassy_stm32::pac::RCC;
    let r = RCC.csr().read();
    RCC.csr().modify(|w| w.set_rmvf(true));
    ResetFlags {
        power_on: r.borrstf(),
        pin: r.pinrstf(),
        watchdog: r.iwdgrstf() || r.wwdgrstf(),
        software: r.sftrstf(),
    }
}

#[embassy_executor::main]
async fn main(_spawner: Spawner) {
    let flags = reset_flags();
    let hse = hse_starts();
    let p = embassy_stm32::init(clocks(hse));
    let mut watchdog = IndependentWatchdog::new(p.IWDG, WATCHDOG_US);
    watchdog.unleash();
    let node = NODE.take();
    // the reset cause (logged, announced at the loop's start); the guard seeded from the
    // part's RNG (HSI48), so tables can be replaced or erased over the bus
    node.boot(flags, &mut Rng::new(p.RNG, Irqs)).await;
    if !hse {
        defmt::error!("the 24 MHz HSE crystal did not start: running on the HSI");
    }
    let configurator = can::CanConfigurator::new(p.FDCAN1, p.PA11, p.PA12, Irqs);
    let running = rcc::frequency::<FDCAN1>();
    let Ok(can) = trn_fdcan_node::start(
        configurator,
        &FDCAN_CLOCK,
        running,
        TX_BUFFER.take(),
        RX_BUFFER.take(),
    ) else {
        defmt::error!(
            "FDCAN kernel clock {} Hz, not the {} Hz the bit timings were built for: not started",
            running.0,
            FDCAN_CLOCK.hz()
        );
        return;
    };
    defmt::info!(
        "trn-controller on STM32G474: compact i16 tables, CAN {} bit/s, FD data phase {} bit/s; waiting for a SessionConfig",
        bitrate::NOMINAL,
        bitrate::DATA
    );
    trn_fdcan_node::run(can, CONTROLLER.take(), node, || watchdog.pet()).await
}
