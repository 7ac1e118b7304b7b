//! The bridge to the firmware in QEMU: CAN frames as SLCAN lines over the emulated UART,
//! which QEMU connects to a TCP socket of this process (`-serial tcp:127.0.0.1:PORT`).
//! `SlcanPort` is a port like the others (`embedded-can` + `ReceiveTimeout`), so the
//! simulator's session runs unchanged against the firmware.

use std::io::{ErrorKind, Read, Write};
use std::net::{TcpListener, TcpStream};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use trn_protocol::bus::ReceiveTimeout;
use trn_protocol::slcan::{self, MAX_LINE};
use trn_protocol::{CanFrame, Error};

fn io(e: std::io::Error) -> Error {
    Error::Io(e.kind())
}

/// A bus port whose other end is the firmware's UART.
#[derive(Debug)]
pub struct SlcanPort {
    stream: TcpStream,
    pending: Vec<u8>,
    /// Lines that did not parse as SLCAN (dropped).
    pub bad_lines: u64,
}

/// The repository root (for the default QEMU and firmware paths).
fn repo() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../..")
}

/// `$TRN_QEMU_ARM`, the copy `scripts/cross/install-toolchain.sh` unpacks, or the PATH's.
pub fn qemu_arm() -> PathBuf {
    if let Some(p) = std::env::var_os("TRN_QEMU_ARM") {
        return p.into();
    }
    let local = repo().join(".vm/qemu-arm/root/usr/bin/qemu-system-arm");
    if local.exists() {
        local
    } else {
        "qemu-system-arm".into()
    }
}

/// `$TRN_FIRMWARE`, or the PIL build of `scripts/cross/pil.sh`.
pub fn firmware_elf() -> PathBuf {
    match std::env::var_os("TRN_FIRMWARE") {
        Some(p) => p.into(),
        None => repo().join("firmware/target/elf/trn-firmware-pil"),
    }
}

impl SlcanPort {
    /// Starts QEMU (mps2-an386, Cortex-M4F) with `elf` and connects its UART0.
    pub fn spawn_qemu(qemu: &Path, elf: &Path) -> Result<(SlcanPort, Child), String> {
        if !elf.exists() {
            return Err(format!(
                "{} not found: build it with `bash scripts/cross/pil.sh --build-only`",
                elf.display()
            ));
        }
        let listener = TcpListener::bind("127.0.0.1:0").map_err(|e| e.to_string())?;
        let port = listener.local_addr().map_err(|e| e.to_string())?.port();
        let child = Command::new(qemu)
            .args([
                "-machine",
                "mps2-an386",
                "-cpu",
                "cortex-m4",
                "-nographic",
                "-monitor",
                "none",
            ])
            .args([
                "-semihosting-config",
                "enable=on,target=native",
                "-icount",
                "shift=0",
            ])
            .arg("-serial")
            .arg(format!("tcp:127.0.0.1:{port}"))
            .arg("-kernel")
            .arg(elf)
            .stdin(Stdio::null())
            .spawn()
            .map_err(|e| format!("cannot start {}: {e}", qemu.display()))?;
        listener.set_nonblocking(true).map_err(|e| e.to_string())?;
        let deadline = Instant::now() + Duration::from_secs(20);
        let stream = loop {
            match listener.accept() {
                Ok((s, _)) => break s,
                Err(e) if e.kind() == ErrorKind::WouldBlock && Instant::now() < deadline => {
                    std::thread::sleep(Duration::from_millis(10))
                }
                Err(e) => return Err(format!("QEMU did not connect its UART: {e}")),
            }
        };
        stream.set_nonblocking(false).map_err(|e| e.to_string())?;
        stream.set_nodelay(true).map_err(|e| e.to_string())?;
        Ok((
            SlcanPort {
                stream,
                pending: Vec::new(),
                bad_lines: 0,
            },
            child,
        ))
    }

    /// A complete line from the buffer, if there is one.
    fn take_line(&mut self) -> Option<CanFrame> {
        while let Some(end) = self.pending.iter().position(|&b| b == b'\r' || b == b'\n') {
            let line: Vec<u8> = self.pending.drain(..=end).collect();
            if line.len() <= 1 {
                continue;
            }
            match slcan::decode(&line) {
                Ok(f) => return Some(f),
                Err(_) => self.bad_lines += 1,
            }
        }
        None
    }
}

impl embedded_can::blocking::Can for SlcanPort {
    type Frame = CanFrame;
    type Error = Error;

    fn transmit(&mut self, frame: &CanFrame) -> Result<(), Error> {
        let mut line = [0u8; MAX_LINE];
        let n = slcan::encode(frame, &mut line);
        self.stream.write_all(&line[..n]).map_err(io)
    }

    fn receive(&mut self) -> Result<CanFrame, Error> {
        loop {
            if let Some(f) = self.receive_timeout(Duration::from_secs(3600))? {
                return Ok(f);
            }
        }
    }
}

impl ReceiveTimeout for SlcanPort {
    fn receive_timeout(&mut self, timeout: Duration) -> Result<Option<CanFrame>, Error> {
        let deadline = Instant::now() + timeout;
        loop {
            if let Some(f) = self.take_line() {
                return Ok(Some(f));
            }
            let left = deadline.saturating_duration_since(Instant::now());
            if left.is_zero() {
                return Ok(None);
            }
            self.stream
                .set_read_timeout(Some(left.max(Duration::from_millis(1))))
                .map_err(io)?;
            let mut buf = [0u8; 4096];
            match self.stream.read(&mut buf) {
                Ok(0) => return Err(Error::Io(ErrorKind::UnexpectedEof)),
                Ok(n) => self.pending.extend_from_slice(&buf[..n]),
                Err(e) if matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut) => {
                    return Ok(None)
                }
                Err(e) => return Err(io(e)),
            }
        }
    }
}
