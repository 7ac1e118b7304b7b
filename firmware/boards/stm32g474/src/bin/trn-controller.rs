//! The TRN controller node on an STM32G474 (NUCLEO-G474RE): the compact build (i16 tables,
//! no Broyden servo) in its 128 KiB of RAM, FDCAN1 on PA11 (RX) / PA12 (TX) to a CAN
//! transceiver, CAN 2.0 or CAN FD as the session asks. 170 MHz from the board's 24 MHz
//! crystal (HSE), FDCAN kernel clock the HSE itself. Logs over RTT (defmt, non-blocking).
//!
//! The learned tables are kept in the part's own flash ([`store`]) as compact images
//! (checkpoint format 3: the i16 tables as they are, half an f32 image: two f32 slots would
//! not fit beside the image): the newest intact copy is restored at boot and announced; the
//! node saves on a `StoreCommand`, on entering `Mature` and every 2,887 learning steps
//! (`trn_fdcan_node::store`). The image runs from bank 1 and the store lives in bank 2, whose pages
//! erase in the background while the node's loop runs. A double ECC error in the flash
//! raises an NMI on this part; a read of the store that meets one (a word torn by a power
//! cut) is a damaged copy, never a fault at every boot.
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
use trn_controller::{Controller, WithStore};
use trn_fdcan_node::{bitrate, recover, KernelClock, NodeState, ResetFlags};

bind_interrupts!(struct Irqs {
    FDCAN1_IT0 => can::IT0InterruptHandler<FDCAN1>;
    FDCAN1_IT1 => can::IT1InterruptHandler<FDCAN1>;
    RNG => rng::InterruptHandler<peripherals::RNG>;
});

/// The FDCAN kernel clock of `clocks()`: the 24 MHz crystal.
const FDCAN_CLOCK: KernelClock = KernelClock::new(24_000_000);

/// Frames the receive interrupt can hold before the loop takes them, and frames waiting to
/// be sent: sized for this part's RAM with its store (each frame buffer is about 80 bytes);
/// the largest burst of one turn is about a dozen frames, and the FDCAN's own transmit
/// FIFO holds 3 more.
const RX_FRAMES: usize = 6;
const TX_FRAMES: usize = 12;

/// Both networks, zeroed (in `.bss`) until a `SessionConfig` configures and seeds them.
static CONTROLLER: ConstStaticCell<Controller> = ConstStaticCell::new(Controller::new_zeroed());
static NODE: ConstStaticCell<NodeState> =
    ConstStaticCell::new(NodeState::with_config(trn_fdcan_node::store::NODE_CONFIG));
static RX_BUFFER: ConstStaticCell<RxFdBuf<RX_FRAMES>> = ConstStaticCell::new(RxFdBuf::new());
static TX_BUFFER: ConstStaticCell<TxFdBuf<TX_FRAMES>> = ConstStaticCell::new(TxFdBuf::new());

/// The watchdog's period: above the longest turn of the node's loop, a `StoreCommand{Erase}`
/// that erases the store's 112 pages in one turn (ST: 40 ms maximum each, 4.5 s).
const WATCHDOG_US: u32 = 10_000_000;

/// The store of the learned tables in bank 2.
mod store {
    use core::sync::atomic::{AtomicBool, Ordering};

    use cortex_m_rt::exception;
    use embassy_stm32::flash::{Blocking, Error, Flash, FLASH_BASE, FLASH_SIZE};
    use embassy_stm32::pac;
    use embedded_storage::nor_flash::{ErrorType, NorFlash, ReadNorFlash};
    use trn_controller::checkpoint::Encoding;
    use trn_store::{BackgroundErase, FlashStore};

    pub use trn_fdcan_node::store::FlashError;

    /// True while the store reads the flash: an ECC double error then is the store's to
    /// handle ([`ECC_MET`]), not a fault.
    static READING: AtomicBool = AtomicBool::new(false);
    /// Set by the NMI when a read of the store met an ECC double error.
    static ECC_MET: AtomicBool = AtomicBool::new(false);

    /// The NMI: on this part a double ECC error in the flash raises it (RM0440 3.3.4), the
    /// read returning whatever the word holds. During a read of the store the flag is
    /// cleared and the error noted for the read ([`FlashError::Ecc`]); any other NMI (an
    /// ECC error in the image itself, the clock security system) cannot be recovered from
    /// here: a panic records it and resets the part.
    // SAFETY (cortex-m-rt: an NMI handler is unsafe to define, since it can preempt any
    // critical section): it touches only the flash's ECC register and two atomics, which no
    // critical section guards
    #[allow(unsafe_code)]
    #[exception]
    unsafe fn NonMaskableInt() {
        let eccr = pac::FLASH.eccr().read();
        let double = eccr.eccd() || eccr.eccd2();
        if double {
            // write-1-to-clear: ECCD (and ECCD2, a single error's ECCC too)
            pac::FLASH.eccr().modify(|_| {});
            if READING.load(Ordering::Relaxed) {
                ECC_MET.store(true, Ordering::Relaxed);
                return;
            }
        }
        panic!(
            "NMI: ECC double error outside the store: {} (address 0x{:x})",
            double,
            eccr.addr_ecc()
        );
    }

    /// Embassy's blocking driver of the whole flash (offsets from 0x0800_0000; 2 KiB pages
    /// in dual-bank mode, programmed 8 bytes at a time), its reads guarded against ECC
    /// double errors.
    ///
    /// The store's erases run in the background ([`BackgroundErase`]): the part's two banks
    /// read while they write, so with the image in bank 1 and the store in bank 2 a page
    /// erase of bank 2 is started (PER, BKER, PNB, STRT) and polled (BSY) while the node's
    /// loop runs from bank 1; embassy 0.6's blocking erase waits inside the call (22 ms
    /// typical, 40 ms maximum a page). Reads, writes and blocking erases wait for an erase
    /// under way first. As embassy's own operations, an erase runs with the flash's data
    /// cache off, reset and re-enabled after it.
    pub struct EccFlash {
        flash: Flash<'static, Blocking>,
        /// The offset of the page whose erase is under way, and whether the data cache was on.
        erasing: Option<(u32, bool)>,
    }

    impl EccFlash {
        pub fn new(flash: Flash<'static, Blocking>) -> Self {
            EccFlash {
                flash,
                erasing: None,
            }
        }
    }

    impl ErrorType for EccFlash {
        type Error = FlashError;
    }

    impl ReadNorFlash for EccFlash {
        const READ_SIZE: usize = <Flash<'static, Blocking> as ReadNorFlash>::READ_SIZE;

        /// A read during which an ECC double error is noted by the NMI, not a fault: a torn
        /// word is [`FlashError::Ecc`].
        fn read(&mut self, offset: u32, bytes: &mut [u8]) -> Result<(), FlashError> {
            self.erase_wait()?;
            ECC_MET.store(false, Ordering::Relaxed);
            READING.store(true, Ordering::SeqCst);
            let read = self.flash.read(offset, bytes);
            READING.store(false, Ordering::SeqCst);
            if ECC_MET.swap(false, Ordering::Relaxed) {
                return Err(FlashError::Ecc);
            }
            Ok(read?)
        }

        fn capacity(&self) -> usize {
            self.flash.capacity()
        }
    }

    impl NorFlash for EccFlash {
        const WRITE_SIZE: usize = <Flash<'static, Blocking> as NorFlash>::WRITE_SIZE;
        const ERASE_SIZE: usize = <Flash<'static, Blocking> as NorFlash>::ERASE_SIZE;

        fn write(&mut self, offset: u32, bytes: &[u8]) -> Result<(), FlashError> {
            self.erase_wait()?;
            Ok(self.flash.write(offset, bytes)?)
        }

        fn erase(&mut self, from: u32, to: u32) -> Result<(), FlashError> {
            self.erase_wait()?;
            Ok(self.flash.erase(from, to)?)
        }
    }

    /// A page: 2 KiB in dual-bank mode.
    const PAGE: u32 = 2048;

    impl BackgroundErase for EccFlash {
        /// RM0440's page erase in bank 2: unlock, PER with BKER and the page number, STRT;
        /// only pages of bank 2 (the store's).
        fn erase_start(&mut self, offset: u32) -> Result<(), FlashError> {
            self.erase_wait()?;
            let bank_size = FLASH_SIZE as u32 / 2;
            if offset < bank_size || offset >= FLASH_SIZE as u32 {
                return Err(Error::Size.into());
            }
            if !offset.is_multiple_of(PAGE) {
                return Err(Error::Unaligned.into());
            }
            let f = pac::FLASH;
            if f.sr().read().bsy() {
                return Err(Error::Seq.into());
            }
            // write-1-to-clear: every error flag and EOP
            f.sr().modify(|_| {});
            let cached = f.acr().read().dcen();
            f.acr().modify(|w| w.set_dcen(false));
            if f.cr().read().lock() {
                f.keyr().write_value(0x4567_0123);
                f.keyr().write_value(0xCDEF_89AB);
            }
            f.cr().modify(|w| {
                w.set_per(true);
                w.set_bker(true);
                w.set_pnb(((offset - bank_size) / PAGE) as u8);
            });
            f.cr().modify(|w| w.set_strt(true));
            cortex_m::asm::dsb();
            self.erasing = Some((offset, cached));
            Ok(())
        }

        fn erase_done(&mut self) -> Result<bool, FlashError> {
            let Some((_, cached)) = self.erasing else {
                return Ok(true);
            };
            let f = pac::FLASH;
            let sr = f.sr().read();
            if sr.bsy() {
                return Ok(false);
            }
            self.erasing = None;
            f.cr().modify(|w| {
                w.set_per(false);
                w.set_bker(false);
            });
            f.cr().modify(|w| w.set_lock(true));
            f.sr().modify(|_| {});
            if cached {
                f.acr().modify(|w| w.set_dcrst(true));
                f.acr().modify(|w| w.set_dcrst(false));
                f.acr().modify(|w| w.set_dcen(true));
            }
            if sr.wrperr() {
                Err(Error::Protected.into())
            } else if sr.pgserr() || sr.progerr() || sr.pgaerr() || sr.sizerr() || sr.operr() {
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

    /// The store of the tables: compact images.
    pub type Store = FlashStore<EccFlash>;

    /// A slot: the header and the largest compact checkpoint, in whole pages.
    pub const SLOT: u32 = Store::slot_size_needed_as(Encoding::Compact);

    /// The store's first byte (an offset in the flash): bank 2's first page (0x0804_0000),
    /// where memory.x ends the image's FLASH.
    pub const STORE_AT: u32 = FLASH_SIZE as u32 / 2;

    /// The two slots fit bank 2 (a build whose checkpoint outgrew it stops here).
    const _: () = assert!(2 * SLOT <= FLASH_SIZE as u32 / 2);

    extern "C" {
        /// memory.x: the first byte past the image's FLASH region.
        static __trn_store: u8;
    }

    /// True when the link ended the image's flash where the store begins.
    pub fn linked_apart() -> bool {
        core::ptr::addr_of!(__trn_store) as usize == FLASH_BASE + STORE_AT as usize
    }
}

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
    trn_fdcan_node::guard_stack();
    let flags = reset_flags();
    let hse = hse_starts();
    let p = embassy_stm32::init(clocks(hse));
    let mut watchdog = IndependentWatchdog::new(p.IWDG, WATCHDOG_US);
    watchdog.unleash();
    if !hse {
        defmt::error!("the 24 MHz HSE crystal did not start: running on the HSI");
    }
    if !store::linked_apart() {
        defmt::error!(
            "the image's flash does not end where the tables' store begins (memory.x): not started"
        );
        return;
    }
    let flash = store::EccFlash::new(embassy_stm32::flash::Flash::new_blocking(p.FLASH));
    let Ok(store) = store::Store::new_as(
        flash,
        store::STORE_AT,
        store::SLOT,
        trn_controller::checkpoint::Encoding::Compact,
    )
    .map(store::Store::with_background_erase) else {
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
        "trn-controller on STM32G474: compact i16 tables (store: 2 slots of {} B at 0x{:x}, saves every {} learning steps), CAN {} bit/s, FD data phase {} bit/s; waiting for a SessionConfig",
        store::SLOT,
        embassy_stm32::flash::FLASH_BASE as u32 + store::STORE_AT,
        trn_fdcan_node::store::SAVE_EVERY_STEPS,
        bitrate::NOMINAL,
        bitrate::DATA
    );
    trn_fdcan_node::run(can, &mut board, node, || watchdog.pet()).await
}
