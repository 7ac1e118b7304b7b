//! [`RecordingPort`]: records a port's traffic (both directions) as a candump log.

use std::io::Write;
use std::time::Duration;

use super::ReceiveTimeout;
use crate::candump::Recorder;
use crate::error::{Error, Result};
use crate::frame::CanFrame;

/// Wraps a port; every frame transmitted or received is appended to the log with the
/// timestamp the caller's clock returns (microseconds).
#[derive(Debug)]
pub struct RecordingPort<P, W: Write, C: FnMut() -> u64> {
    port: P,
    recorder: Recorder<W>,
    clock: C,
}

impl<P, W: Write, C: FnMut() -> u64> RecordingPort<P, W, C> {
    /// Records `port`'s traffic into `out` under interface name `iface`.
    pub fn new(port: P, out: W, iface: &str, clock: C) -> Self {
        RecordingPort {
            port,
            recorder: Recorder::new(out, iface),
            clock,
        }
    }

    fn log(&mut self, frame: &CanFrame) -> Result<()> {
        let t = (self.clock)();
        self.recorder.record(t, frame)
    }

    /// The port it records.
    pub fn port(&self) -> &P {
        &self.port
    }

    /// Unwraps into the port and the flushed writer.
    pub fn into_parts(self) -> Result<(P, W)> {
        Ok((self.port, self.recorder.into_inner()?))
    }
}

impl<P, W, C> embedded_can::blocking::Can for RecordingPort<P, W, C>
where
    P: embedded_can::blocking::Can<Frame = CanFrame, Error = Error>,
    W: Write,
    C: FnMut() -> u64,
{
    type Frame = CanFrame;
    type Error = Error;

    fn transmit(&mut self, frame: &CanFrame) -> Result<()> {
        self.port.transmit(frame)?;
        self.log(frame)
    }

    fn receive(&mut self) -> Result<CanFrame> {
        let f = self.port.receive()?;
        self.log(&f)?;
        Ok(f)
    }
}

impl<P, W, C> embedded_can::nb::Can for RecordingPort<P, W, C>
where
    P: embedded_can::nb::Can<Frame = CanFrame, Error = Error>,
    W: Write,
    C: FnMut() -> u64,
{
    type Frame = CanFrame;
    type Error = Error;

    fn transmit(&mut self, frame: &CanFrame) -> nb::Result<Option<CanFrame>, Error> {
        let r = self.port.transmit(frame)?;
        self.log(frame).map_err(nb::Error::Other)?;
        Ok(r)
    }

    fn receive(&mut self) -> nb::Result<CanFrame, Error> {
        let f = self.port.receive()?;
        self.log(&f).map_err(nb::Error::Other)?;
        Ok(f)
    }
}

impl<P, W, C> ReceiveTimeout for RecordingPort<P, W, C>
where
    P: ReceiveTimeout,
    W: Write,
    C: FnMut() -> u64,
{
    fn receive_timeout(&mut self, timeout: Duration) -> Result<Option<CanFrame>> {
        let f = self.port.receive_timeout(timeout)?;
        if let Some(f) = &f {
            self.log(f)?;
        }
        Ok(f)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bus::InProcBus;
    use crate::candump::{read_log, replay};
    use crate::envelope::BusMode;
    use embedded_can::blocking::Can;

    #[test]
    fn record_then_replay_reproduces_the_traffic() {
        let bus = InProcBus::new(BusMode::Fd, 0);
        let mut t = 1_700_000_000_000_000u64;
        let mut rec = RecordingPort::new(bus.port(), Vec::new(), "vcan0", move || {
            t += 1000;
            t
        });
        let mut other = bus.port();
        let sent = [
            CanFrame::classic(0x082, &[1, 0, 0, 8]).unwrap(),
            CanFrame::fd(0x111, &[7; 48]).unwrap(),
        ];
        for f in &sent {
            rec.transmit(f).unwrap();
        }
        other.transmit(&sent[0]).unwrap();
        assert_eq!(rec.receive().unwrap(), sent[0]);
        let (_, log) = rec.into_parts().unwrap();
        let text = String::from_utf8(log).unwrap();
        assert_eq!(text.lines().count(), 3);
        assert!(text.starts_with("(1700000000.001000) vcan0 082#01000008\n"));
        let records = read_log(text.as_bytes()).unwrap();
        assert_eq!(records[1].frame, sent[1]);

        // Replay into a fresh bus: a listener sees the same frames.
        let bus2 = InProcBus::new(BusMode::Fd, 0);
        let mut player = bus2.port();
        let mut listener = bus2.port();
        assert_eq!(replay(text.as_bytes(), &mut player).unwrap(), 3);
        for r in &records {
            assert_eq!(listener.try_receive(), Some(r.frame));
        }
    }
}
