//! How long the runner waits for the controller before it repeats a request, on a bus run on
//! the wall clock: RFC 6298's estimator (a smoothed round trip `SRTT`, its variation
//! `RTTVAR`, a timeout `SRTT + 4 RTTVAR`) over the gaps between a request, or the controller's
//! last sign in a trial, and its next sign; no sample across a repeat (Karn's rule); the
//! timeout doubled at each repeat without an answer after the first [`PLAIN_REPEATS`], up to
//! [`MAX_DOUBLINGS`] times; all between a floor and the bus
//! profile's reply timeout, which stays the ceiling and the timeout until the first sample.
//!
//! What a repeat costs is then about one round trip of the bus, not the profile's whole
//! reply timeout, while a controller that answers slowly is still waited for as long as
//! before before a trial or a request is given up ([`Patience::exhausted`]).
//!
//! Which buses learn it is the bus profile's `adaptive_reply`: SocketCAN and serial SLCAN. On
//! a simulated clock (the in-process bus) the timeout is always the profile's: repeats cost no
//! wall time there, and every simulated-time figure stays what it was; nor under QEMU, whose
//! emulated clock's pace varies with what the firmware computes.

use std::time::Duration;

/// The shortest timeout on a wall-clock bus: above the scheduling jitter of a loaded host
/// (a repeat the controller did not need costs a few frames, never a score).
pub const FLOOR: Duration = Duration::from_millis(15);

/// Repeats at the learned timeout before it doubles: a lost frame is lost at random, and a
/// message of several frames is lost whole more often than a frame (at 5 % per frame, a
/// 7-frame message about one time in three), so a repeat lost too is no sign of a slow
/// controller; only a run of them is.
pub const PLAIN_REPEATS: u32 = 2;

/// The most the learned timeout is doubled: a start repeated while the controller serves it is
/// ignored, so repeats every 8 timeouts cost a slow controller a few frames, and a lossy bus
/// keeps many tries within the give-up time (a 12-frame start through 10 % loss gets through
/// whole about one time in four).
pub const MAX_DOUBLINGS: u32 = 3;

/// The runner's reply timeout and what it learned of the bus's round trip.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Patience {
    ceiling: Duration,
    adaptive: bool,
    /// `(SRTT, RTTVAR)` once a gap was measured.
    estimate: Option<(Duration, Duration)>,
}

impl Patience {
    /// Always `reply` (a simulated clock).
    pub const fn fixed(reply: Duration) -> Patience {
        Patience {
            ceiling: reply,
            adaptive: false,
            estimate: None,
        }
    }

    /// Learned from the gaps, at most `ceiling` (a wall-clock bus).
    pub const fn adaptive(ceiling: Duration) -> Patience {
        Patience {
            ceiling,
            adaptive: true,
            estimate: None,
        }
    }

    /// The timeout after `repeats` repeats without an answer.
    pub fn wait(&self, repeats: u32) -> Duration {
        match (self.adaptive, self.estimate) {
            (true, Some((srtt, rttvar))) => {
                let base = (srtt + 4 * rttvar).max(FLOOR);
                let doublings = repeats.saturating_sub(PLAIN_REPEATS).min(MAX_DOUBLINGS);
                base.saturating_mul(1u32 << doublings).min(self.ceiling)
            }
            _ => self.ceiling,
        }
    }

    /// A sign came `gap` after the request (or the last sign) with no repeat between.
    pub fn answered(&mut self, gap: Duration) {
        if !self.adaptive {
            return;
        }
        self.estimate = Some(match self.estimate {
            None => (gap, gap / 2),
            Some((srtt, rttvar)) => {
                let diff = srtt.abs_diff(gap);
                (
                    srtt.mul_f64(0.875) + gap.mul_f64(0.125),
                    rttvar.mul_f64(0.75) + diff.mul_f64(0.25),
                )
            }
        });
    }

    /// Whether a request repeated `repeats` times, `stalled` after the last sign, should be
    /// given up after `retries` repeats: with the profile's fixed timeout at the count; with
    /// a learned one only once `retries` whole ceilings went by as well, as long as the fixed
    /// timeout waited.
    pub fn exhausted(&self, repeats: u32, stalled: Duration, retries: u32) -> bool {
        repeats >= retries && (!self.adaptive || stalled >= self.ceiling.saturating_mul(retries))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MS: Duration = Duration::from_millis(1);

    /// Fails if a simulated clock's timeout moves, or its give-up is not the count alone.
    #[test]
    fn a_fixed_patience_is_the_profiles_reply_timeout() {
        let mut p = Patience::fixed(60 * MS);
        p.answered(2 * MS);
        assert_eq!((p.wait(0), p.wait(5)), (60 * MS, 60 * MS));
        assert!(p.exhausted(12, Duration::ZERO, 12));
        assert!(!p.exhausted(11, Duration::from_secs(100), 12));
    }

    /// Fails if the timeout does not follow the gaps, falls below the floor, does not double
    /// per repeat up to the ceiling, or gives up before the fixed timeout's whole wait.
    #[test]
    fn an_adaptive_patience_follows_the_gaps_between_floor_and_ceiling() {
        let mut p = Patience::adaptive(300 * MS);
        assert_eq!(p.wait(0), 300 * MS, "no sample yet: the ceiling");
        for _ in 0..50 {
            p.answered(20 * MS);
        }
        let settled = p.wait(0);
        assert!(settled >= 20 * MS && settled < 30 * MS, "{settled:?}");
        assert_eq!(p.wait(PLAIN_REPEATS), settled);
        assert_eq!(p.wait(PLAIN_REPEATS + 1), settled * 2);
        assert_eq!(p.wait(20), settled * (1 << MAX_DOUBLINGS));
        let mut slow = Patience::adaptive(300 * MS);
        slow.answered(100 * MS);
        assert_eq!(slow.wait(20), 300 * MS, "never above the ceiling");
        let mut fast = Patience::adaptive(300 * MS);
        for _ in 0..50 {
            fast.answered(MS / 10);
        }
        assert_eq!(fast.wait(0), FLOOR);
        // a jittery bus waits longer than a steady one with the same mean
        let mut jitter = Patience::adaptive(300 * MS);
        for i in 0..50 {
            jitter.answered(if i % 2 == 0 { 5 * MS } else { 35 * MS });
        }
        assert!(jitter.wait(0) > settled, "{:?}", jitter.wait(0));
        assert!(!p.exhausted(12, 3599 * MS, 12));
        assert!(p.exhausted(12, 3600 * MS, 12));
        assert!(!p.exhausted(11, Duration::from_secs(100), 12));
    }
}
