//! The guard of the learned tables: a nonce issued on request for one destructive operation
//! (re-seeding tables that learned, writing tables in, erasing the stored copy), valid once,
//! within a window of the node's clock, drawn from a generator the embedding seeds at boot
//! (the MCU's RNG; on a host, a seeded generator). An operation without it, or with a stale,
//! used or wrong one, is refused and changes nothing (protocol/SPEC.md 3.4).

use trn_protocol::GuardOp;

/// Why the guard refused an operation (`GUARD_REFUSED` detail, low byte).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
#[repr(u8)]
pub enum Refusal {
    /// The operation carried no nonce (a plain `SessionConfig`, a nonce field of 0).
    NoNonce = 1,
    /// The nonce issued for it, presented after its window.
    Stale = 2,
    /// A nonce already used (or refused) once: a replay.
    Used = 3,
    /// Not the nonce issued for this operation (another operation's, another boot's, none
    /// issued).
    Wrong = 4,
    /// The node cannot issue nonces: its embedding never seeded the generator.
    Unavailable = 5,
}

/// The wire number of an operation in `GUARD_REFUSED` and `TABLES_FAILED` details (bits
/// 8..16): 1 re-seed, 2 table write, 3 erase of the stored copy.
pub fn op_code(op: GuardOp) -> u32 {
    op as u32 + 1
}

/// Draws a board takes from its hardware RNG for the guard's seed ([`seed_from_draws`]).
pub const SEED_DRAWS: usize = 16;

/// Why no seed came out of a hardware RNG's draws.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SeedFailure {
    /// Draws that failed (the RNG's seed or clock error, a timeout, a zero word).
    pub failed: u8,
    /// Draws that repeated a word already taken (a stuck RNG).
    pub repeated: u8,
}

/// The guard's seed from a hardware RNG's draws, each a word or `None` for a draw that
/// failed: the first four distinct non-zero words of at most [`SEED_DRAWS`] draws. A zero
/// word (what an STM32's RNG reads after a seed error) and a word already taken (an RNG
/// stuck on one value) are skipped; fewer than four good words is a [`SeedFailure`], and the
/// node then stays unseeded (it refuses every guarded operation, `GUARD_REFUSED` reason 5).
pub fn seed_from_draws(
    draws: impl IntoIterator<Item = Option<u32>>,
) -> Result<[u8; 16], SeedFailure> {
    let mut words = [0u32; 4];
    let mut taken = 0;
    let mut failure = SeedFailure {
        failed: 0,
        repeated: 0,
    };
    for draw in draws.into_iter().take(SEED_DRAWS) {
        match draw {
            None | Some(0) => failure.failed += 1,
            Some(w) if words[..taken].contains(&w) => failure.repeated += 1,
            Some(w) => {
                words[taken] = w;
                taken += 1;
                if taken == words.len() {
                    let mut seed = [0u8; 16];
                    for (chunk, w) in seed.chunks_exact_mut(4).zip(words) {
                        chunk.copy_from_slice(&w.to_le_bytes());
                    }
                    return Ok(seed);
                }
            }
        }
    }
    Err(failure)
}

/// xoshiro128++ (Blackman and Vigna), the generator of `rand_xoshiro::Xoshiro128PlusPlus`,
/// written out so that a node is built by a `const fn` (the firmware's is a `static`); a test
/// checks it against the crate. The all-zero state, which the algorithm never leaves or
/// enters, stands for "not seeded".
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct Xoshiro128pp([u32; 4]);

impl Xoshiro128pp {
    fn next_u32(&mut self) -> u32 {
        let s = &mut self.0;
        let result = s[0].wrapping_add(s[3]).rotate_left(7).wrapping_add(s[0]);
        let t = s[1] << 9;
        s[2] ^= s[0];
        s[3] ^= s[1];
        s[1] ^= s[2];
        s[0] ^= s[3];
        s[2] ^= t;
        s[3] = s[3].rotate_left(11);
        result
    }
}

/// The node's nonce generator and the nonce it issued last, in 32 bytes (a nonce is never 0,
/// so 0 stands for none).
#[derive(Debug, Clone)]
pub(crate) struct Guard {
    rng: Xoshiro128pp,
    /// The operation, nonce (0: none) and issue time of the nonce issued last.
    op: GuardOp,
    issued: u32,
    issued_ms: u32,
    /// The issued nonce spent last (by a try that was accepted, stale or wrong), 0 none: a
    /// nonce is good for one try, and presenting it again is refused as used.
    spent: u32,
}

impl Guard {
    /// A guard that issues nothing until seeded.
    pub(crate) const fn new() -> Guard {
        Guard {
            rng: Xoshiro128pp([0; 4]),
            op: GuardOp::Reseed,
            issued: 0,
            issued_ms: 0,
            spent: 0,
        }
    }

    /// Seeds the generator (at boot, from a source the bus cannot predict); an all-zero seed
    /// (a failed RNG) leaves the guard unseeded.
    pub(crate) fn seed(&mut self, seed: [u8; 16]) {
        let word = |i: usize| u32::from_le_bytes([seed[i], seed[i + 1], seed[i + 2], seed[i + 3]]);
        self.rng = Xoshiro128pp([word(0), word(4), word(8), word(12)]);
        self.issued = 0;
    }

    /// A fresh nonce for `op` (never 0: 0 means "no nonce" on the wire); it replaces any
    /// nonce issued before.
    pub(crate) fn issue(&mut self, op: GuardOp, now_ms: u32) -> Result<u32, Refusal> {
        if self.rng.0 == [0; 4] {
            return Err(Refusal::Unavailable);
        }
        let nonce = loop {
            let n = self.rng.next_u32();
            if n != 0 && n != self.spent {
                break n;
            }
        };
        (self.op, self.issued, self.issued_ms) = (op, nonce, now_ms);
        Ok(nonce)
    }

    /// Checks the nonce an operation carries (`0`: none). The issued nonce is spent by any
    /// try, good or not.
    pub(crate) fn check(
        &mut self,
        op: GuardOp,
        nonce: u32,
        now_ms: u32,
        window_ms: u32,
    ) -> Result<(), Refusal> {
        if nonce == 0 {
            return Err(Refusal::NoNonce);
        }
        if self.spent == nonce {
            return Err(Refusal::Used);
        }
        if self.issued == 0 {
            return Err(Refusal::Wrong);
        }
        let issued = core::mem::take(&mut self.issued);
        self.spent = issued;
        if issued != nonce || self.op != op {
            return Err(Refusal::Wrong);
        }
        if now_ms.wrapping_sub(self.issued_ms) > window_ms {
            return Err(Refusal::Stale);
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn seeded() -> Guard {
        let mut g = Guard::new();
        g.seed([7; 16]);
        g
    }

    #[test]
    fn a_fresh_nonce_is_accepted_once() {
        let mut g = seeded();
        let n = g.issue(GuardOp::Reseed, 1000).unwrap();
        assert_ne!(n, 0);
        assert_eq!(g.check(GuardOp::Reseed, n, 2999, 2000), Ok(()));
        assert_eq!(g.check(GuardOp::Reseed, n, 3000, 2000), Err(Refusal::Used));
    }

    #[test]
    fn refusals_are_told_apart() {
        let mut g = seeded();
        assert_eq!(g.check(GuardOp::Reseed, 0, 0, 2000), Err(Refusal::NoNonce));
        assert_eq!(g.check(GuardOp::Reseed, 42, 0, 2000), Err(Refusal::Wrong));
        let n = g.issue(GuardOp::Reseed, 0).unwrap();
        assert_eq!(g.check(GuardOp::Reseed, n, 2001, 2000), Err(Refusal::Stale));
        // another operation's nonce
        let n = g.issue(GuardOp::StoreErase, 5000).unwrap();
        assert_eq!(
            g.check(GuardOp::TableWrite, n, 5001, 2000),
            Err(Refusal::Wrong)
        );
        // a wrong try spends the nonce issued: the right one after it is refused as used
        let n = g.issue(GuardOp::TableWrite, 6000).unwrap();
        assert_eq!(
            g.check(GuardOp::TableWrite, n ^ 1, 6001, 2000),
            Err(Refusal::Wrong)
        );
        assert_eq!(
            g.check(GuardOp::TableWrite, n, 6002, 2000),
            Err(Refusal::Used)
        );
        // the clock wraps
        let n = g.issue(GuardOp::Reseed, u32::MAX - 10).unwrap();
        assert_eq!(g.check(GuardOp::Reseed, n, 100, 2000), Ok(()));
    }

    #[test]
    fn an_unseeded_guard_issues_nothing_and_accepts_nothing() {
        let mut g = Guard::new();
        assert_eq!(g.issue(GuardOp::Reseed, 0), Err(Refusal::Unavailable));
        assert_eq!(g.check(GuardOp::Reseed, 1, 0, 2000), Err(Refusal::Wrong));
        g.seed([0; 16]);
        assert_eq!(g.issue(GuardOp::Reseed, 0), Err(Refusal::Unavailable));
    }

    /// The generator is xoshiro128++ as the `rand_xoshiro` crate has it.
    #[test]
    fn the_generator_is_xoshiro128_plus_plus() {
        use rand_core::{RngCore, SeedableRng};
        let seed: [u8; 16] = core::array::from_fn(|i| (i as u8).wrapping_mul(37) ^ 0xA5);
        let mut reference = rand_xoshiro::Xoshiro128PlusPlus::from_seed(seed);
        let mut g = Guard::new();
        g.seed(seed);
        for _ in 0..1000 {
            assert_eq!(g.rng.next_u32(), reference.next_u32());
        }
    }

    #[test]
    fn nonces_differ_by_seed_and_are_not_a_counter() {
        let mut a = seeded();
        let mut b = Guard::new();
        b.seed([8; 16]);
        let xs: Vec<u32> = (0..8)
            .map(|_| a.issue(GuardOp::Reseed, 0).unwrap())
            .collect();
        let ys: Vec<u32> = (0..8)
            .map(|_| b.issue(GuardOp::Reseed, 0).unwrap())
            .collect();
        assert_ne!(xs, ys);
        assert!(xs.windows(2).all(|w| w[1] != w[0].wrapping_add(1)));
    }
}
