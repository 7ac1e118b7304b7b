//! SLCAN (the Lawicel ASCII format of USB-CAN adapters and Linux `slcand`): CAN frames as
//! text lines, used to carry the bus over a UART to the firmware in QEMU.
//!
//! Classical frames: `tIIIL<data>\r` (`III` 3 hex digits of the 11-bit id, `L` the length
//! 0..8, two hex digits a byte). CAN FD frames (the common `d` extension): `dIIIC<data>\r`
//! with `C` the FD length code 0..F.

use crate::error::{Error, Result};
use crate::frame::{CanFrame, FD_MAX};

/// Longest line: `d`, 3 id digits, the length code, 64 bytes as 128 digits, `\r`.
pub const MAX_LINE: usize = 1 + 3 + 1 + 2 * FD_MAX + 1;

const HEX: &[u8; 16] = b"0123456789ABCDEF";
const FD_LENS: [usize; 16] = [0, 1, 2, 3, 4, 5, 6, 7, 8, 12, 16, 20, 24, 32, 48, 64];

fn hex(c: u8) -> Result<u8> {
    match c {
        b'0'..=b'9' => Ok(c - b'0'),
        b'a'..=b'f' => Ok(c - b'a' + 10),
        b'A'..=b'F' => Ok(c - b'A' + 10),
        _ => Err(Error::FrameFormat),
    }
}

/// Writes `frame` as one SLCAN line (with the trailing `\r`) into `out`; returns its length.
pub fn encode(frame: &CanFrame, out: &mut [u8; MAX_LINE]) -> usize {
    let data = frame.payload();
    let id = frame.raw_id();
    out[0] = if frame.is_fd() { b'd' } else { b't' };
    out[1] = HEX[((id >> 8) & 0xF) as usize];
    out[2] = HEX[((id >> 4) & 0xF) as usize];
    out[3] = HEX[(id & 0xF) as usize];
    let code = FD_LENS.iter().position(|&l| l == data.len()).unwrap_or(0);
    out[4] = HEX[code];
    let mut n = 5;
    for b in data {
        out[n] = HEX[(b >> 4) as usize];
        out[n + 1] = HEX[(b & 0xF) as usize];
        n += 2;
    }
    out[n] = b'\r';
    n + 1
}

/// Parses one SLCAN line (without or with its trailing `\r`).
pub fn decode(line: &[u8]) -> Result<CanFrame> {
    let line = match line.last() {
        Some(b'\r') => &line[..line.len() - 1],
        _ => line,
    };
    if line.len() < 5 {
        return Err(Error::FrameFormat);
    }
    let fd = match line[0] {
        b't' => false,
        b'd' => true,
        _ => return Err(Error::FrameFormat),
    };
    let id = ((hex(line[1])? as u16) << 8) | ((hex(line[2])? as u16) << 4) | hex(line[3])? as u16;
    let code = hex(line[4])? as usize;
    let len = if fd { FD_LENS[code] } else { code };
    if !fd && len > 8 {
        return Err(Error::FrameFormat);
    }
    let digits = &line[5..];
    if digits.len() != 2 * len {
        return Err(Error::InvalidFrameLength(digits.len() / 2));
    }
    let mut data = [0u8; FD_MAX];
    for i in 0..len {
        data[i] = (hex(digits[2 * i])? << 4) | hex(digits[2 * i + 1])?;
    }
    CanFrame::new_checked(id, &data[..len], fd)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn known_lines() {
        let f = CanFrame::classic(0x123, &[0xDE, 0xAD, 0xBE, 0xEF]).unwrap();
        let mut buf = [0u8; MAX_LINE];
        let n = encode(&f, &mut buf);
        assert_eq!(&buf[..n], b"t1234DEADBEEF\r");
        assert_eq!(decode(b"t1234deadbeef\r").unwrap(), f);
        assert_eq!(
            decode(b"t7000").unwrap(),
            CanFrame::classic(0x700, &[]).unwrap()
        );
    }

    #[test]
    fn bad_lines_are_errors() {
        for bad in [
            &b""[..],
            b"x1230",
            b"t12",
            b"t1239",
            b"t1232AB",
            b"t12G1AA",
            b"t1231AAB",
        ] {
            assert!(decode(bad).is_err(), "{:?}", core::str::from_utf8(bad));
        }
    }

    proptest! {
        #[test]
        fn round_trip(id in 0u16..0x800, data in prop::collection::vec(any::<u8>(), 0..=8), fd in any::<bool>()) {
            let f = if fd {
                let len = crate::fd_len_for(data.len()).unwrap();
                let mut d = data.clone();
                d.resize(len, 0);
                CanFrame::fd(id, &d).unwrap()
            } else {
                CanFrame::classic(id, &data).unwrap()
            };
            let mut buf = [0u8; MAX_LINE];
            let n = encode(&f, &mut buf);
            prop_assert_eq!(decode(&buf[..n]).unwrap(), f);
        }

        #[test]
        fn arbitrary_bytes_never_panic(line in prop::collection::vec(any::<u8>(), 0..140)) {
            let _ = decode(&line);
        }
    }
}
