//! The candump log format (`candump -l`, read by `canplayer`, cantools, SavvyCAN):
//!
//! ```text
//! (1700000000.123456) vcan0 123#DEADBEEF
//! (1700000000.123457) vcan0 123##0DEADBEEF00000000
//! ```
//!
//! Classical frames are `iii#data`, FD frames `iii##Fdata` where `F` is the FD flags
//! nibble (bit 0 = BRS). Formatting and parsing are no_std; [`Recorder`] and [`replay`]
//! (feature `std`) work with files and ports.

use core::fmt;

use crate::error::{Error, Result};
use crate::frame::CanFrame;

/// One log line.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Record {
    /// Timestamp, microseconds since the Unix epoch (or any epoch the recorder chose).
    pub timestamp_us: u64,
    /// Interface name, e.g. `vcan0`.
    pub iface: heapless::String<16>,
    /// The frame.
    pub frame: CanFrame,
}

/// Writes one line (without newline) for `frame`.
///
/// ```
/// use trn_protocol::{candump, CanFrame};
/// let mut s = String::new();
/// let f = CanFrame::classic(0x123, &[0xDE, 0xAD, 0xBE, 0xEF])?;
/// candump::write_line(&mut s, 1_700_000_000_123_456, "vcan0", &f).unwrap();
/// assert_eq!(s, "(1700000000.123456) vcan0 123#DEADBEEF");
/// assert_eq!(candump::parse_line(&s)?.frame, f);
/// # Ok::<(), trn_protocol::Error>(())
/// ```
pub fn write_line<W: fmt::Write>(
    w: &mut W,
    timestamp_us: u64,
    iface: &str,
    frame: &CanFrame,
) -> fmt::Result {
    write!(
        w,
        "({}.{:06}) {} {:03X}#",
        timestamp_us / 1_000_000,
        timestamp_us % 1_000_000,
        iface,
        frame.raw_id()
    )?;
    if frame.is_fd() {
        w.write_str("#0")?;
    }
    for b in frame.payload() {
        write!(w, "{b:02X}")?;
    }
    Ok(())
}

fn hex(c: u8) -> Result<u8> {
    match c {
        b'0'..=b'9' => Ok(c - b'0'),
        b'a'..=b'f' => Ok(c - b'a' + 10),
        b'A'..=b'F' => Ok(c - b'A' + 10),
        _ => Err(Error::CandumpSyntax),
    }
}

/// Parses one line (surrounding whitespace ignored). Extended ids, remote and error
/// frames are rejected with [`Error::CandumpSyntax`] / [`Error::InvalidId`].
pub fn parse_line(line: &str) -> Result<Record> {
    let line = line.trim();
    let rest = line.strip_prefix('(').ok_or(Error::CandumpSyntax)?;
    let (ts, rest) = rest.split_once(')').ok_or(Error::CandumpSyntax)?;
    let (secs, frac) = ts.split_once('.').ok_or(Error::CandumpSyntax)?;
    if secs.is_empty() || frac.len() != 6 {
        return Err(Error::CandumpSyntax);
    }
    let secs: u64 = parse_dec(secs)?;
    let micros: u64 = parse_dec(frac)?;
    let timestamp_us = secs
        .checked_mul(1_000_000)
        .and_then(|s| s.checked_add(micros))
        .ok_or(Error::CandumpSyntax)?;
    let mut parts = rest.split_ascii_whitespace();
    let iface = parts.next().ok_or(Error::CandumpSyntax)?;
    let body = parts.next().ok_or(Error::CandumpSyntax)?;
    if parts.next().is_some() {
        return Err(Error::CandumpSyntax);
    }
    let iface = heapless::String::try_from(iface).map_err(|_| Error::CandumpSyntax)?;
    let (id, data) = body.split_once('#').ok_or(Error::CandumpSyntax)?;
    if id.len() != 3 {
        // 8 hex digits would be an extended id, which the protocol does not use.
        return Err(Error::CandumpSyntax);
    }
    let mut raw_id = 0u32;
    for c in id.bytes() {
        raw_id = raw_id << 4 | hex(c)? as u32;
    }
    if raw_id > 0x7FF {
        return Err(Error::InvalidId(raw_id));
    }
    let (fd, data) = match data.strip_prefix('#') {
        Some(d) => {
            let flags = d.bytes().next().ok_or(Error::CandumpSyntax)?;
            hex(flags)?;
            (true, &d[1..])
        }
        None => (false, data),
    };
    let bytes = data.as_bytes();
    if bytes.len() % 2 != 0 || bytes.len() > 128 {
        return Err(Error::CandumpSyntax);
    }
    let mut buf = [0u8; 64];
    for (i, pair) in bytes.chunks(2).enumerate() {
        buf[i] = hex(pair[0])? << 4 | hex(pair[1])?;
    }
    let frame = CanFrame::new_checked(raw_id as u16, &buf[..bytes.len() / 2], fd)?;
    Ok(Record {
        timestamp_us,
        iface,
        frame,
    })
}

fn parse_dec(s: &str) -> Result<u64> {
    if s.is_empty() || !s.bytes().all(|c| c.is_ascii_digit()) {
        return Err(Error::CandumpSyntax);
    }
    s.parse().map_err(|_| Error::CandumpSyntax)
}

/// A fixed-capacity line buffer (no_std formatting target).
pub type Line = heapless::String<200>;

/// Formats one line into a [`Line`].
pub fn format_line(timestamp_us: u64, iface: &str, frame: &CanFrame) -> Result<Line> {
    let mut s = Line::new();
    write_line(&mut s, timestamp_us, iface, frame).map_err(|_| Error::Encode)?;
    Ok(s)
}

#[cfg(feature = "std")]
mod io {
    use std::io::{BufRead, Write};

    #[cfg(not(all(feature = "socketcan", target_os = "linux")))]
    use super::parse_line;
    use super::{write_line, Record};
    use crate::error::{Error, Result};
    use crate::frame::CanFrame;

    /// Writes frames to a candump log with caller-supplied timestamps.
    #[derive(Debug)]
    pub struct Recorder<W: Write> {
        out: W,
        iface: String,
        lines: u64,
    }

    impl<W: Write> Recorder<W> {
        /// Records to `out` under interface name `iface`.
        pub fn new(out: W, iface: &str) -> Self {
            Recorder {
                out,
                iface: iface.to_owned(),
                lines: 0,
            }
        }

        /// Appends one frame at `timestamp_us`.
        pub fn record(&mut self, timestamp_us: u64, frame: &CanFrame) -> Result<()> {
            let mut s = String::new();
            write_line(&mut s, timestamp_us, &self.iface, frame).map_err(|_| Error::Encode)?;
            s.push('\n');
            self.out.write_all(s.as_bytes())?;
            self.lines += 1;
            Ok(())
        }

        /// Lines written so far.
        pub fn lines(&self) -> u64 {
            self.lines
        }

        /// Flushes and returns the writer.
        pub fn into_inner(mut self) -> Result<W> {
            self.out.flush()?;
            Ok(self.out)
        }
    }

    /// Reads every record of a log (blank lines skipped); stops at the first bad line. With
    /// the `socketcan` feature on Linux each line is parsed by the socketcan crate's
    /// can-utils parser (`socketcan::dump`), otherwise by [`parse_line`].
    pub fn read_log<R: BufRead>(input: R) -> Result<Vec<Record>> {
        let mut out = Vec::new();
        for line in input.lines() {
            let line = line?;
            if line.trim().is_empty() {
                continue;
            }
            out.push(read_line(&line)?);
        }
        Ok(out)
    }

    #[cfg(all(feature = "socketcan", target_os = "linux"))]
    fn read_line(line: &str) -> Result<Record> {
        super::can_utils::parse(line)
    }

    #[cfg(not(all(feature = "socketcan", target_os = "linux")))]
    fn read_line(line: &str) -> Result<Record> {
        parse_line(line)
    }

    /// Replays a log into a port (as fast as the port accepts), returning the number of
    /// frames sent.
    pub fn replay<R, P>(input: R, port: &mut P) -> Result<usize>
    where
        R: BufRead,
        P: embedded_can::blocking::Can<Frame = CanFrame, Error = Error>,
    {
        let records = read_log(input)?;
        for r in &records {
            port.transmit(&r.frame)?;
        }
        Ok(records.len())
    }
}

#[cfg(feature = "std")]
pub use io::{read_log, replay, Recorder};

/// can-utils logs through the socketcan crate's parser (`socketcan::dump`), which follows
/// can-utils itself; frames the protocol does not use (extended ids, remote and error frames)
/// are rejected. The hand-written [`parse_line`] stays for what that parser cannot serve:
/// `no_std` builds (the fuzz target, a logger on the MCU) and hosts other than Linux (the
/// socketcan crate builds on Linux only); a test checks that both read the same log alike.
#[cfg(all(feature = "socketcan", target_os = "linux"))]
pub mod can_utils {
    use socketcan::dump::Reader;
    use socketcan::{CanAnyFrame, EmbeddedFrame, Id};

    use super::Record;
    use crate::error::{Error, Result};
    use crate::frame::CanFrame;

    /// Parses one log line with `socketcan::dump`.
    pub fn parse(line: &str) -> Result<Record> {
        let rec = Reader::from_reader(line.as_bytes())
            .next_record()
            .map_err(|_| Error::CandumpSyntax)?
            .ok_or(Error::CandumpSyntax)?;
        let (id, data, fd) = match &rec.frame {
            CanAnyFrame::Normal(f) => (f.id(), f.data(), false),
            CanAnyFrame::Fd(f) => (f.id(), f.data(), true),
            CanAnyFrame::Remote(_) | CanAnyFrame::Error(_) => return Err(Error::CandumpSyntax),
        };
        let Id::Standard(id) = id else {
            return Err(Error::CandumpSyntax);
        };
        let iface =
            heapless::String::try_from(rec.device.as_str()).map_err(|_| Error::CandumpSyntax)?;
        Ok(Record {
            timestamp_us: rec.t_us,
            iface,
            frame: CanFrame::new_checked(id.as_raw(), data, fd)?,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn classic_and_fd_round_trip() {
        let c = CanFrame::classic(0x7FF, &[]).unwrap();
        let l = format_line(5, "vcan0", &c).unwrap();
        assert_eq!(l.as_str(), "(0.000005) vcan0 7FF#");
        assert_eq!(parse_line(&l).unwrap().frame, c);
        let f = CanFrame::fd(0x211, &[0xAB; 12]).unwrap();
        let l = format_line(1_700_000_000_000_001, "can0", &f).unwrap();
        assert_eq!(
            l.as_str(),
            "(1700000000.000001) can0 211##0ABABABABABABABABABABABAB"
        );
        let r = parse_line(&l).unwrap();
        assert_eq!(r.frame, f);
        assert_eq!(r.timestamp_us, 1_700_000_000_000_001);
        assert_eq!(r.iface.as_str(), "can0");
    }

    #[cfg(all(feature = "socketcan", target_os = "linux"))]
    #[test]
    fn socketcan_and_the_hand_written_parser_read_logs_alike() {
        let good = [
            "(1700000000.123456) vcan0 123#DEADBEEF",
            "(0.000005) vcan0 7FF#",
            "(1700000000.000001) can0 211##0ABABABABABABABABABABABAB",
            "(1700000000.000002) can0 211##1ABABABABABABABABABABABAB",
        ];
        for l in good {
            assert_eq!(can_utils::parse(l).unwrap(), parse_line(l).unwrap(), "{l}");
        }
        for bad in [
            "(1.000000) vcan0 12345678#00",
            "(1.000000) vcan0 123#R",
            "(1.5) vcan0 123#00",
            "(1.000000) vcan0",
            "(1.000000) vcan0 123#001122334455667788",
        ] {
            assert!(can_utils::parse(bad).is_err(), "{bad}");
            assert!(parse_line(bad).is_err(), "{bad}");
        }
    }

    #[test]
    fn rejects_garbage() {
        for bad in [
            "",
            "(1.5) vcan0 123#00",
            "(1.000000) vcan0 123#0",
            "(1.000000) vcan0 12345678#00",
            "(1.000000) vcan0 800#00",
            "(1.000000) vcan0 123#R",
            "(1.000000) vcan0 123#001122334455667788",
            "(1.000000) vcan0 123##0001122334455667788",
            "(1.000000) vcan0",
            "(x.000000) vcan0 123#00",
            "(1.000000) vcan0 123#00 extra",
        ] {
            assert!(parse_line(bad).is_err(), "{bad}");
        }
    }
}
