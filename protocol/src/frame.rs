//! [`CanFrame`]: an 11-bit standard-id data frame, classical (≤ 8 bytes) or FD (≤ 64).

use core::fmt;

use embedded_can::{Id, StandardId};

use crate::error::{Error, Result};
use crate::id::MAX_STANDARD_ID;

/// Maximum classical CAN payload.
pub const CLASSIC_MAX: usize = 8;
/// Maximum CAN FD payload.
pub const FD_MAX: usize = 64;

/// The smallest valid CAN FD payload length ≥ `len` (0..=8, 12, 16, 20, 24, 32, 48, 64),
/// `None` if `len > 64`.
pub const fn fd_len_for(len: usize) -> Option<usize> {
    match len {
        0..=8 => Some(len),
        9..=12 => Some(12),
        13..=16 => Some(16),
        17..=20 => Some(20),
        21..=24 => Some(24),
        25..=32 => Some(32),
        33..=48 => Some(48),
        49..=64 => Some(64),
        _ => None,
    }
}

/// A CAN data frame with an 11-bit id. Remote and extended frames are not used by the
/// protocol and cannot be represented.
#[derive(Clone, Copy)]
pub struct CanFrame {
    id: u16,
    len: u8,
    fd: bool,
    data: [u8; FD_MAX],
}

impl CanFrame {
    /// A classical frame; `id ≤ 0x7FF`, `data.len() ≤ 8`.
    pub fn classic(id: u16, data: &[u8]) -> Result<CanFrame> {
        if data.len() > CLASSIC_MAX {
            return Err(Error::InvalidFrameLength(data.len()));
        }
        Self::build(id, data, false)
    }

    /// An FD frame; `id ≤ 0x7FF`, `data.len()` a valid FD length (see [`fd_len_for`]).
    pub fn fd(id: u16, data: &[u8]) -> Result<CanFrame> {
        if fd_len_for(data.len()) != Some(data.len()) {
            return Err(Error::InvalidFrameLength(data.len()));
        }
        Self::build(id, data, true)
    }

    /// A classical or FD frame.
    pub fn new_checked(id: u16, data: &[u8], fd: bool) -> Result<CanFrame> {
        if fd {
            Self::fd(id, data)
        } else {
            Self::classic(id, data)
        }
    }

    fn build(id: u16, data: &[u8], fd: bool) -> Result<CanFrame> {
        if id > MAX_STANDARD_ID {
            return Err(Error::InvalidId(id as u32));
        }
        let mut buf = [0u8; FD_MAX];
        buf[..data.len()].copy_from_slice(data);
        Ok(CanFrame {
            id,
            len: data.len() as u8,
            fd,
            data: buf,
        })
    }

    /// The raw 11-bit id.
    pub const fn raw_id(&self) -> u16 {
        self.id
    }

    /// The payload.
    pub fn payload(&self) -> &[u8] {
        &self.data[..self.len as usize]
    }

    /// Payload length in bytes.
    pub const fn len(&self) -> usize {
        self.len as usize
    }

    /// True if the payload is empty.
    pub const fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// True for a CAN FD frame.
    pub const fn is_fd(&self) -> bool {
        self.fd
    }
}

impl PartialEq for CanFrame {
    fn eq(&self, other: &Self) -> bool {
        self.id == other.id && self.fd == other.fd && self.payload() == other.payload()
    }
}
impl Eq for CanFrame {}

impl fmt::Debug for CanFrame {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "CanFrame({:03X}{}",
            self.id,
            if self.fd { "##" } else { "#" }
        )?;
        for b in self.payload() {
            write!(f, "{b:02X}")?;
        }
        write!(f, ")")
    }
}

/// Classical-frame view for `embedded-can`: `new` builds classical frames with standard
/// ids only; remote frames are not supported (`new_remote` returns `None`). For an FD
/// frame `dlc()` returns the payload length in bytes.
impl embedded_can::Frame for CanFrame {
    fn new(id: impl Into<Id>, data: &[u8]) -> Option<Self> {
        match id.into() {
            Id::Standard(s) => CanFrame::classic(s.as_raw(), data).ok(),
            Id::Extended(_) => None,
        }
    }

    fn new_remote(_id: impl Into<Id>, _dlc: usize) -> Option<Self> {
        None
    }

    fn is_extended(&self) -> bool {
        false
    }

    fn is_remote_frame(&self) -> bool {
        false
    }

    fn id(&self) -> Id {
        // `id` is validated ≤ 0x7FF on construction.
        Id::Standard(StandardId::new(self.id).unwrap_or(StandardId::ZERO))
    }

    fn dlc(&self) -> usize {
        self.len as usize
    }

    fn data(&self) -> &[u8] {
        self.payload()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use embedded_can::{ExtendedId, Frame};

    #[test]
    fn constructors_validate() {
        assert!(CanFrame::classic(0x7FF, &[1; 8]).is_ok());
        assert_eq!(CanFrame::classic(0x800, &[]), Err(Error::InvalidId(0x800)));
        assert_eq!(
            CanFrame::classic(1, &[0; 9]),
            Err(Error::InvalidFrameLength(9))
        );
        assert!(CanFrame::fd(1, &[0; 12]).is_ok());
        assert_eq!(
            CanFrame::fd(1, &[0; 13]),
            Err(Error::InvalidFrameLength(13))
        );
        assert_eq!(
            CanFrame::fd(1, &[0; 65]),
            Err(Error::InvalidFrameLength(65))
        );
    }

    #[test]
    fn embedded_can_view() {
        let f = <CanFrame as Frame>::new(StandardId::new(0x123).unwrap(), &[1, 2, 3]).unwrap();
        assert_eq!(f.id(), Id::Standard(StandardId::new(0x123).unwrap()));
        assert_eq!(f.dlc(), 3);
        assert_eq!(Frame::data(&f), &[1, 2, 3]);
        assert!(!f.is_extended() && !f.is_remote_frame() && !f.is_fd());
        assert!(<CanFrame as Frame>::new(ExtendedId::new(0x123).unwrap(), &[]).is_none());
        assert!(<CanFrame as Frame>::new_remote(StandardId::ZERO, 0).is_none());
    }

    #[test]
    fn fd_lengths() {
        assert_eq!(fd_len_for(9), Some(12));
        assert_eq!(fd_len_for(43), Some(48));
        assert_eq!(fd_len_for(64), Some(64));
        assert_eq!(fd_len_for(65), None);
    }
}
