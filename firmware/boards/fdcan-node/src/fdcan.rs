//! The FDCAN peripheral set up for the protocol and started with interrupt-driven buffers.

use embassy_stm32::can::config::{
    FrameTransmissionConfig, GlobalFilter, NonMatchingFilter, TxBufferMode,
};
use embassy_stm32::can::{BufferedCanFd, CanConfigurator, OperatingMode, RxFdBuf, TxFdBuf};
use embassy_stm32::time::Hertz;

use crate::bitrate::{self, Timings};

/// The FDCAN driver the node runs on: its interrupt handler moves received frames into a
/// buffer of `RX` and frames to send from a buffer of `TX` into the peripheral.
pub type Fdcan<const TX: usize, const RX: usize> = BufferedCanFd<'static, TX, RX>;

/// The FDCAN kernel clock a board's clock tree is set up to give, and the bit timings of the
/// build's rates for it.
pub struct KernelClock {
    hz: u32,
    timings: Timings,
}

impl KernelClock {
    /// A kernel clock of `hz`. In a `const` (as the boards declare it) the timings are
    /// computed when the image is built, and a bit rate the clock cannot make fails the build.
    pub const fn new(hz: u32) -> Self {
        KernelClock {
            hz,
            timings: bitrate::timings(hz),
        }
    }

    /// The clock (Hz).
    pub const fn hz(&self) -> u32 {
        self.hz
    }
}

/// Configures the FDCAN and starts it on the bus: the build's bit rates with CAN FD and
/// bit-rate switching allowed (each frame is sent classical or FD as the protocol's frame
/// says, so the node serves CAN 2.0 and CAN FD sessions alike), frames sent strictly in the
/// order written (the segments of a message must not overtake each other), standard-id data
/// frames received into FIFO 0 and everything else rejected by the peripheral, no automatic
/// recovery from bus-off (the loop restarts it after a hold-off, [`crate::health`]).
///
/// `running` is the kernel clock the peripheral really has
/// (`embassy_stm32::rcc::frequency::<FDCAN1>()`); when it is not `clock`, the timings would
/// give other bit rates than the build's, so nothing is started and it is returned.
pub fn start<const TX: usize, const RX: usize>(
    mut can: CanConfigurator<'static>,
    clock: &KernelClock,
    running: Hertz,
    tx: &'static mut TxFdBuf<TX>,
    rx: &'static mut RxFdBuf<RX>,
) -> Result<Fdcan<TX, RX>, Hertz> {
    if running.0 != clock.hz {
        return Err(running);
    }
    let config = can
        .config()
        .set_nominal_bit_timing(clock.timings.nominal)
        .set_data_bit_timing(clock.timings.data)
        .set_frame_transmit(FrameTransmissionConfig::AllowFdCanAndBRS)
        .set_tx_buffer_mode(TxBufferMode::Fifo)
        .set_global_filter(
            GlobalFilter::reject_all().set_handle_standard_frames(NonMatchingFilter::IntoRxFifo0),
        )
        .set_automatic_bus_off_recovery(false);
    can.set_config(config);
    Ok(can
        .start(OperatingMode::NormalOperationMode)
        .buffered_fd(tx, rx))
}
