//! [`FaultyPort`]: the in-process bus's fault injector in front of any port, for the buses
//! whose frames this process does not deliver itself (SocketCAN, serial SLCAN, QEMU): each
//! frame this node sends and each frame it receives meets the faults of a [`FaultConfig`],
//! seeded and counted per direction, so a lossy real bus can be had on demand.

use std::collections::VecDeque;
use std::time::{Duration, Instant};

use super::faults::{BusStats, FaultConfig, Injector};
use super::ReceiveTimeout;
use crate::error::{Error, Result};
use crate::frame::CanFrame;

/// Frames held back by a delay, each with the number of later frames on the bus (either way)
/// it still waits for.
#[derive(Debug, Default)]
struct Held(Vec<(CanFrame, u32)>);

impl Held {
    /// One more frame went by: the frames now due, in the order they were held.
    fn age(&mut self) -> Vec<CanFrame> {
        let mut due = Vec::new();
        self.0.retain_mut(|(frame, remaining)| {
            *remaining -= 1;
            if *remaining == 0 {
                due.push(*frame);
                false
            } else {
                true
            }
        });
        due
    }
}

/// A port whose traffic meets injected faults in both directions: what [`transmit`] is
/// given may be dropped, duplicated, corrupted, truncated or sent after later frames, and so
/// may each frame the port receives, with one seeded injector for both. A delayed frame
/// waits for later frames on the bus, either way, as on the in-process bus (a frame this node
/// holds back is not held for as long as the node stays quiet).
///
/// ```
/// use embedded_can::blocking::Can;
/// use trn_protocol::bus::{FaultConfig, FaultyPort, InProcBus};
/// use trn_protocol::{BusMode, CanFrame};
/// let bus = InProcBus::new(BusMode::Classic, 1);
/// let faults: FaultConfig = "drop=1".parse().unwrap();
/// let mut lossy = FaultyPort::new(bus.port(), faults, 7);
/// let mut other = bus.port();
/// lossy.transmit(&CanFrame::classic(0x701, &[0, 1])?)?;
/// assert_eq!(other.try_receive(), None);
/// assert_eq!(lossy.stats().0.dropped, 1);
/// # Ok::<(), trn_protocol::Error>(())
/// ```
///
/// [`transmit`]: embedded_can::blocking::Can::transmit
#[derive(Debug)]
pub struct FaultyPort<P> {
    port: P,
    faults: FaultConfig,
    inj: Injector,
    /// Received frames that passed the faults, in the order they are due.
    inbox: VecDeque<CanFrame>,
    held_out: Held,
    held_in: Held,
    out: BusStats,
    incoming: BusStats,
}

impl<P> FaultyPort<P> {
    /// `port` behind the faults `faults`, decided by an injector seeded with `seed`.
    pub fn new(port: P, faults: FaultConfig, seed: u64) -> FaultyPort<P> {
        FaultyPort {
            port,
            faults,
            inj: Injector::new(seed),
            inbox: VecDeque::new(),
            held_out: Held::default(),
            held_in: Held::default(),
            out: BusStats::default(),
            incoming: BusStats::default(),
        }
    }

    /// What the faults did to the frames this port sent and to those it received, in that
    /// order (`sent`: frames given to it or arriving; `delivered`: copies passed on).
    pub fn stats(&self) -> (BusStats, BusStats) {
        (self.out, self.incoming)
    }

    /// The port behind the faults.
    pub fn port(&self) -> &P {
        &self.port
    }

    /// Unwraps into the port (held frames are lost).
    pub fn into_inner(self) -> P {
        self.port
    }

    /// One more frame crossed the bus: the received frames now due go to the inbox; those
    /// this node held back and now sends are returned.
    fn crossed(&mut self) -> Vec<CanFrame> {
        for due in self.held_in.age() {
            self.inbox.push_back(due);
            self.incoming.delivered += 1;
        }
        self.held_out.age()
    }
}

impl<P> FaultyPort<P>
where
    P: embedded_can::blocking::Can<Frame = CanFrame, Error = Error>,
{
    fn send(&mut self, frame: &CanFrame) -> Result<()> {
        self.out.sent += 1;
        let fate = self.inj.fate(&self.faults, frame, &mut self.out);
        for (copy, delay) in fate.into_iter().flatten() {
            if delay > 0 {
                self.held_out.0.push((copy, delay));
            } else {
                self.port.transmit(&copy)?;
                self.out.delivered += 1;
            }
        }
        let due = self.crossed();
        self.send_due(due)
    }

    /// Sends the frames held back that are now due.
    fn send_due(&mut self, due: Vec<CanFrame>) -> Result<()> {
        for f in due {
            self.port.transmit(&f)?;
            self.out.delivered += 1;
        }
        Ok(())
    }

    /// A frame that arrived: through the faults into the inbox.
    fn arrived(&mut self, frame: &CanFrame) -> Result<()> {
        self.incoming.sent += 1;
        let fate = self.inj.fate(&self.faults, frame, &mut self.incoming);
        for (copy, delay) in fate.into_iter().flatten() {
            if delay > 0 {
                self.held_in.0.push((copy, delay));
            } else {
                self.inbox.push_back(copy);
                self.incoming.delivered += 1;
            }
        }
        let due = self.crossed();
        self.send_due(due)
    }
}

impl<P> embedded_can::blocking::Can for FaultyPort<P>
where
    P: embedded_can::blocking::Can<Frame = CanFrame, Error = Error> + ReceiveTimeout,
{
    type Frame = CanFrame;
    type Error = Error;

    fn transmit(&mut self, frame: &CanFrame) -> Result<()> {
        self.send(frame)
    }

    /// Blocks until a frame passes the faults.
    fn receive(&mut self) -> Result<CanFrame> {
        loop {
            if let Some(f) = self.receive_timeout(Duration::from_secs(3600))? {
                return Ok(f);
            }
        }
    }
}

impl<P> ReceiveTimeout for FaultyPort<P>
where
    P: embedded_can::blocking::Can<Frame = CanFrame, Error = Error> + ReceiveTimeout,
{
    fn receive_timeout(&mut self, timeout: Duration) -> Result<Option<CanFrame>> {
        let deadline = Instant::now() + timeout;
        loop {
            if let Some(f) = self.inbox.pop_front() {
                return Ok(Some(f));
            }
            let left = deadline.saturating_duration_since(Instant::now());
            match self.port.receive_timeout(left)? {
                Some(frame) => self.arrived(&frame)?,
                None => return Ok(None),
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bus::InProcBus;
    use crate::envelope::BusMode;
    use embedded_can::blocking::Can as _;

    fn f(id: u16, b: u8) -> CanFrame {
        CanFrame::classic(id, &[b]).unwrap()
    }

    /// Both directions lose about the configured share, the same frames for the same seed,
    /// and the counters add up. Fails if one direction is spared, if the seed is not the
    /// only source of the decisions, or if a counter misses a frame.
    #[test]
    fn both_directions_meet_the_faults_seeded_and_counted() {
        let run = |seed| {
            let bus = InProcBus::new(BusMode::Classic, 1);
            let faults: FaultConfig = "drop=0.2,dup=0.1".parse().unwrap();
            let mut lossy = FaultyPort::new(bus.port(), faults, seed);
            let mut other = bus.port();
            let mut got_there = Vec::new();
            let mut got_here = Vec::new();
            for i in 0..500u16 {
                lossy.transmit(&f(0x100 + (i % 256), i as u8)).unwrap();
                while let Some(x) = other.try_receive() {
                    got_there.push(x);
                }
                other.transmit(&f(0x200 + (i % 256), i as u8)).unwrap();
                while let Some(x) = lossy.receive_timeout(Duration::ZERO).unwrap() {
                    got_here.push(x);
                }
            }
            (got_there, got_here, lossy.stats())
        };
        let (there, here, (out, incoming)) = run(3);
        for (s, got) in [(out, there.len()), (incoming, here.len())] {
            assert_eq!(s.sent, 500);
            assert_eq!(s.delivered as usize, got);
            assert_eq!(s.sent - s.dropped + s.duplicated, s.delivered);
            assert!((70..=130).contains(&s.dropped), "{s:?}");
            assert!(s.duplicated > 20, "{s:?}");
        }
        let again = run(3);
        assert_eq!((again.0, again.1), (there.clone(), here.clone()));
        let other_seed = run(4);
        assert_ne!(other_seed.0, there);
    }

    /// A delayed frame is sent after the later frames it waits for, and a frame held back
    /// goes out when frames come the other way too. Fails if the order is kept, a held frame
    /// is lost, or a quiet node holds its frames until it sends again.
    #[test]
    fn a_delay_reorders_frames_and_loses_none() {
        let bus = InProcBus::new(BusMode::Classic, 1);
        let faults: FaultConfig = "reorder=0.5".parse().unwrap();
        let mut lossy = FaultyPort::new(bus.port(), faults, 9);
        let mut other = bus.port();
        for i in 0..200u16 {
            lossy.transmit(&f(0x100, i as u8)).unwrap();
        }
        let mut got = Vec::new();
        while let Some(x) = other.try_receive() {
            got.push(x.payload()[0]);
        }
        let held = lossy.held_out.0.len();
        assert_eq!(got.len() + held, 200);
        assert!(held <= 8);
        assert!(got.windows(2).any(|w| w[0] > w[1]), "nothing reordered");
        let (out, _) = lossy.stats();
        assert!(out.delayed > 50, "{out:?}");
        // the node goes quiet; frames from the other side release what it held
        for i in 0..8u16 {
            other.transmit(&f(0x300, i as u8)).unwrap();
            while lossy.receive_timeout(Duration::ZERO).unwrap().is_some() {}
        }
        assert!(lossy.held_out.0.is_empty());
        let mut late = 0;
        while other.try_receive().is_some() {
            late += 1;
        }
        assert_eq!(late, held);
    }
}
