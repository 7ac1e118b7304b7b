//! SLCAN (the Lawicel ASCII format of USB-CAN adapters and Linux `slcand`): CAN frames as
//! text lines, used to carry the bus over a UART to the firmware in QEMU and over the
//! serial device of a USB-CAN adapter.
//!
//! Classical frames: `tIIIL<data>\r` (`III` 3 hex digits of the 11-bit id, `L` the length
//! 0..8, two hex digits a byte). CAN FD frames (the common `d` extension): `dIIIC<data>\r`
//! with `C` the FD length code 0..F. protocol/SPEC.md has the whole line format.
//!
//! [`SlcanPort`] is an `embedded-can` port over any [`ByteLink`]: the firmware's UART, or a
//! host serial device.

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

/// Assembles SLCAN lines from a byte stream.
#[derive(Debug, Clone)]
pub struct LineDecoder {
    line: [u8; MAX_LINE],
    len: usize,
    overlong: bool,
}

impl Default for LineDecoder {
    fn default() -> Self {
        Self::new()
    }
}

impl LineDecoder {
    /// An empty decoder.
    pub const fn new() -> Self {
        LineDecoder {
            line: [0; MAX_LINE],
            len: 0,
            overlong: false,
        }
    }

    /// True when no partial line is waiting.
    pub fn is_empty(&self) -> bool {
        self.len == 0 && !self.overlong
    }

    /// Feeds one byte. At the end of a line (`\r` or `\n`) returns its frame, or the error
    /// of a malformed or overlong line; empty lines and the bytes within a line give `None`.
    pub fn push(&mut self, b: u8) -> Option<Result<CanFrame>> {
        if b == b'\r' || b == b'\n' {
            let (len, overlong) = (self.len, self.overlong);
            self.len = 0;
            self.overlong = false;
            return match (len, overlong) {
                (_, true) => Some(Err(Error::FrameFormat)),
                (0, false) => None,
                _ => Some(decode(&self.line[..len])),
            };
        }
        if self.len < MAX_LINE {
            self.line[self.len] = b;
            self.len += 1;
        } else {
            self.overlong = true;
        }
        None
    }
}

/// A byte link an SLCAN port runs over: a UART, a serial device.
pub trait ByteLink {
    /// A received byte, if one is waiting (never blocks).
    fn read_byte(&mut self) -> Result<Option<u8>>;
    /// Sends bytes (may wait while the link's transmit buffer is full).
    fn write_all(&mut self, bytes: &[u8]) -> Result<()>;
}

/// CAN frames as SLCAN lines over a [`ByteLink`], behind the `embedded-can` traits.
#[derive(Debug)]
pub struct SlcanPort<L> {
    link: L,
    dec: LineDecoder,
    bad_lines: u32,
}

impl<L: ByteLink> SlcanPort<L> {
    /// A port on `link`.
    pub const fn new(link: L) -> Self {
        SlcanPort {
            link,
            dec: LineDecoder::new(),
            bad_lines: 0,
        }
    }

    /// Lines that were not SLCAN frames (dropped).
    pub fn bad_lines(&self) -> u32 {
        self.bad_lines
    }

    /// The link.
    pub fn link_mut(&mut self) -> &mut L {
        &mut self.link
    }
}

impl<L: ByteLink> embedded_can::nb::Can for SlcanPort<L> {
    type Frame = CanFrame;
    type Error = Error;

    fn transmit(&mut self, frame: &CanFrame) -> nb::Result<Option<CanFrame>, Error> {
        let mut line = [0u8; MAX_LINE];
        let n = encode(frame, &mut line);
        self.link.write_all(&line[..n]).map_err(nb::Error::Other)?;
        Ok(None)
    }

    fn receive(&mut self) -> nb::Result<CanFrame, Error> {
        while let Some(b) = self.link.read_byte().map_err(nb::Error::Other)? {
            match self.dec.push(b) {
                Some(Ok(f)) => return Ok(f),
                Some(Err(_)) => self.bad_lines = self.bad_lines.saturating_add(1),
                None => {}
            }
        }
        Err(nb::Error::WouldBlock)
    }
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

    /// A link that replays bytes and records what is written.
    struct Loop {
        input: std::vec::Vec<u8>,
        output: std::vec::Vec<u8>,
    }

    impl ByteLink for Loop {
        fn read_byte(&mut self) -> Result<Option<u8>> {
            Ok(if self.input.is_empty() {
                None
            } else {
                Some(self.input.remove(0))
            })
        }
        fn write_all(&mut self, bytes: &[u8]) -> Result<()> {
            self.output.extend_from_slice(bytes);
            Ok(())
        }
    }

    #[test]
    fn a_port_over_a_byte_link_skips_bad_lines() {
        use embedded_can::nb::Can;
        let mut input = b"\r\nt1232ABCD\rxyz\r".to_vec();
        input.extend(std::iter::repeat_n(b'1', MAX_LINE + 5));
        input.extend(b"\rt7000\r");
        let mut port = SlcanPort::new(Loop {
            input,
            output: vec![],
        });
        assert_eq!(
            port.receive().unwrap(),
            CanFrame::classic(0x123, &[0xAB, 0xCD]).unwrap()
        );
        assert_eq!(
            port.receive().unwrap(),
            CanFrame::classic(0x700, &[]).unwrap()
        );
        assert_eq!(port.bad_lines(), 2, "`xyz` and the overlong line");
        assert!(matches!(port.receive(), Err(nb::Error::WouldBlock)));
        port.transmit(&CanFrame::classic(0x701, &[1, 2]).unwrap())
            .unwrap();
        assert_eq!(port.link_mut().output, b"t70120102\r");
    }

    proptest! {
        // a fixed seed: the same cases every run
        #![proptest_config(ProptestConfig {
            rng_seed: proptest::test_runner::RngSeed::Fixed(0x5ca1),
            ..ProptestConfig::default()
        })]
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
