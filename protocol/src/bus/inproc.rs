//! [`InProcBus`]: a deterministic in-process virtual CAN bus with fault injection.

use std::collections::VecDeque;
use std::sync::{Arc, Condvar, Mutex, MutexGuard};
use std::time::{Duration, Instant};

use super::faults::{BusStats, FaultConfig, Injector};
use super::ReceiveTimeout;
use crate::envelope::BusMode;
use crate::error::{Error, Result};
use crate::frame::CanFrame;

#[derive(Debug)]
struct PortState {
    queue: VecDeque<CanFrame>,
    alive: bool,
    faultless: bool,
}

#[derive(Debug)]
struct Delayed {
    port: usize,
    frame: CanFrame,
    remaining: u32,
}

#[derive(Debug)]
struct Inner {
    mode: BusMode,
    bus_off: bool,
    faults: FaultConfig,
    inj: Injector,
    ports: Vec<PortState>,
    delayed: Vec<Delayed>,
    stats: BusStats,
}

#[derive(Debug)]
struct Shared {
    inner: Mutex<Inner>,
    ready: Condvar,
}

/// A virtual CAN bus. Every frame sent by one port is delivered to every other port,
/// in FIFO order, unless a fault is injected. Cloning gives another handle to the same bus.
///
/// ```
/// use embedded_can::blocking::Can;
/// use trn_protocol::bus::InProcBus;
/// use trn_protocol::{BusMode, CanFrame};
/// let bus = InProcBus::new(BusMode::Classic, 1);
/// let mut a = bus.port();
/// let mut b = bus.port();
/// let f = CanFrame::classic(0x701, &[0, 1])?;
/// a.transmit(&f)?;
/// assert_eq!(b.receive()?, f);
/// # Ok::<(), trn_protocol::Error>(())
/// ```
#[derive(Debug, Clone)]
pub struct InProcBus {
    shared: Arc<Shared>,
}

/// One node's connection to an [`InProcBus`].
#[derive(Debug)]
pub struct InProcPort {
    shared: Arc<Shared>,
    index: usize,
}

impl InProcBus {
    /// A bus in `mode` (FD frames are refused on a classic bus); `seed` seeds the fault
    /// injector.
    pub fn new(mode: BusMode, seed: u64) -> InProcBus {
        InProcBus {
            shared: Arc::new(Shared {
                inner: Mutex::new(Inner {
                    mode,
                    bus_off: false,
                    faults: FaultConfig::default(),
                    inj: Injector::new(seed),
                    ports: Vec::new(),
                    delayed: Vec::new(),
                    stats: BusStats::default(),
                }),
                ready: Condvar::new(),
            }),
        }
    }

    fn lock(&self) -> MutexGuard<'_, Inner> {
        lock(&self.shared)
    }

    fn add_port(&self, faultless: bool) -> InProcPort {
        let mut inner = self.lock();
        inner.ports.push(PortState {
            queue: VecDeque::new(),
            alive: true,
            faultless,
        });
        InProcPort {
            shared: self.shared.clone(),
            index: inner.ports.len() - 1,
        }
    }

    /// Connects a new node.
    pub fn port(&self) -> InProcPort {
        self.add_port(false)
    }

    /// Connects a passive observer that sees every frame exactly as sent, never faulted
    /// (for recording the bus).
    pub fn tap(&self) -> InProcPort {
        self.add_port(true)
    }

    /// The bus mode.
    pub fn mode(&self) -> BusMode {
        self.lock().mode
    }

    /// Sets the fault probabilities.
    pub fn set_faults(&self, faults: FaultConfig) {
        self.lock().faults = faults;
    }

    /// Enters or leaves bus-off: while on, every transmit fails with [`Error::BusOff`].
    pub fn set_bus_off(&self, on: bool) {
        self.lock().bus_off = on;
    }

    /// Delivers every delayed frame now.
    pub fn flush_delayed(&self) {
        let mut inner = self.lock();
        let delayed = std::mem::take(&mut inner.delayed);
        for d in delayed {
            deliver(&mut inner, d.port, d.frame);
        }
        drop(inner);
        self.shared.ready.notify_all();
    }

    /// What the bus did so far.
    pub fn stats(&self) -> BusStats {
        self.lock().stats
    }
}

fn lock(shared: &Shared) -> MutexGuard<'_, Inner> {
    // A panic in another thread while holding the lock leaves consistent data.
    shared.inner.lock().unwrap_or_else(|e| e.into_inner())
}

fn deliver(inner: &mut Inner, port: usize, frame: CanFrame) {
    if let Some(p) = inner.ports.get_mut(port) {
        if p.alive {
            p.queue.push_back(frame);
            inner.stats.delivered += 1;
        }
    }
}

impl Inner {
    fn transmit_from(&mut self, from: usize, frame: &CanFrame) -> Result<()> {
        if self.bus_off {
            return Err(Error::BusOff);
        }
        if frame.is_fd() && self.mode != BusMode::Fd {
            return Err(Error::FrameFormat);
        }
        self.stats.sent += 1;
        let f = self.faults;
        for port in 0..self.ports.len() {
            if port == from || !self.ports[port].alive {
                continue;
            }
            if self.ports[port].faultless {
                deliver(self, port, *frame);
                continue;
            }
            for (copy, remaining) in self
                .inj
                .fate(&f, frame, &mut self.stats)
                .into_iter()
                .flatten()
            {
                if remaining > 0 {
                    self.delayed.push(Delayed {
                        port,
                        frame: copy,
                        remaining,
                    });
                } else {
                    deliver(self, port, copy);
                }
            }
        }
        // Frames delayed earlier move one step; those due are delivered after this one.
        let mut due = Vec::new();
        self.delayed.retain_mut(|d| {
            if d.port == from {
                return true;
            }
            d.remaining -= 1;
            if d.remaining == 0 {
                due.push((d.port, d.frame));
                false
            } else {
                true
            }
        });
        for (port, frame) in due {
            deliver(self, port, frame);
        }
        Ok(())
    }
}

impl InProcPort {
    fn lock(&self) -> MutexGuard<'_, Inner> {
        lock(&self.shared)
    }

    fn send(&mut self, frame: &CanFrame) -> Result<()> {
        self.lock().transmit_from(self.index, frame)?;
        self.shared.ready.notify_all();
        Ok(())
    }

    /// Frames waiting in this port's receive queue.
    pub fn pending(&self) -> usize {
        self.lock().ports[self.index].queue.len()
    }

    /// Takes the next frame without blocking (`Ok(None)` when the queue is empty).
    pub fn try_receive(&mut self) -> Option<CanFrame> {
        self.lock().ports[self.index].queue.pop_front()
    }
}

impl Drop for InProcPort {
    fn drop(&mut self) {
        let mut inner = self.lock();
        let p = &mut inner.ports[self.index];
        p.alive = false;
        p.queue.clear();
    }
}

impl embedded_can::nb::Can for InProcPort {
    type Frame = CanFrame;
    type Error = Error;

    fn transmit(&mut self, frame: &CanFrame) -> nb::Result<Option<CanFrame>, Error> {
        self.send(frame).map_err(nb::Error::Other)?;
        Ok(None)
    }

    fn receive(&mut self) -> nb::Result<CanFrame, Error> {
        self.try_receive().ok_or(nb::Error::WouldBlock)
    }
}

impl embedded_can::blocking::Can for InProcPort {
    type Frame = CanFrame;
    type Error = Error;

    fn transmit(&mut self, frame: &CanFrame) -> Result<()> {
        self.send(frame)
    }

    /// Blocks until a frame arrives.
    fn receive(&mut self) -> Result<CanFrame> {
        let mut inner = self.lock();
        loop {
            if let Some(f) = inner.ports[self.index].queue.pop_front() {
                return Ok(f);
            }
            inner = self
                .shared
                .ready
                .wait(inner)
                .unwrap_or_else(|e| e.into_inner());
        }
    }
}

impl ReceiveTimeout for InProcPort {
    fn receive_timeout(&mut self, timeout: Duration) -> Result<Option<CanFrame>> {
        let deadline = Instant::now() + timeout;
        let mut inner = self.lock();
        loop {
            if let Some(f) = inner.ports[self.index].queue.pop_front() {
                return Ok(Some(f));
            }
            let now = Instant::now();
            if now >= deadline {
                return Ok(None);
            }
            inner = self
                .shared
                .ready
                .wait_timeout(inner, deadline - now)
                .unwrap_or_else(|e| e.into_inner())
                .0;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::super::faults::CorruptScope;
    use super::*;
    use embedded_can::blocking::Can as _;

    fn f(id: u16, b: u8) -> CanFrame {
        CanFrame::classic(id, &[b]).unwrap()
    }

    #[test]
    fn every_other_port_gets_every_frame_in_order() {
        let bus = InProcBus::new(BusMode::Classic, 0);
        let mut a = bus.port();
        let mut b = bus.port();
        let mut c = bus.port();
        for i in 0..10 {
            a.transmit(&f(0x100, i)).unwrap();
        }
        b.transmit(&f(0x200, 0)).unwrap();
        assert_eq!(a.pending(), 1);
        for i in 0..10 {
            assert_eq!(embedded_can::nb::Can::receive(&mut b).unwrap(), f(0x100, i));
            assert_eq!(embedded_can::nb::Can::receive(&mut c).unwrap(), f(0x100, i));
        }
        assert_eq!(embedded_can::nb::Can::receive(&mut c).unwrap(), f(0x200, 0));
        assert!(matches!(
            embedded_can::nb::Can::receive(&mut b),
            Err(nb::Error::WouldBlock)
        ));
    }

    #[test]
    fn fd_frames_need_an_fd_bus_and_bus_off_blocks() {
        let bus = InProcBus::new(BusMode::Classic, 0);
        let mut a = bus.port();
        let fd = CanFrame::fd(0x100, &[0; 12]).unwrap();
        assert_eq!(a.transmit(&fd), Err(Error::FrameFormat));
        bus.set_bus_off(true);
        assert_eq!(a.transmit(&f(1, 1)), Err(Error::BusOff));
        bus.set_bus_off(false);
        assert!(a.transmit(&f(1, 1)).is_ok());
        let fdbus = InProcBus::new(BusMode::Fd, 0);
        let mut x = fdbus.port();
        let mut y = fdbus.port();
        x.transmit(&fd).unwrap();
        assert_eq!(y.receive().unwrap(), fd);
    }

    #[test]
    fn receive_timeout_times_out_and_wakes_up() {
        let bus = InProcBus::new(BusMode::Classic, 0);
        let mut a = bus.port();
        let mut b = bus.port();
        assert_eq!(b.receive_timeout(Duration::from_millis(20)).unwrap(), None);
        let t = std::thread::spawn(move || {
            std::thread::sleep(Duration::from_millis(20));
            a.transmit(&f(0x10, 7)).unwrap();
            a
        });
        assert_eq!(
            b.receive_timeout(Duration::from_secs(5)).unwrap(),
            Some(f(0x10, 7))
        );
        t.join().unwrap();
    }

    #[test]
    fn faults_are_seeded_and_counted() {
        let run = |seed| {
            let bus = InProcBus::new(BusMode::Classic, seed);
            bus.set_faults(FaultConfig {
                drop: 0.1,
                duplicate: 0.1,
                corrupt: 0.1,
                truncate: 0.1,
                delay: 0.1,
                max_delay_frames: 3,
                corrupt_scope: CorruptScope::AllFrames,
            });
            let mut a = bus.port();
            let mut b = bus.port();
            let mut tap = bus.tap();
            for i in 0..1000u32 {
                a.transmit(&CanFrame::classic(0x100, &i.to_le_bytes()).unwrap())
                    .unwrap();
            }
            bus.flush_delayed();
            let mut got = Vec::new();
            while let Some(x) = b.try_receive() {
                got.push(x);
            }
            let mut tapped = 0;
            while tap.try_receive().is_some() {
                tapped += 1;
            }
            assert_eq!(tapped, 1000);
            (got, bus.stats())
        };
        let (g1, s1) = run(42);
        let (g2, s2) = run(42);
        let (g3, _) = run(43);
        assert_eq!(g1, g2);
        assert_eq!(s1, s2);
        assert_ne!(g1, g3);
        for n in [
            s1.dropped,
            s1.duplicated,
            s1.corrupted,
            s1.truncated,
            s1.delayed,
        ] {
            assert!((50..=150).contains(&n), "{s1:?}");
        }
        assert_eq!(s1.delivered, 1000 + 1000 - s1.dropped + s1.duplicated);
    }

    #[test]
    fn corrupt_scope_long_messages_spares_single_frames() {
        let bus = InProcBus::new(BusMode::Classic, 1);
        bus.set_faults(FaultConfig {
            corrupt: 1.0,
            corrupt_scope: CorruptScope::LongMessages,
            ..FaultConfig::default()
        });
        let mut a = bus.port();
        let mut b = bus.port();
        let heartbeat = CanFrame::classic(0x701, &[0, 1]).unwrap();
        a.transmit(&heartbeat).unwrap();
        assert_eq!(b.try_receive(), Some(heartbeat));
        let segment = CanFrame::classic(0x211, &[0, 38, 1, 2, 3, 4, 5, 6]).unwrap();
        a.transmit(&segment).unwrap();
        assert_ne!(b.try_receive(), Some(segment));
    }
}
