//! One run's seed fanned out to everything it drives: the one table of named sub-seeds
//! ([`Seeds`]). Each consumer seeds its own stream from its entry, so no two draw the same
//! numbers; the salts are the ones the streams had before the table (every figure of a run
//! without faults is unchanged), except the fault injector's, which drew the initial tables'
//! stream (the run's seed itself) and now has a stream of its own.

/// The named sub-seeds of a run's seed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Seeds {
    /// The controller's initial tables: the session's `SessionConfig.seed` (SPEC.md 3.2),
    /// the run's seed itself, so that a board seeds the same tables as the in-process
    /// controller.
    pub tables: u64,
    /// The simulated plant (its joints' and cameras' noise, which it spreads itself).
    pub plant: u64,
    /// The schedule: the held-out targets and the snapshots' sets.
    pub schedule: u64,
    /// The runner: the training targets and start poses.
    pub runner: u64,
    /// The in-process controller node's guard (its nonces).
    pub guard: u64,
    /// The faults injected on the in-process bus.
    pub faults: u64,
    /// The conformance suite's own choices.
    pub suite: u64,
}

impl Seeds {
    /// The table of `seed`.
    pub const fn of(seed: u64) -> Seeds {
        Seeds {
            tables: seed,
            plant: seed,
            schedule: seed ^ 0x4E1D_0075_EED5,
            runner: seed ^ 0x5EED_7A26_E75E_55ED,
            guard: seed ^ 0x6A09_E667_F3BC_C908,
            faults: seed ^ 0xFA17_0B05_5EED,
            suite: seed ^ 0xC0F0_12AA,
        }
    }

    /// Every entry with its name (for the test that no two streams share a seed).
    pub const fn named(&self) -> [(&'static str, u64); 7] {
        [
            ("tables", self.tables),
            ("plant", self.plant),
            ("schedule", self.schedule),
            ("runner", self.runner),
            ("guard", self.guard),
            ("faults", self.faults),
            ("suite", self.suite),
        ]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The plant spreads its own sub-seed (it XORs its streams' salts in), so it may share
    /// the run's seed with the tables; every other stream has a sub-seed of its own, for
    /// every seed, and the fault injector's is not the tables'.
    #[test]
    fn no_two_streams_but_the_plants_share_a_seed() {
        for seed in [0, 1, 100, 109, u64::MAX, 0x4E1D_0075_EED5] {
            let s = Seeds::of(seed);
            assert_ne!(s.faults, s.tables, "seed {seed}");
            let named = s.named();
            for (i, (a, x)) in named.iter().enumerate() {
                for (b, y) in &named[i + 1..] {
                    if (*a, *b) != ("tables", "plant") {
                        assert_ne!(x, y, "seed {seed}: {a} and {b}");
                    }
                }
            }
        }
    }
}
