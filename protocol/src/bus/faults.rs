//! Fault injection of the in-process bus: what may happen to a frame on its way to each
//! receiver (dropped, duplicated, corrupted, truncated, delayed), seeded, and counted.

use rand_core::{RngCore, SeedableRng};
use rand_xoshiro::Xoshiro256PlusPlus;

use crate::frame::{fd_len_for, CanFrame};
use crate::id::CanId;

/// Which frames the corruption injector may corrupt.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
pub enum CorruptScope {
    /// Any frame.
    #[default]
    AllFrames,
    /// Only frames of long (CRC-protected) messages: segments and whole FD frames. Models
    /// the protocol's threat model: the CAN CRC protects single frames on the wire.
    LongMessages,
}

/// Fault probabilities, each applied independently per frame and per receiving port.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize, serde::Deserialize)]
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

impl core::str::FromStr for FaultConfig {
    type Err = String;

    /// `drop=P,dup=P,reorder=P,corrupt=P,truncate=P` (any subset, each P in [0, 1]):
    /// `reorder` delays a frame by up to 8 later frames; `corrupt` flips a byte of frames of
    /// long (CRC-protected) messages only: on a real bus CAN's own CRC discards a corrupted
    /// frame, which `drop` models, so what reaches a node corrupted is what passed that
    /// check, and the protocol's end-to-end CRC-32 is what catches it.
    fn from_str(s: &str) -> Result<Self, String> {
        let mut f = FaultConfig {
            corrupt_scope: CorruptScope::LongMessages,
            ..FaultConfig::default()
        };
        let mut seen: Vec<&str> = Vec::new();
        if s.trim().is_empty() {
            return Err(
                "no fault given: drop=P, dup=P, reorder=P, corrupt=P or truncate=P, comma-separated"
                    .into(),
            );
        }
        for part in s.split(',') {
            if part.trim().is_empty() {
                return Err(format!("`{s}`: an empty item between commas"));
            }
            let (name, value) = part
                .split_once('=')
                .ok_or_else(|| format!("`{part}`: expected NAME=P"))?;
            let canonical = match name.trim() {
                "dup" => "duplicate",
                "delay" => "reorder",
                other => other,
            };
            if seen.contains(&canonical) {
                return Err(format!("`{}` is given twice", name.trim()));
            }
            seen.push(canonical);
            let p: f64 = value
                .trim()
                .parse()
                .map_err(|_| format!("`{part}`: {value} is not a number"))?;
            if !(0.0..=1.0).contains(&p) {
                return Err(format!("`{part}`: a probability is in [0, 1]"));
            }
            match name.trim() {
                "drop" => f.drop = p,
                "dup" | "duplicate" => f.duplicate = p,
                "reorder" | "delay" => {
                    f.delay = p;
                    f.max_delay_frames = 8;
                }
                "corrupt" => f.corrupt = p,
                "truncate" => f.truncate = p,
                other => {
                    return Err(format!(
                        "unknown fault `{other}`: drop, dup, reorder, corrupt, truncate"
                    ))
                }
            }
        }
        Ok(f)
    }
}

#[cfg(test)]
mod parse_tests {
    use super::*;

    #[test]
    fn fault_lists_parse_and_bad_ones_are_named() {
        let f: FaultConfig = "drop=0.05,dup=0.01,reorder=0.02,corrupt=0.03,truncate=0.04"
            .parse()
            .unwrap();
        assert_eq!(
            (f.drop, f.duplicate, f.delay, f.corrupt, f.truncate),
            (0.05, 0.01, 0.02, 0.03, 0.04)
        );
        assert_eq!(
            (f.max_delay_frames, f.corrupt_scope),
            (8, CorruptScope::LongMessages)
        );
        for bad in [
            "drop",
            "drop=x",
            "drop=2",
            "drop=-0.1",
            "jam=0.1",
            "drop=nan",
            "drop=0.1,drop=0.2",
            "dup=0.1,duplicate=0.1",
            "reorder=0.1,delay=0.2",
            "",
            " ",
            "drop=0.1,,dup=0.1",
            "drop=0.1,",
            ",drop=0.1",
        ] {
            assert!(bad.parse::<FaultConfig>().is_err(), "{bad}");
        }
        let e = "drop=0.1,drop=0.2".parse::<FaultConfig>().unwrap_err();
        assert!(e.contains("twice"), "{e}");
        let e = "".parse::<FaultConfig>().unwrap_err();
        assert!(e.contains("no fault given"), "{e}");
        let e = "drop=0.1,,dup=0.1".parse::<FaultConfig>().unwrap_err();
        assert!(e.contains("empty item"), "{e}");
    }
}

/// Counters of what the bus did.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
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

    /// What becomes of `frame` on its way to one receiver under `f`, counted in `stats`
    /// (all but `sent` and `delivered`): no copy (dropped), or one or two copies, each with
    /// the number of later frames it waits for (0: delivered now). The draws, in order: drop,
    /// corrupt (when `f` may corrupt this frame), truncate, duplicate, and each copy's delay.
    pub(super) fn fate(
        &mut self,
        f: &FaultConfig,
        frame: &CanFrame,
        stats: &mut BusStats,
    ) -> [Option<(CanFrame, u32)>; 2] {
        if self.chance(f.drop) {
            stats.dropped += 1;
            return [None, None];
        }
        let long = CanId::from_raw(frame.raw_id())
            .map(|id| !id.kind.is_single_frame())
            .unwrap_or(false);
        let mut copy = *frame;
        let may_corrupt = f.corrupt_scope == CorruptScope::AllFrames || long;
        if may_corrupt && self.chance(f.corrupt) {
            copy = self.corrupt(&copy);
            stats.corrupted += 1;
        }
        if self.chance(f.truncate) {
            copy = self.truncate(&copy);
            stats.truncated += 1;
        }
        let copies = if self.chance(f.duplicate) {
            stats.duplicated += 1;
            2
        } else {
            1
        };
        let mut out = [None, None];
        for slot in out.iter_mut().take(copies) {
            let delay = if f.max_delay_frames > 0 && self.chance(f.delay) {
                stats.delayed += 1;
                1 + self.below(f.max_delay_frames as u64) as u32
            } else {
                0
            };
            *slot = Some((copy, delay));
        }
        out
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
