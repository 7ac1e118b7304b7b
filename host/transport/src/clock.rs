//! The time a run's loops read: the wall clock on a real bus, a simulated clock in process.
//! The runner, the rig and the in-process controller node share one [`SimClock`], which
//! moves only when every node waits ([`crate::inproc::SimulatedBus`]): a run never sleeps and
//! the same seed and faults give the same run, frame for frame.

use std::cell::Cell;
use std::rc::Rc;
use std::time::{Duration, Instant};

/// Time since the start of a run.
pub trait Clock {
    /// Now, since the run's start.
    fn now(&self) -> Duration;
}

/// The wall clock (SocketCAN, serial SLCAN, the firmware in QEMU).
#[derive(Debug, Clone, Copy)]
pub struct WallClock {
    start: Instant,
}

impl WallClock {
    /// A clock that starts now.
    pub fn start() -> WallClock {
        WallClock {
            start: Instant::now(),
        }
    }
}

impl Clock for WallClock {
    fn now(&self) -> Duration {
        self.start.elapsed()
    }
}

/// A simulated clock: a shared handle (clones read and move the same time), advanced only
/// by the loop that knows nothing happens before a given time.
#[derive(Debug, Clone, Default)]
pub struct SimClock {
    now: Rc<Cell<Duration>>,
}

impl SimClock {
    /// A clock at zero.
    pub fn new() -> SimClock {
        SimClock::default()
    }

    /// Moves the clock to `t`; a time in the past leaves it where it is (time never goes
    /// back).
    pub fn advance_to(&self, t: Duration) {
        if t > self.now.get() {
            self.now.set(t);
        }
    }
}

impl Clock for SimClock {
    fn now(&self) -> Duration {
        self.now.get()
    }
}

/// `now` as the node's millisecond clock (`u32`, wrapping after 49 days as on the firmware).
pub fn millis(now: Duration) -> u32 {
    now.as_millis() as u32
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_simulated_clock_is_shared_and_never_goes_back() {
        let a = SimClock::new();
        let b = a.clone();
        a.advance_to(Duration::from_millis(30));
        assert_eq!(b.now(), Duration::from_millis(30));
        b.advance_to(Duration::from_millis(10));
        assert_eq!(a.now(), Duration::from_millis(30), "time never goes back");
        assert_eq!(millis(a.now()), 30);
    }
}
