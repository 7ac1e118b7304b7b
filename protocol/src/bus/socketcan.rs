//! [`SocketCanPort`]: Linux SocketCAN (vcan or hardware), classical and FD frames.

use std::time::Duration;

use embedded_can::{Frame as _, Id, StandardId};
use socketcan::{CanAddr, CanAnyFrame, CanDataFrame, CanFdFrame, CanFdSocket, Socket};

use super::ReceiveTimeout;
use crate::error::{Error, Result};
use crate::frame::CanFrame;

/// A raw CAN socket bound to one interface, with FD frames enabled. FD frames can only be
/// sent when the interface MTU is 72 (`ip link set vcan0 mtu 72`); otherwise the write
/// fails with an I/O error. Own frames are not received (like the in-process bus).
#[derive(Debug)]
pub struct SocketCanPort {
    socket: CanFdSocket,
    iface: String,
}

impl SocketCanPort {
    /// Opens `iface` (e.g. `vcan0`); [`Error::InterfaceNotFound`] if it does not exist.
    pub fn open(iface: &str) -> Result<SocketCanPort> {
        let name = || {
            let mut name = heapless::String::new();
            for c in iface.chars() {
                if name.push(c).is_err() {
                    break;
                }
            }
            name
        };
        let addr = CanAddr::from_iface(iface).map_err(|_| Error::InterfaceNotFound(name()))?;
        let socket = CanFdSocket::open_addr(&addr).map_err(|_| Error::NotCanInterface(name()))?;
        Ok(SocketCanPort {
            socket,
            iface: iface.to_owned(),
        })
    }

    /// The interface name.
    pub fn iface(&self) -> &str {
        &self.iface
    }

    fn write(&self, frame: &CanFrame) -> std::io::Result<()> {
        let id = Id::Standard(StandardId::new(frame.raw_id()).unwrap_or(StandardId::ZERO));
        let invalid = || std::io::Error::from(std::io::ErrorKind::InvalidInput);
        if frame.is_fd() {
            let f = CanFdFrame::new(id, frame.payload()).ok_or_else(invalid)?;
            self.socket.write_frame(&f)
        } else {
            let f = CanDataFrame::new(id, frame.payload()).ok_or_else(invalid)?;
            self.socket.write_frame(&f)
        }
    }

    fn convert(frame: CanAnyFrame) -> Result<CanFrame> {
        let (id, data, fd) = match &frame {
            CanAnyFrame::Normal(f) => (f.id(), f.data(), false),
            CanAnyFrame::Fd(f) => (f.id(), f.data(), true),
            // Remote and error frames are not part of the protocol.
            CanAnyFrame::Remote(_) | CanAnyFrame::Error(_) => return Err(Error::FrameFormat),
        };
        match id {
            Id::Standard(s) => CanFrame::new_checked(s.as_raw(), data, fd),
            Id::Extended(e) => Err(Error::InvalidId(e.as_raw())),
        }
    }

    fn read(&self, timeout: Duration) -> Result<Option<CanFrame>> {
        match self.socket.read_frame_timeout(timeout) {
            Ok(f) => Self::convert(f).map(Some),
            Err(e)
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::TimedOut | std::io::ErrorKind::WouldBlock
                ) =>
            {
                Ok(None)
            }
            Err(e) => Err(e.into()),
        }
    }
}

impl embedded_can::blocking::Can for SocketCanPort {
    type Frame = CanFrame;
    type Error = Error;

    fn transmit(&mut self, frame: &CanFrame) -> Result<()> {
        Ok(self.write(frame)?)
    }

    fn receive(&mut self) -> Result<CanFrame> {
        let f = self.socket.read_frame()?;
        Self::convert(f)
    }
}

impl embedded_can::nb::Can for SocketCanPort {
    type Frame = CanFrame;
    type Error = Error;

    fn transmit(&mut self, frame: &CanFrame) -> nb::Result<Option<CanFrame>, Error> {
        match self.write(frame) {
            Ok(()) => Ok(None),
            Err(e) if e.kind() == std::io::ErrorKind::WouldBlock => Err(nb::Error::WouldBlock),
            Err(e) => Err(nb::Error::Other(e.into())),
        }
    }

    fn receive(&mut self) -> nb::Result<CanFrame, Error> {
        match self.read(Duration::ZERO) {
            Ok(Some(f)) => Ok(f),
            Ok(None) => Err(nb::Error::WouldBlock),
            Err(e) => Err(nb::Error::Other(e)),
        }
    }
}

impl ReceiveTimeout for SocketCanPort {
    fn receive_timeout(&mut self, timeout: Duration) -> Result<Option<CanFrame>> {
        self.read(timeout)
    }
}
