//! The TRN controller node on an STM32G474 (NUCLEO-G474RE): the compact build (i16 tables,
//! no Broyden servo) in its 128 KiB of RAM, FDCAN1 on PA11 (RX) / PA12 (TX) to a CAN
//! transceiver, CAN 2.0 or CAN FD as the session asks. 170 MHz from the board's 24 MHz
//! crystal (HSE), FDCAN kernel clock the HSE itself. Logs over RTT (defmt).
#![no_std]
#![no_main]

use defmt_rtt as _;
use embassy_executor::Spawner;
use embassy_stm32::can::{self, RxFdBuf, TxFdBuf};
use embassy_stm32::peripherals::FDCAN1;
use embassy_stm32::time::Hertz;
use embassy_stm32::{bind_interrupts, rcc};
use panic_probe as _;
use static_cell::ConstStaticCell;
use trn_controller::Controller;
use trn_fdcan_node::{bitrate, KernelClock, NodeState};

bind_interrupts!(struct Irqs {
    FDCAN1_IT0 => can::IT0InterruptHandler<FDCAN1>;
    FDCAN1_IT1 => can::IT1InterruptHandler<FDCAN1>;
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

/// 170 MHz system clock (boost mode) from the 24 MHz HSE crystal through the PLL
/// (24 / 6 * 85 / 2); the FDCAN straight from the HSE.
fn clocks() -> embassy_stm32::Config {
    use rcc::*;
    let mut config = embassy_stm32::Config::default();
    config.rcc.hse = Some(Hse {
        freq: Hertz(24_000_000),
        mode: HseMode::Oscillator,
    });
    config.rcc.pll = Some(Pll {
        source: PllSource::HSE,
        prediv: PllPreDiv::DIV6,
        mul: PllMul::MUL85,
        divp: None,
        divq: None,
        divr: Some(PllRDiv::DIV2),
    });
    config.rcc.sys = Sysclk::PLL1_R;
    config.rcc.boost = true;
    config.rcc.mux.fdcansel = mux::Fdcansel::HSE;
    config
}

#[embassy_executor::main]
async fn main(_spawner: Spawner) {
    let p = embassy_stm32::init(clocks());
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
    trn_fdcan_node::run(can, CONTROLLER.take(), NODE.take()).await
}
