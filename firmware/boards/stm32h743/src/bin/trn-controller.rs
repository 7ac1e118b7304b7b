//! The TRN controller node on an STM32H743 (NUCLEO-H743ZI/ZI2): both networks' f32 tables in
//! AXI SRAM, FDCAN1 on PD0 (RX) / PD1 (TX) to a CAN transceiver, CAN 2.0 or CAN FD as the
//! session asks. 400 MHz from the ST-LINK's 8 MHz clock (HSE bypass), FDCAN kernel clock
//! 80 MHz (PLL1 Q), caches on. Logs over RTT (defmt).
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

/// The FDCAN kernel clock of `clocks()`: PLL1 Q, 8 MHz / 1 * 100 / 10.
const FDCAN_CLOCK: KernelClock = KernelClock::new(80_000_000);

/// Frames the receive interrupt can hold before the loop takes them, and frames waiting to
/// be sent (the largest burst of one turn is about a dozen).
const RX_FRAMES: usize = 32;
const TX_FRAMES: usize = 32;

/// Both networks, zeroed (in `.bss`) until a `SessionConfig` configures and seeds them.
static CONTROLLER: ConstStaticCell<Controller> = ConstStaticCell::new(Controller::new_zeroed());
static NODE: ConstStaticCell<NodeState> = ConstStaticCell::new(NodeState::new());
static RX_BUFFER: ConstStaticCell<RxFdBuf<RX_FRAMES>> = ConstStaticCell::new(RxFdBuf::new());
static TX_BUFFER: ConstStaticCell<TxFdBuf<TX_FRAMES>> = ConstStaticCell::new(TxFdBuf::new());

/// 400 MHz system clock from HSE (NUCLEO: the ST-LINK's 8 MHz MCO, bypass), AHB 200 MHz,
/// APBs 100 MHz, FDCAN from PLL1 Q at 80 MHz.
fn clocks() -> embassy_stm32::Config {
    use rcc::*;
    let mut config = embassy_stm32::Config::default();
    config.rcc.hse = Some(Hse {
        freq: Hertz(8_000_000),
        mode: HseMode::Bypass,
    });
    config.rcc.pll1 = Some(Pll {
        source: PllSource::HSE,
        prediv: PllPreDiv::DIV1,
        mul: PllMul::MUL100,
        fracn: None,
        divp: Some(PllDiv::DIV2),
        divq: Some(PllDiv::DIV10),
        divr: None,
    });
    config.rcc.sys = Sysclk::PLL1_P;
    config.rcc.ahb_pre = AHBPrescaler::DIV2;
    config.rcc.apb1_pre = APBPrescaler::DIV2;
    config.rcc.apb2_pre = APBPrescaler::DIV2;
    config.rcc.apb3_pre = APBPrescaler::DIV2;
    config.rcc.apb4_pre = APBPrescaler::DIV2;
    config.rcc.voltage_scale = VoltageScale::Scale1;
    config.rcc.mux.fdcansel = mux::Fdcansel::PLL1_Q;
    config
}

#[embassy_executor::main]
async fn main(_spawner: Spawner) {
    let p = embassy_stm32::init(clocks());
    // the tables are read from AXI SRAM: with the caches on (no DMA touches that memory)
    if let Some(mut core) = cortex_m::Peripherals::take() {
        core.SCB.enable_icache();
        core.SCB.enable_dcache(&mut core.CPUID);
    } else {
        defmt::warn!("the core peripherals were taken: caches left off (the steps run slower)");
    }
    let configurator = can::CanConfigurator::new(p.FDCAN1, p.PD0, p.PD1, Irqs);
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
        "trn-controller on STM32H743: f32 tables, CAN {} bit/s, FD data phase {} bit/s; waiting for a SessionConfig",
        bitrate::NOMINAL,
        bitrate::DATA
    );
    trn_fdcan_node::run(can, CONTROLLER.take(), NODE.take()).await
}
