//! The TRN controller node on an STM32H743 (NUCLEO-H743ZI/ZI2): both networks' f32 tables in
//! AXI SRAM, FDCAN1 on PD0 (RX) / PD1 (TX) to a CAN transceiver, CAN 2.0 or CAN FD as the
//! session asks. 400 MHz from the ST-LINK's 8 MHz clock (HSE bypass), FDCAN kernel clock
//! 80 MHz (PLL1 Q), caches on. Logs over RTT (defmt, non-blocking).
//!
//! The learned tables are kept in the part's own flash ([`store`]): the newest intact copy is
//! restored at boot and announced; the node saves on a `StoreCommand`, on entering `Mature`
//! and every 2,887 learning steps (`trn_fdcan_node::store`). The store reads the flash with
//! bus faults masked and checks the ECC flags, so a flash word torn by a power cut is a damaged copy,
//! never a fault at every boot.
//!
//! The independent watchdog resets the part when the node's loop stops turning for
//! [`WATCHDOG_US`]; a panic or a hard fault resets it at once (`trn_fdcan_node::recover`).
//! The HSE's start is bounded: without the ST-LINK's clock the part runs from its HSI
//! (64 MHz, the same PLL and FDCAN clocks; the HSI is less accurate, which the log says).
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
use trn_controller::{Controller, WithStore};
use trn_fdcan_node::{bitrate, recover, KernelClock, NodeState, ResetFlags};

bind_interrupts!(struct Irqs {
    FDCAN1_IT0 => can::IT0InterruptHandler<FDCAN1>;
    FDCAN1_IT1 => can::IT1InterruptHandler<FDCAN1>;
    RNG => rng::InterruptHandler<peripherals::RNG>;
});

/// The FDCAN kernel clock of `clocks()`: PLL1 Q, 8 MHz / 1 * 100 / 10.
const FDCAN_CLOCK: KernelClock = KernelClock::new(80_000_000);

/// Frames the receive interrupt can hold before the loop takes them, and frames waiting to
/// be sent (the largest burst of one turn is about a dozen).
const RX_FRAMES: usize = 32;
const TX_FRAMES: usize = 32;

/// Both networks, zeroed (in `.bss`) until a `SessionConfig` configures and seeds them.
static CONTROLLER: ConstStaticCell<Controller> = ConstStaticCell::new(Controller::new_zeroed());
static NODE: ConstStaticCell<NodeState> =
    ConstStaticCell::new(NodeState::with_config(trn_fdcan_node::store::NODE_CONFIG));
static RX_BUFFER: ConstStaticCell<RxFdBuf<RX_FRAMES>> = ConstStaticCell::new(RxFdBuf::new());
static TX_BUFFER: ConstStaticCell<TxFdBuf<TX_FRAMES>> = ConstStaticCell::new(TxFdBuf::new());

/// The watchdog's period: above the longest turn of the node's loop, a `StoreCommand{Erase}`
/// that erases the store's four sectors in one turn (ST: 2.2 s maximum each at x32; the
/// blocking erase may run at x8, slower) — 30 s of the IWDG's 32.7 s at most.
const WATCHDOG_US: u32 = 30_000_000;

/// The store of the learned tables in the flash's last 512 KiB.
mod store {
    use cortex_m::peripheral::SCB;
    use embassy_stm32::flash::{Blocking, Error, Flash, FLASH_BASE, FLASH_SIZE};
    use embassy_stm32::pac;
    use embedded_storage::nor_flash::{ErrorType, NorFlash, ReadNorFlash};
    use trn_store::{BackgroundErase, FlashStore};

    pub use trn_fdcan_node::store::FlashError;

    /// SCB CCR's BFHFNMIGN: precise data bus faults ignored at a priority of -1 and below.
    const BFHFNMIGN: u32 = 1 << 8;

    /// Runs `f` with bus faults masked: FAULTMASK set and CCR.BFHFNMIGN, so a load that the
    /// flash answers with a bus error (an ECC double error) returns instead of faulting
    /// (RM0433; the pattern of Zephyr's H7 flash driver).
    fn bus_faults_masked<R>(f: impl FnOnce() -> R) -> R {
        // SAFETY: FAULTMASK and CCR are the core's own, restored before returning; no
        // interrupt runs meanwhile (FAULTMASK), so nothing else sees them changed
        #[allow(unsafe_code)]
        unsafe {
            let scb = &*SCB::PTR;
            core::arch::asm!("cpsid f", options(nostack, preserves_flags));
            scb.ccr.modify(|r| r | BFHFNMIGN);
            cortex_m::asm::dsb();
            cortex_m::asm::isb();
            let r = f();
            cortex_m::asm::dsb();
            scb.ccr.modify(|r| r & !BFHFNMIGN);
            cortex_m::asm::isb();
            core::arch::asm!("cpsie f", options(nostack, preserves_flags));
            r
        }
    }

    /// A sector: 128 KiB.
    const SECTOR: u32 = 128 * 1024;
    /// PSIZE for erases: x32 parallelism (the 2.7-3.6 V range without an external VPP),
    /// ST's 1.1 s typical / 2.2 s maximum per sector. embassy's word write leaves PSIZE at
    /// x8 (its `CR` write starts from zero), at which an erase is slower, so each erase sets
    /// it.
    const PSIZE_X32: u8 = 0b10;

    /// Embassy's blocking driver of the whole flash (offsets from 0x0800_0000; sectors of
    /// 128 KiB, programmed 32 bytes at a time) with the data cache kept coherent: the flash is
    /// read through the D-cache (write-through), so the lines of what an erase or a program
    /// changed are invalidated after it (a stale line would show a header that is gone).
    ///
    /// The store's erases run in the background ([`BackgroundErase`]): the part's dual banks
    /// read while they write, so with the image in bank 1 and the store in bank 2 a sector
    /// erase of bank 2 is started through bank 2's registers and polled (BSY, QW) while the
    /// node's loop runs from bank 1. embassy 0.6's blocking erase waits for it inside the
    /// call (1.1-2.2 s at x32, the drives' heartbeat supervision is 500 ms); its async erase
    /// needs an executor task for the store. Reads, writes and blocking erases wait for an
    /// erase under way first (a read of bank 2 during its erase would stall the bus).
    pub struct CoherentFlash {
        flash: Flash<'static, Blocking>,
        /// `None` when the caches were left off.
        scb: Option<SCB>,
        /// The offset of the sector whose erase is under way.
        erasing: Option<u32>,
    }

    /// Bank 2's registers (the store's sectors are bank 2's sectors 4-7).
    fn bank2() -> pac::flash::Bank {
        pac::FLASH.bank(1)
    }

    /// Clears bank 2's error and end-of-operation flags.
    fn clear_flags() {
        bank2().ccr().write(|w| {
            w.set_clr_eop(true);
            w.set_clr_wrperr(true);
            w.set_clr_pgserr(true);
            w.set_clr_strberr(true);
            w.set_clr_incerr(true);
            w.set_clr_operr(true);
        });
    }

    impl CoherentFlash {
        pub fn new(flash: Flash<'static, Blocking>, scb: Option<SCB>) -> Self {
            CoherentFlash {
                flash,
                scb,
                erasing: None,
            }
        }

        fn invalidate(&mut self, offset: u32, len: usize) {
            if let Some(scb) = self.scb.as_mut() {
                // SAFETY: the lines are the store's flash, which holds no variable and is
                // write-through cached: no line there is dirty, nothing is lost
                unsafe { scb.invalidate_dcache_by_address(FLASH_BASE + offset as usize, len) }
            }
        }
    }

    impl ErrorType for CoherentFlash {
        type Error = FlashError;
    }

    impl ReadNorFlash for CoherentFlash {
        const READ_SIZE: usize = <Flash<'static, Blocking> as ReadNorFlash>::READ_SIZE;

        /// A read with bus faults masked, then the bank's DBECCERR flag checked: a torn word
        /// is [`FlashError::Ecc`], not a fault (and its cache lines are dropped).
        fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), FlashError> {
            self.erase_wait()?;
            let bank = pac::FLASH.bank((offset >= FLASH_SIZE as u32 / 2) as usize);
            bank.ccr().write(|w| w.set_clr_dbeccerr(true));
            let flash = &mut self.flash;
            let read = bus_faults_masked(|| flash.read(offset, bytes));
            if bank.sr().read().dbeccerr() {
                bank.ccr().write(|w| w.set_clr_dbeccerr(true));
                self.invalidate(offset, bytes.len());
                return Err(FlashError::Ecc);
            }
            Ok(read?)
        }

        fn capacity(&self) -> usize {
            self.flash.capacity()
        }
    }

    impl NorFlash for CoherentFlash {
        const WRITE_SIZE: usize = <Flash<'static, Blocking> as NorFlash>::WRITE_SIZE;
        const ERASE_SIZE: usize = <Flash<'static, Blocking> as NorFlash>::ERASE_SIZE;

        fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), FlashError> {
            self.erase_wait()?;
            let done = self.flash.write(offset, bytes);
            self.invalidate(offset, bytes.len());
            Ok(done?)
        }

        fn erase(&mut self, from: u32, to: u32) -> Result<(), FlashError> {
            self.erase_wait()?;
            let done = self.flash.erase(from, to);
            self.invalidate(from, to.saturating_sub(from) as usize);
            Ok(done?)
        }
    }

    impl BackgroundErase for CoherentFlash {
        /// RM0433's sector erase on bank 2: unlock, SER with the sector and PSIZE, START;
        /// only sectors of bank 2 (the store's).
        fn erase_start(&mut self, offset: u32) -> Result<(), FlashError> {
            self.erase_wait()?;
            let bank_size = FLASH_SIZE as u32 / 2;
            if offset < bank_size || offset >= FLASH_SIZE as u32 {
                return Err(Error::Size.into());
            }
            if !offset.is_multiple_of(SECTOR) {
                return Err(Error::Unaligned.into());
            }
            let bank = bank2();
            if bank.sr().read().bsy() || bank.sr().read().qw() {
                return Err(Error::Seq.into());
            }
            clear_flags();
            if bank.cr().read().lock() {
                bank.keyr().write_value(0x4567_0123);
                bank.keyr().write_value(0xCDEF_89AB);
            }
            bank.cr().modify(|w| {
                w.set_ser(true);
                w.set_snb(((offset - bank_size) / SECTOR) as u8);
                w.set_psize(PSIZE_X32);
            });
            bank.cr().modify(|w| w.set_start(true));
            cortex_m::asm::dsb();
            self.erasing = Some(offset);
            Ok(())
        }

        fn erase_done(&mut self) -> Result<bool, FlashError> {
            let Some(offset) = self.erasing else {
                return Ok(true);
            };
            let bank = bank2();
            let sr = bank.sr().read();
            if sr.bsy() || sr.qw() {
                return Ok(false);
            }
            self.erasing = None;
            bank.cr().modify(|w| w.set_ser(false));
            bank.cr().modify(|w| w.set_lock(true));
            clear_flags();
            self.invalidate(offset, SECTOR as usize);
            if sr.wrperr() {
                Err(Error::Protected.into())
            } else if sr.pgserr() || sr.strberr() || sr.incerr() || sr.operr() {
                Err(Error::Seq.into())
            } else {
                Ok(true)
            }
        }

        fn erase_wait(&mut self) -> Result<(), FlashError> {
            while !self.erase_done()? {}
            Ok(())
        }
    }

    /// The store of the tables.
    pub type Store = FlashStore<CoherentFlash>;

    /// A slot: the header and the largest checkpoint, in whole sectors (2 x 128 KiB).
    pub const SLOT: u32 = Store::slot_size_needed();

    /// The store's first byte (an offset in the flash): the two slots end the flash
    /// (0x0818_0000, bank 2's sectors 4-7), where memory.x ends the image's FLASH.
    pub const STORE_AT: u32 = FLASH_SIZE as u32 - 2 * SLOT;

    extern "C" {
        /// memory.x: the first byte past the image's FLASH region.
        static __trn_store: u8;
    }

    /// True when the link ended the image's flash where the store begins.
    pub fn linked_apart() -> bool {
        core::ptr::addr_of!(__trn_store) as usize == FLASH_BASE + STORE_AT as usize
    }
}

/// Switches the HSE on in bypass (the ST-LINK's clock output) and waits for it, bounded:
/// true when it runs.
fn hse_starts() -> bool {
    use embassy_stm32::pac::RCC;
    RCC.cr().modify(|w| w.set_hsebyp(true));
    RCC.cr().modify(|w| w.set_hseon(true));
    let started = recover::hse_started(|| RCC.cr().read().hserdy());
    if !started {
        RCC.cr().modify(|w| w.set_hseon(false));
        RCC.cr().modify(|w| w.set_hsebyp(false));
    }
    started
}

/// 400 MHz system clock from HSE (NUCLEO: the ST-LINK's 8 MHz MCO, bypass), AHB 200 MHz,
/// APBs 100 MHz, FDCAN from PLL1 Q at 80 MHz. Without the HSE (`hse` false): the same PLL
/// from the 64 MHz HSI divided by 8.
fn clocks(hse: bool) -> embassy_stm32::Config {
    use rcc::*;
    let mut config = embassy_stm32::Config::default();
    if hse {
        config.rcc.hse = Some(Hse {
            freq: Hertz(8_000_000),
            mode: HseMode::Bypass,
        });
    }
    config.rcc.pll1 = Some(Pll {
        source: if hse { PllSource::HSE } else { PllSource::HSI },
        prediv: if hse {
            PllPreDiv::DIV1
        } else {
            PllPreDiv::DIV8
        },
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

/// The reset flags (RCC RSR: a power-on also sets the brown-out flag), then cleared.
fn reset_flags() -> ResetFlags {
    use embassy_stm32::pac::RCC;
    let r = RCC.rsr().read();
    RCC.rsr().modify(|w| w.set_rmvf(true));
    ResetFlags {
        power_on: r.porrstf() || r.borrstf(),
        pin: r.pinrstf(),
        watchdog: r.iwdg1rstf() || r.wwdg1rstf(),
        software: r.sftrstf(),
    }
}

#[embassy_executor::main]
async fn main(_spawner: Spawner) {
    trn_fdcan_node::guard_stack();
    let flags = reset_flags();
    let hse = hse_starts();
    let p = embassy_stm32::init(clocks(hse));
    let mut watchdog = IndependentWatchdog::new(p.IWDG1, WATCHDOG_US);
    watchdog.unleash();
    if !hse {
        defmt::warn!(
            "the HSE (the ST-LINK's 8 MHz clock) did not start: running on the HSI, whose accuracy may not hold the CAN bit rate"
        );
    }
    // the tables are read from AXI SRAM: with the caches on (no DMA touches that memory)
    let scb = if let Some(mut core) = cortex_m::Peripherals::take() {
        core.SCB.enable_icache();
        core.SCB.enable_dcache(&mut core.CPUID);
        Some(core.SCB)
    } else {
        defmt::warn!("the core peripherals were taken: caches left off (the steps run slower)");
        None
    };
    if !store::linked_apart() {
        defmt::error!(
            "the image's flash does not end where the tables' store begins (memory.x): not started"
        );
        return;
    }
    let flash = store::CoherentFlash::new(embassy_stm32::flash::Flash::new_blocking(p.FLASH), scb);
    let Ok(store) = store::Store::new(flash, store::STORE_AT, store::SLOT)
        .map(store::Store::with_background_erase)
    else {
        defmt::error!("the tables' store does not fit its flash region: not started");
        return;
    };
    let mut board = WithStore {
        ctrl: CONTROLLER.take(),
        store,
    };
    let node = NODE.take();
    // the newest intact copy, announced by the node at its first turn
    let restored = trn_fdcan_node::store::restore_at_boot(&mut board.store, board.ctrl);
    // the reset cause (logged, announced at the loop's start); the guard seeded from the
    // part's RNG (HSI48), so tables can be replaced or erased over the bus
    node.boot(flags, &mut Rng::new(p.RNG, Irqs)).await;
    node.tables_restored(&mut board, restored);
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
        "trn-controller on STM32H743: f32 tables (store: 2 slots of {} B at 0x{:x}, saves every {} learning steps), CAN {} bit/s, FD data phase {} bit/s; waiting for a SessionConfig",
        store::SLOT,
        embassy_stm32::flash::FLASH_BASE as u32 + store::STORE_AT,
        trn_fdcan_node::store::SAVE_EVERY_STEPS,
        bitrate::NOMINAL,
        bitrate::DATA
    );
    trn_fdcan_node::run(can, &mut board, node, || watchdog.pet()).await
}
