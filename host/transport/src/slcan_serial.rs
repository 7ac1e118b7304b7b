//! SLCAN over a serial device: the USB-CAN adapters that speak the Lawicel format
//! (`--bus slcan:/dev/ttyACM0`), through the `serialport` crate. The adapter is opened at
//! 500 kbit/s (`C`, `S6`, `O`); frames are the lines of protocol/SPEC.md 4.6; the adapter's
//! acknowledgements (`z`, `Z`) and error bells are skipped.

use std::io::{ErrorKind, Read, Write};
use std::time::{Duration, Instant};

use serialport::SerialPort;
use trn_protocol::bus::ReceiveTimeout;
use trn_protocol::slcan::{self, LineDecoder, MAX_LINE};
use trn_protocol::{CanFrame, Error};

fn io(e: std::io::Error) -> Error {
    Error::Io(e.kind())
}

/// A bus port on a serial SLCAN adapter.
pub struct SerialSlcan {
    port: Box<dyn SerialPort>,
    dec: LineDecoder,
    pending: std::collections::VecDeque<CanFrame>,
    /// Lines that were neither frames nor acknowledgements (dropped).
    pub bad_lines: u64,
}

impl SerialSlcan {
    /// Opens the adapter at `path` and starts it at `bitrate` bit/s (one of
    /// [`SLCAN_BITRATES`]: the adapter's `Sn` command). The adapter's answers to `C`, `Sn`
    /// and `O` (an empty line, or a bell for a refused command) are not waited for: they
    /// arrive as lines and are skipped.
    pub fn open(path: &str, bitrate: u32) -> Result<SerialSlcan, String> {
        let code = slcan_bitrate_code(bitrate)?;
        let port = serialport::new(path, 115_200)
            .timeout(Duration::from_millis(50))
            .open()
            .map_err(|e| format!("{path}: {e}"))?;
        let mut s = SerialSlcan::on(port);
        // close (if it was open), the bit rate, open
        s.port
            .write_all(format!("C\rS{code}\rO\r").as_bytes())
            .map_err(|e| format!("{path}: {e}"))?;
        Ok(s)
    }

    /// A port on an already open serial port (tests: one end of a pseudo-terminal pair).
    pub fn on(port: Box<dyn SerialPort>) -> SerialSlcan {
        SerialSlcan {
            port,
            dec: LineDecoder::new(),
            pending: Default::default(),
            bad_lines: 0,
        }
    }

    fn feed(&mut self, bytes: &[u8]) {
        for &b in bytes {
            if b == 0x07 {
                // the adapter's error bell: a refused command
                self.bad_lines += 1;
                continue;
            }
            match self.dec.push(b) {
                Some(Ok(f)) => self.pending.push_back(f),
                Some(Err(_)) => self.bad_lines += 1,
                None => {}
            }
        }
    }
}

/// The CAN bit rates an SLCAN adapter's `Sn` command sets (n is the index).
pub const SLCAN_BITRATES: [u32; 9] = [
    10_000, 20_000, 50_000, 100_000, 125_000, 250_000, 500_000, 800_000, 1_000_000,
];

/// The `Sn` code of a bit rate.
pub fn slcan_bitrate_code(bitrate: u32) -> Result<usize, String> {
    SLCAN_BITRATES
        .iter()
        .position(|&b| b == bitrate)
        .ok_or_else(|| {
            format!("an SLCAN adapter runs at one of {SLCAN_BITRATES:?} bit/s, not {bitrate}")
        })
}

/// True for an adapter's acknowledgement of a transmitted frame (`z`, `Z`) or of a command
/// (an empty line): not a frame, not an error.
fn is_ack(line: &[u8]) -> bool {
    matches!(line, [b'z'] | [b'Z'])
}

impl embedded_can::blocking::Can for SerialSlcan {
    type Frame = CanFrame;
    type Error = Error;

    fn transmit(&mut self, frame: &CanFrame) -> Result<(), Error> {
        let mut line = [0u8; MAX_LINE];
        let n = slcan::encode(frame, &mut line);
        self.port.write_all(&line[..n]).map_err(io)
    }

    fn receive(&mut self) -> Result<CanFrame, Error> {
        loop {
            if let Some(f) = self.receive_timeout(Duration::from_secs(3600))? {
                return Ok(f);
            }
        }
    }
}

/// The same port seen through the non-blocking trait (a controller node's loop on a serial
/// adapter: [`crate::controller_loop::run`]): a receive takes what already arrived, waiting at
/// most a millisecond for the line.
impl embedded_can::nb::Can for SerialSlcan {
    type Frame = CanFrame;
    type Error = Error;

    fn transmit(&mut self, frame: &CanFrame) -> nb::Result<Option<CanFrame>, Error> {
        embedded_can::blocking::Can::transmit(self, frame).map_err(nb::Error::Other)?;
        Ok(None)
    }

    fn receive(&mut self) -> nb::Result<CanFrame, Error> {
        match self.receive_timeout(Duration::from_millis(1)) {
            Ok(Some(f)) => Ok(f),
            Ok(None) => Err(nb::Error::WouldBlock),
            Err(e) => Err(nb::Error::Other(e)),
        }
    }
}

impl ReceiveTimeout for SerialSlcan {
    fn receive_timeout(&mut self, timeout: Duration) -> Result<Option<CanFrame>, Error> {
        let deadline = Instant::now() + timeout;
        loop {
            if let Some(f) = self.pending.pop_front() {
                return Ok(Some(f));
            }
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                return Ok(None);
            }
            self.port
                .set_timeout(left.max(Duration::from_millis(1)))
                .map_err(|e| Error::Io(std::io::Error::from(e).kind()))?;
            let mut buf = [0u8; 512];
            match self.port.read(&mut buf) {
                Ok(0) => return Err(Error::Io(ErrorKind::UnexpectedEof)),
                Ok(n) => {
                    // acknowledgements are whole lines of their own: drop them before decoding
                    let bytes = &buf[..n];
                    let mut start = 0;
                    for (i, &b) in bytes.iter().enumerate() {
                        if b == b'\r' || b == b'\n' {
                            let line = &bytes[start..i];
                            if !(is_ack(line) && self.dec.is_empty()) {
                                self.feed(&bytes[start..=i]);
                            }
                            start = i + 1;
                        }
                    }
                    self.feed(&bytes[start..]);
                }
                Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => {
                    return Ok(None)
                }
                Err(e) => return Err(io(e)),
            }
        }
    }
}

/// A node served on one end of a pseudo-terminal pair, in a thread of its own, and the other
/// end's path for `--bus slcan:PATH`: a serial line without an adapter (tests, benchmarks).
#[cfg(unix)]
pub struct PtyPeer<T> {
    path: String,
    // the end the run opens by its path: kept open while the peer runs
    _ours: serialport::TTYPort,
    stop: std::sync::Arc<std::sync::atomic::AtomicBool>,
    thread: std::thread::JoinHandle<T>,
}

#[cfg(unix)]
impl<T: Send + 'static> PtyPeer<T> {
    /// Starts `serve` on one end (until the flag it is given is set) and keeps the other.
    pub fn spawn(
        serve: impl FnOnce(SerialSlcan, &std::sync::atomic::AtomicBool) -> T + Send + 'static,
    ) -> Result<PtyPeer<T>, String> {
        let (theirs, ours) =
            serialport::TTYPort::pair().map_err(|e| format!("a pseudo-terminal pair: {e}"))?;
        let path = ours.name().ok_or("the pseudo-terminal has no name")?;
        let stop = std::sync::Arc::new(std::sync::atomic::AtomicBool::new(false));
        let flag = stop.clone();
        let thread = std::thread::spawn(move || serve(SerialSlcan::on(Box::new(theirs)), &flag));
        Ok(PtyPeer {
            path,
            _ours: ours,
            stop,
            thread,
        })
    }

    /// The path of the end a run opens (`--bus slcan:PATH`).
    pub fn path(&self) -> &str {
        &self.path
    }

    /// Stops the peer and returns what `serve` returned (`Err`: it panicked).
    pub fn finish(self) -> std::thread::Result<T> {
        self.stop.store(true, std::sync::atomic::Ordering::Relaxed);
        self.thread.join()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use embedded_can::blocking::Can;
    use serialport::TTYPort;

    #[test]
    fn bit_rates_map_to_the_adapters_codes() {
        assert_eq!(slcan_bitrate_code(500_000), Ok(6));
        assert_eq!(slcan_bitrate_code(1_000_000), Ok(8));
        assert_eq!(slcan_bitrate_code(10_000), Ok(0));
        let e = slcan_bitrate_code(333_333).unwrap_err();
        assert!(e.contains("333333") && e.contains("500000"), "{e}");
    }

    /// Frames both ways over a pseudo-terminal pair: our port on one end, a fake adapter on
    /// the other. Fails if a line is malformed, an acknowledgement is taken for a frame or an
    /// error, or a frame is lost.
    #[test]
    fn frames_cross_a_pseudo_terminal_both_ways() {
        let (mut adapter, ours) = TTYPort::pair().expect("a pseudo-terminal pair");
        let mut port = SerialSlcan::on(Box::new(ours));
        let f = CanFrame::classic(0x123, &[0xAB, 0xCD]).unwrap();
        port.transmit(&f).unwrap();
        let mut buf = [0u8; 64];
        adapter.set_timeout(Duration::from_secs(2)).unwrap();
        let n = adapter.read(&mut buf).unwrap();
        assert_eq!(&buf[..n], b"t1232ABCD\r");
        // the adapter acknowledges, sends a classical and an FD frame, and a bad line
        adapter.write_all(b"z\rt7012017F\rd2819").unwrap();
        adapter.write_all(&[b'0'; 24]).unwrap();
        adapter.write_all(b"\rxyz\r").unwrap();
        let got = port.receive_timeout(Duration::from_secs(2)).unwrap();
        assert_eq!(got, Some(CanFrame::classic(0x701, &[0x01, 0x7F]).unwrap()));
        let got = port.receive_timeout(Duration::from_secs(2)).unwrap();
        assert_eq!(got, Some(CanFrame::fd(0x281, &[0u8; 12]).unwrap()));
        assert_eq!(
            port.receive_timeout(Duration::from_millis(200)).unwrap(),
            None
        );
        assert_eq!(port.bad_lines, 1, "`xyz` only: `z` is an acknowledgement");
    }

    #[test]
    fn a_missing_adapter_is_a_clear_error() {
        let e = SerialSlcan::open("/dev/nonexistent-adapter", 500_000)
            .err()
            .unwrap();
        assert!(e.contains("/dev/nonexistent-adapter"), "{e}");
    }
}
