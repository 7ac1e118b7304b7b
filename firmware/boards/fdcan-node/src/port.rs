//! embassy's buffered FDCAN driver as an `embedded-can` port of the protocol's frames.

use embassy_stm32::can::enums::BusError;
use embassy_stm32::can::frame::{FdEnvelope, FdFrame, Header};
use embassy_stm32::can::{BufferedFdCanReceiver, BufferedFdCanSender};
use embedded_can::{ErrorKind, Id, StandardId};
use trn_protocol::CanFrame;

/// What the port could not do.
#[derive(Debug, defmt::Format)]
pub enum PortError {
    /// The peripheral reported a bus error (it is counted by the peripheral too; the frames
    /// around it are unaffected).
    Bus(BusError),
    /// The transmit buffer was full (the bus is not taking frames: no other node
    /// acknowledges, or it is overloaded); the frame was dropped, as a lost frame would be,
    /// and the protocol's repeats recover it.
    TransmitBufferFull,
    /// The driver refused the frame's layout (a protocol frame always has a standard id and a
    /// valid length, so this is reported rather than expected).
    FrameRejected,
}

impl embedded_can::Error for PortError {
    fn kind(&self) -> ErrorKind {
        match self {
            PortError::Bus(BusError::Stuff) => ErrorKind::Stuff,
            PortError::Bus(BusError::Form) => ErrorKind::Form,
            PortError::Bus(BusError::Acknowledge) => ErrorKind::Acknowledge,
            PortError::Bus(BusError::BitRecessive | BusError::BitDominant) => ErrorKind::Bit,
            PortError::Bus(BusError::Crc) => ErrorKind::Crc,
            PortError::Bus(BusError::Software) => ErrorKind::Other,
            PortError::TransmitBufferFull => ErrorKind::Overrun,
            PortError::FrameRejected => ErrorKind::Other,
        }
    }
}

/// The FDCAN's receive and transmit buffers as a port of [`CanFrame`]s: classical or FD
/// frames both ways, the FD flag kept (an FD frame is sent with bit-rate switching).
/// Nothing here blocks: `receive` answers `WouldBlock` when the buffer is empty, `transmit`
/// never does.
pub struct FdcanPort {
    reader: BufferedFdCanReceiver,
    writer: BufferedFdCanSender,
    /// A frame the loop already took from the receive buffer while waiting for one.
    waited: Option<CanFrame>,
    /// Received frames that are not the protocol's (the peripheral's filters let only
    /// standard-id data frames through, so this stays 0 unless they are changed).
    foreign: u32,
    /// The controller is off the bus: frames to send are dropped, not queued.
    off_bus: bool,
    /// Frames dropped while off the bus.
    dropped: u32,
}

impl FdcanPort {
    /// The port over a started driver's buffers.
    pub fn new(reader: BufferedFdCanReceiver, writer: BufferedFdCanSender) -> Self {
        FdcanPort {
            reader,
            writer,
            waited: None,
            foreign: 0,
            off_bus: false,
            dropped: 0,
        }
    }

    /// Whether the controller is off the bus (bus-off, waiting for its restart): frames to
    /// send are then dropped and counted ([`FdcanPort::dropped_off_bus`]) rather than left
    /// to go out, stale, once it rejoins.
    pub fn set_off_bus(&mut self, off: bool) {
        self.off_bus = off;
    }

    /// Frames dropped while the controller was off the bus.
    pub fn dropped_off_bus(&self) -> u32 {
        self.dropped
    }

    /// The receive buffer, to wait on for the next frame.
    pub fn reader(&self) -> &BufferedFdCanReceiver {
        &self.reader
    }

    /// Hands the port what the loop took from the receive buffer while waiting: a frame,
    /// which `receive` returns first, or a bus error, returned here.
    pub fn put_back(&mut self, received: Result<FdEnvelope, BusError>) -> Result<(), BusError> {
        let frame = received?.frame;
        match to_protocol(&frame) {
            Some(f) => self.waited = Some(f),
            None => self.foreign = self.foreign.wrapping_add(1),
        }
        Ok(())
    }

    /// Received frames that were not the protocol's (remote frames, extended ids).
    pub fn foreign_frames(&self) -> u32 {
        self.foreign
    }
}

/// A received frame as the protocol's; `None` for a remote frame or an extended id.
fn to_protocol(frame: &FdFrame) -> Option<CanFrame> {
    let header = frame.header();
    if header.rtr() {
        return None;
    }
    let Id::Standard(id) = *header.id() else {
        return None;
    };
    let data = &frame.data()[..usize::from(header.len()).min(frame.data().len())];
    CanFrame::new_checked(id.as_raw(), data, header.fdcan()).ok()
}

/// The protocol's frame as the driver's: classical, or FD with bit-rate switching.
fn to_driver(frame: &CanFrame) -> Option<FdFrame> {
    let id = Id::Standard(StandardId::new(frame.raw_id())?);
    let len = frame.len() as u8;
    let header = if frame.is_fd() {
        Header::new_fd(id, len, false, true)
    } else {
        Header::new(id, len, false)
    };
    FdFrame::new(header, frame.payload()).ok()
}

impl embedded_can::nb::Can for FdcanPort {
    type Frame = CanFrame;
    type Error = PortError;

    fn transmit(&mut self, frame: &CanFrame) -> nb::Result<Option<CanFrame>, PortError> {
        if self.off_bus {
            self.dropped = self.dropped.wrapping_add(1);
            return Ok(None);
        }
        let out = to_driver(frame).ok_or(nb::Error::Other(PortError::FrameRejected))?;
        self.writer
            .try_write(out)
            .map_err(|_| nb::Error::Other(PortError::TransmitBufferFull))?;
        Ok(None)
    }

    fn receive(&mut self) -> nb::Result<CanFrame, PortError> {
        if let Some(f) = self.waited.take() {
            return Ok(f);
        }
        loop {
            match self.reader.try_receive() {
                Err(_empty) => return Err(nb::Error::WouldBlock),
                Ok(Err(e)) => return Err(nb::Error::Other(PortError::Bus(e))),
                Ok(Ok(envelope)) => match to_protocol(&envelope.frame) {
                    Some(f) => return Ok(f),
                    None => self.foreign = self.foreign.wrapping_add(1),
                },
            }
        }
    }
}
