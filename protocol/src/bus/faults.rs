//! Fault injection of the in-process bus: what may happen to a frame on its way to each
//! receiver (dropped, duplicated, corrupted, truncated, delayed), seeded, and counted.

use rand_core::{RngCore, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;

use crate::frame::{fd_len_for, CanFrame};

/// Which frames the corruption injector may corrupt.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum CorruptScope {
    /// Any frame.
    #[default]
    AllFrames,
    /// Only frames of long (CRC-protected) messages: segments and whole FD frames. Models
    /// the protocol's threat model: the CAN CRC protects single frames on the wire.
    LongMessages,
}

/// Fault probabilities, each applied independently per frame and per receiving port.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct FaultConfig {
    /// Probability that a receiver does not get the frame.
    pub drop: f64,
    /// Probability that a receiver gets the frame twice.
    pub duplicate: f64,
    /// Probability that one payload byte is XORed with a random non-zero value.
    pub corrupt: f64,
    /// Which frames may be corrupted.
    pub corrupt_scope: CorruptScope,
    /// Probability that the payload is cut short (to a valid length for the frame type);
    /// applies to every frame (every layout has a fixed length, so truncation is always
    /// detected).
    pub truncate: f64,
    /// Probability that delivery is delayed until 1..=`max_delay_frames` later frames
    /// were sent (this reorders frames).
    pub delay: f64,
    /// Longest delay, in frames sent after the delayed one.
    pub max_delay_frames: u32,
}

/// Counters of what the bus did.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct BusStats {
    /// Frames accepted for transmission.
    pub sent: u64,
    /// Frame copies put into receive queues.
    pub delivered: u64,
    /// Copies dropped.
    pub dropped: u64,
    /// Extra copies delivered.
    pub duplicated: u64,
    /// Copies corrupted.
    pub corrupted: u64,
    /// Copies truncated.
    pub truncated: u64,
    /// Copies delayed.
    pub delayed: u64,
}

/// The seeded source of every fault decision.
#[derive(Debug)]
pub(super) struct Injector {
    rng: Xoshiro256PlusPlus,
}

impl Injector {
    pub(super) fn new(seed: u64) -> Self {
        Injector {
            rng: Xoshiro256PlusPlus::seed_from_u64(seed),
        }
    }

    pub(super) fn chance(&mut self, p: f64) -> bool {
        if p <= 0.0 {
            return false;
        }
        // 53 random bits -> [0, 1).
        let x = (self.rng.next_u64() >> 11) as f64 / (1u64 << 53) as f64;
        x < p
    }

    pub(super) fn below(&mut self, n: u64) -> u64 {
        if n == 0 {
            0
        } else {
            self.rng.next_u64() % n
        }
    }

    pub(super) fn corrupt(&mut self, frame: &CanFrame) -> CanFrame {
        if frame.is_empty() {
            return *frame;
        }
        let mut data = [0u8; 64];
        let len = frame.len();
        data[..len].copy_from_slice(frame.payload());
        let i = self.below(len as u64) as usize;
        data[i] ^= 1 + self.below(255) as u8;
        CanFrame::new_checked(frame.raw_id(), &data[..len], frame.is_fd()).unwrap_or(*frame)
    }

    pub(super) fn truncate(&mut self, frame: &CanFrame) -> CanFrame {
        if frame.is_empty() {
            return *frame;
        }
        let mut n = self.below(frame.len() as u64) as usize;
        if frame.is_fd() {
            while fd_len_for(n) != Some(n) {
                n -= 1;
            }
        }
        CanFrame::new_checked(frame.raw_id(), &frame.payload()[..n], frame.is_fd())
            .unwrap_or(*frame)
    }
}
