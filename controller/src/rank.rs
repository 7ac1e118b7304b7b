//! Closeness ranking (8.2-8.4): which neurons are closest to an input.

use core::cmp::Ordering;

/// How the ranking is computed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RankMode {
    /// Select the `K` nearest with a linear-time selection, then sort those `K` only.
    /// Gives exactly the first `K` ranks of [`RankMode::FullSort`] (ties broken by index in
    /// both), at a fraction of the cost. (The first variant, so that a zeroed controller
    /// uses it: see `Controller::new_zeroed`.)
    PartialSelect,
    /// Sort all `N` distances (the reference).
    FullSort,
}

/// The `K` closest neurons to an input, closest first: `index(r)` is `k(r)` of (8.3).
/// The inverse `r(k)` of (8.4) is only needed for the ranks that carry weight, and those are
/// the positions in this list.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ranking<const K: usize> {
    index: [u16; K],
    dist2: [f32; K],
}

impl<const K: usize> Default for Ranking<K> {
    fn default() -> Self {
        Self::new()
    }
}

/// A (squared distance, neuron index) pair; ordered by distance, then by index, so that the
/// order is total and every ranking mode agrees.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Candidate {
    /// Squared distance (8.2, squared: the order is the same).
    pub dist2: f32,
    /// Neuron index.
    pub index: u16,
}

impl Candidate {
    const ZERO: Candidate = Candidate {
        dist2: 0.0,
        index: 0,
    };
}

fn order(a: &Candidate, b: &Candidate) -> Ordering {
    a.dist2.total_cmp(&b.dist2).then(a.index.cmp(&b.index))
}

/// Scratch space for ranking `N` neurons (one per network, so firmware can make it static).
#[derive(Debug, Clone)]
pub struct RankScratch<const N: usize> {
    cand: [Candidate; N],
}

impl<const N: usize> Default for RankScratch<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> RankScratch<N> {
    /// Zeroed scratch.
    pub const fn new() -> Self {
        RankScratch {
            cand: [Candidate::ZERO; N],
        }
    }
}

impl<const K: usize> Ranking<K> {
    /// An empty ranking.
    pub const fn new() -> Self {
        Ranking {
            index: [0; K],
            dist2: [0.0; K],
        }
    }

    /// Ranks the weights `w` by distance to `u` and keeps the `K` closest.
    ///
    /// `K` must not exceed `N` (checked at compile time where it is instantiated).
    pub fn compute<const N: usize, const D: usize>(
        &mut self,
        w: &[[f32; D]; N],
        u: &[f32; D],
        scratch: &mut RankScratch<N>,
        mode: RankMode,
    ) {
        const { assert!(K <= N && K > 0 && N <= u16::MAX as usize) };
        for (k, (c, wk)) in scratch.cand.iter_mut().zip(w.iter()).enumerate() {
            let mut s = 0.0;
            for d in 0..D {
                let diff = u[d] - wk[d];
                s += diff * diff;
            }
            *c = Candidate {
                dist2: s,
                index: k as u16,
            };
        }
        match mode {
            RankMode::FullSort => scratch.cand.sort_unstable_by(order),
            RankMode::PartialSelect => {
                if K < N {
                    scratch.cand.select_nth_unstable_by(K - 1, order);
                }
                scratch.cand[..K].sort_unstable_by(order);
            }
        }
        for r in 0..K {
            self.index[r] = scratch.cand[r].index;
            self.dist2[r] = scratch.cand[r].dist2;
        }
    }

    /// `k(r)`: the neuron of rank `r` (8.3).
    pub fn index(&self, r: usize) -> usize {
        self.index[r] as usize
    }

    /// Distance `D_k(r)` of the neuron of rank `r` (8.2).
    pub fn distance(&self, r: usize) -> f32 {
        libm::sqrtf(self.dist2[r])
    }

    /// The neuron indices, closest first.
    pub fn indices(&self) -> &[u16; K] {
        &self.index
    }
}

#[cfg(test)]
#[allow(clippy::needless_range_loop)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn brute<const N: usize, const D: usize>(w: &[[f32; D]; N], u: &[f32; D]) -> [usize; N] {
        let mut idx = [0usize; N];
        for (i, x) in idx.iter_mut().enumerate() {
            *x = i;
        }
        let d = |k: usize| -> f32 { (0..D).map(|j| (u[j] - w[k][j]) * (u[j] - w[k][j])).sum() };
        // insertion sort by (distance, index): obviously correct
        for i in 1..N {
            let mut j = i;
            while j > 0
                && (d(idx[j - 1]) > d(idx[j])
                    || (d(idx[j - 1]) == d(idx[j]) && idx[j - 1] > idx[j]))
            {
                idx.swap(j - 1, j);
                j -= 1;
            }
        }
        idx
    }

    proptest! {
        #[test]
        fn full_sort_and_selection_match_brute_force(
            seed in any::<u64>(), u in prop::array::uniform3(-10.0f32..10.0)
        ) {
            let mut rng = <rand_xoshiro::Xoshiro256PlusPlus as rand_core::SeedableRng>::seed_from_u64(seed);
            let mut w = [[0.0f32; 3]; 60];
            for wk in w.iter_mut() {
                for x in wk.iter_mut() {
                    // coarse grid: many exact ties, to exercise the tie-break
                    *x = (crate::net::uniform(&mut rng, -10.0, 10.0)).round();
                }
            }
            let reference = brute(&w, &u);
            let mut scratch = RankScratch::<60>::new();
            let mut full = Ranking::<60>::new();
            full.compute(&w, &u, &mut scratch, RankMode::FullSort);
            let mut part = Ranking::<17>::new();
            part.compute(&w, &u, &mut scratch, RankMode::PartialSelect);
            for r in 0..60 {
                prop_assert_eq!(full.index(r), reference[r]);
            }
            for r in 0..17 {
                prop_assert_eq!(part.index(r), reference[r]);
                prop_assert_eq!(part.distance(r), full.distance(r));
            }
        }
    }

    #[test]
    fn rank_of_a_known_layout() {
        let w = [[0.0f32, 0.0], [5.0, 0.0], [1.0, 0.0], [3.0, 0.0]];
        let mut s = RankScratch::<4>::new();
        let mut r = Ranking::<4>::new();
        r.compute(&w, &[2.9, 0.0], &mut s, RankMode::FullSort);
        assert_eq!(r.indices(), &[3, 2, 1, 0]);
        assert!((r.distance(0) - 0.1).abs() < 1e-6);
    }
}
