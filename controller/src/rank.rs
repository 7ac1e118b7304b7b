//! Closeness ranking (8.2-8.4): which neurons are closest to an input.

#[cfg(test)]
use core::cmp::Ordering;

/// How the ranking is computed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RankMode {
    /// Keep the `K` nearest in a bounded max-heap while scanning (a neuron is rejected as
    /// soon as its partial squared distance exceeds the current `K`-th best), then sort
    /// those `K` only. Gives exactly the first `K` ranks of [`RankMode::FullSort`] (ties
    /// broken by index in both), at a fraction of the cost, with no `N`-sized scratch.
    /// (The first variant, so that a zeroed controller uses it: see
    /// `Controller::new_zeroed`.)
    PartialSelect,
    /// Sort all `N` distances (the reference; `N` keys of 8 bytes on the stack, meant for
    /// the host).
    FullSort,
}

/// The `K` closest neurons to an input, closest first: `index(r)` is `k(r)` of (8.3).
/// The inverse `r(k)` of (8.4) is only needed for the ranks that carry weight, and those are
/// the positions in this list.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Ranking<const K: usize> {
    index: [u16; K],
    /// The squared distances as [`dist_key`]s (their bits, in an order-preserving form).
    /// While [`RankMode::PartialSelect`] runs, `(dist, index)` is a max-heap of the `K`
    /// best pairs seen so far.
    dist: [u32; K],
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

#[cfg(test)]
fn order(a: &Candidate, b: &Candidate) -> Ordering {
    a.dist2.total_cmp(&b.dist2).then(a.index.cmp(&b.index))
}

/// The bits of `dist2` mapped so that unsigned integer order is [`f32::total_cmp`] order
/// (negative values, sign bit set, reversed below the positive ones).
#[inline(always)]
fn dist_key(dist2: f32) -> u32 {
    let b = dist2.to_bits();
    if b & 0x8000_0000 != 0 {
        !b
    } else {
        b | 0x8000_0000
    }
}

/// The squared distance of a [`dist_key`] (exactly: the map is a bijection on the bits).
#[inline(always)]
fn key_dist2(k: u32) -> f32 {
    f32::from_bits(if k & 0x8000_0000 != 0 {
        k & 0x7fff_ffff
    } else {
        !k
    })
}

/// `(dist2, index)` as one integer in the order of [`Candidate`]s.
#[inline(always)]
fn key(dist2: f32, index: usize) -> u64 {
    ((dist_key(dist2) as u64) << 32) | index as u64
}

/// The order of [`Candidate`]s on `(dist_key, index)` pairs: `a < b`.
#[inline(always)]
fn less(ad: u32, ai: u16, bd: u32, bi: u16) -> bool {
    ad < bd || (ad == bd && ai < bi)
}

/// The squared distance (8.2) of `w` to `u`: `sum_d (u_d - w_d)^2`, summed in `d` order.
#[inline(always)]
fn dist2<const D: usize>(w: &[f32; D], u: &[f32; D]) -> f32 {
    let mut s = 0.0;
    for d in 0..D {
        let diff = u[d] - w[d];
        s += diff * diff;
    }
    s
}

/// Restores the max-heap order of the pairs `(dist[j], index[j])`, `j < n`, below `i`.
#[inline(always)]
fn sift_down(dist: &mut [u32], index: &mut [u16], n: usize, mut i: usize) {
    let n = n.min(dist.len()).min(index.len());
    let (xd, xi) = (dist[i], index[i]);
    loop {
        let mut c = 2 * i + 1;
        if c >= n {
            break;
        }
        let (mut cd, mut ci) = (dist[c], index[c]);
        if c + 1 < n {
            let (dd, di) = (dist[c + 1], index[c + 1]);
            if less(cd, ci, dd, di) {
                c += 1;
                cd = dd;
                ci = di;
            }
        }
        if !less(xd, xi, cd, ci) {
            break;
        }
        dist[i] = cd;
        index[i] = ci;
        i = c;
    }
    dist[i] = xd;
    index[i] = xi;
}

/// Sorts a max-heap of pairs ascending: the largest to the end, repeatedly.
#[inline(always)]
fn heap_sort(dist: &mut [u32], index: &mut [u16]) {
    let n = dist.len().min(index.len());
    for end in (1..n).rev() {
        dist.swap(0, end);
        index.swap(0, end);
        sift_down(dist, index, end, 0);
    }
}

/// Scratch space for ranking `N` neurons. Empty: [`RankMode::PartialSelect`] works in the
/// [`Ranking`] itself and [`RankMode::FullSort`] (the host reference) on the stack. Kept so
/// that callers need not change.
#[derive(Debug, Clone)]
pub struct RankScratch<const N: usize> {
    _n: [(); N],
}

impl<const N: usize> Default for RankScratch<N> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize> RankScratch<N> {
    /// Zeroed scratch.
    pub const fn new() -> Self {
        RankScratch { _n: [(); N] }
    }
}

impl<const K: usize> Ranking<K> {
    /// An empty ranking.
    pub const fn new() -> Self {
        Ranking {
            index: [0; K],
            dist: [0; K],
        }
    }

    /// Ranks the weights `w` by distance to `u` and keeps the `K` closest.
    ///
    /// `K` must not exceed `N` (checked at compile time where it is instantiated).
    ///
    /// Both modes give the same result: the `K` smallest `(dist2, index)` pairs in the order
    /// of [`Candidate`] ([`f32::total_cmp`] on the squared distance, ties by index), with the
    /// squared distances summed in the same order. [`RankMode::FullSort`] sorts all `N`
    /// (`N` keys on the stack: the host reference). [`RankMode::PartialSelect`] keeps a
    /// max-heap of the `K` best so far and skips a neuron as soon as the partial sum of its
    /// squared distance exceeds the current `K`-th best: the partial sums of non-negative
    /// terms never decrease (rounding is monotonic), so such a neuron's full distance is
    /// larger too and it could not enter. The tables are finite (inputs are checked,
    /// checkpoints must be finite, the weight update is a convex step), so no NaN reaches the
    /// order.
    pub fn compute<const N: usize, const D: usize>(
        &mut self,
        w: &[[f32; D]; N],
        u: &[f32; D],
        scratch: &mut RankScratch<N>,
        mode: RankMode,
    ) {
        const { assert!(K <= N && K > 0 && N <= u16::MAX as usize) };
        let _ = scratch;
        match mode {
            RankMode::FullSort => self.full_sort(w, u),
            RankMode::PartialSelect => self.select(w, u),
        }
    }

    /// [`RankMode::FullSort`]: all `N` keys sorted (on the stack), the first `K` kept.
    #[inline(never)]
    fn full_sort<const N: usize, const D: usize>(&mut self, w: &[[f32; D]; N], u: &[f32; D]) {
        let mut all = [0u64; N];
        for (k, (c, wk)) in all.iter_mut().zip(w.iter()).enumerate() {
            *c = key(dist2(wk, u), k);
        }
        all.sort_unstable();
        for ((i, d), &c) in self
            .index
            .iter_mut()
            .zip(self.dist.iter_mut())
            .zip(all.iter())
        {
            *i = c as u16;
            *d = (c >> 32) as u32;
        }
    }

    /// [`RankMode::PartialSelect`]: a max-heap of the `K` best, then sorted in place.
    /// Not inlined: inlined into a caller that holds the ranking deep inside a larger
    /// struct, the heap's addresses took extra instructions on every access (measured on
    /// the Cortex-M4F: +36k instructions per ranking in `Controller::begin`).
    #[inline(never)]
    fn select<const N: usize, const D: usize>(&mut self, w: &[[f32; D]; N], u: &[f32; D]) {
        if !self.select_sampled(w, u) {
            self.select_plain(w, u);
        }
    }

    /// The heap scan with a threshold from a sample: the `r`-th smallest pair among the
    /// first `K` neurons, `r` chosen so that about `1.75 K` of all `N` pairs are expected at
    /// or below it. Pairs above it are skipped (and their sums cut short) from the start,
    /// instead of only once the heap has tightened, and the heap is only built from pairs
    /// below it. When at least `K` pairs are at or below the threshold, the `K` best of all
    /// are among them and the result is exactly the plain scan's; when fewer are (an
    /// unlucky sample: 17 calls in 20,000 on uniform random stage-1 weights, host test),
    /// returns false and the caller runs the plain scan (about twice the cost). Leaves the
    /// sorted pairs.
    fn select_sampled<const N: usize, const D: usize>(
        &mut self,
        w: &[[f32; D]; N],
        u: &[f32; D],
    ) -> bool {
        let r = (7 * K * K).div_ceil(4 * N).clamp(1, K);
        if r >= K {
            return false;
        }
        let (first, rest) = w.split_at(K);
        let mut sample = [0u64; K];
        for (k, (c, wk)) in sample.iter_mut().zip(first.iter()).enumerate() {
            *c = key(dist2(wk, u), k);
        }
        sample.select_nth_unstable(r - 1);
        // the r smallest pairs of the sample start the collection
        let (dist, index) = (&mut self.dist[..], &mut self.index[..]);
        for ((d, i), &c) in dist
            .iter_mut()
            .zip(index.iter_mut())
            .zip(sample[..r].iter())
        {
            *d = (c >> 32) as u32;
            *i = c as u16;
        }
        let mut count = r;
        // a later neuron's index is larger than every index collected and than the
        // threshold's: it enters when its distance key is strictly smaller
        let mut top = (sample[r - 1] >> 32) as u32;
        let mut worst = key_dist2(top);
        let half = D / 2;
        for (k, wk) in rest.iter().enumerate() {
            let mut s = 0.0;
            for d in 0..half {
                let diff = u[d] - wk[d];
                s += diff * diff;
            }
            if s > worst {
                continue;
            }
            for d in half..D {
                let diff = u[d] - wk[d];
                s += diff * diff;
            }
            // between non-NaN values the float comparison is the key comparison; equal
            // values and NaN go through the keys
            if s > worst {
                continue;
            }
            let c = dist_key(s);
            if !(s < worst || c < top) {
                continue;
            }
            if count < K {
                dist[count] = c;
                index[count] = (K + k) as u16;
                count += 1;
                if count == K {
                    for i in (0..K / 2).rev() {
                        sift_down(dist, index, K, i);
                    }
                    top = dist[0];
                    worst = key_dist2(top);
                }
            } else {
                dist[0] = c;
                index[0] = (K + k) as u16;
                sift_down(dist, index, K, 0);
                top = dist[0];
                worst = key_dist2(top);
            }
        }
        if count < K {
            return false;
        }
        heap_sort(dist, index);
        true
    }

    /// The plain heap scan: the first `K` neurons make the heap, every later one that is
    /// closer than the `K`-th best so far replaces it.
    fn select_plain<const N: usize, const D: usize>(&mut self, w: &[[f32; D]; N], u: &[f32; D]) {
        let (first, rest) = w.split_at(K);
        for (k, ((i, d), wk)) in self
            .index
            .iter_mut()
            .zip(self.dist.iter_mut())
            .zip(first.iter())
            .enumerate()
        {
            *i = k as u16;
            *d = dist_key(dist2(wk, u));
        }
        let (dist, index) = (&mut self.dist[..], &mut self.index[..]);
        for i in (0..K / 2).rev() {
            sift_down(dist, index, K, i);
        }
        let mut top = dist[0];
        let mut worst = key_dist2(top);
        // the first half of the sum, then a test against the K-th best so far
        let half = D / 2;
        for (k, wk) in rest.iter().enumerate() {
            let mut s = 0.0;
            for d in 0..half {
                let diff = u[d] - wk[d];
                s += diff * diff;
            }
            if s > worst {
                continue;
            }
            for d in half..D {
                let diff = u[d] - wk[d];
                s += diff * diff;
            }
            // every index in the heap is smaller: an equal distance does not enter. Between
            // non-NaN values the float comparison is the key comparison; equal values and
            // NaN go through the keys.
            if s > worst {
                continue;
            }
            let c = dist_key(s);
            if s < worst || c < top {
                dist[0] = c;
                index[0] = (K + k) as u16;
                sift_down(dist, index, K, 0);
                top = dist[0];
                worst = key_dist2(top);
            }
        }
        heap_sort(dist, index);
    }

    /// `k(r)`: the neuron of rank `r` (8.3).
    pub fn index(&self, r: usize) -> usize {
        self.index[r] as usize
    }

    /// Distance `D_k(r)` of the neuron of rank `r` (8.2).
    pub fn distance(&self, r: usize) -> f32 {
        libm::sqrtf(key_dist2(self.dist[r]))
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

    proptest! {
        /// The integer keys order candidates as `order` does, and give back their parts.
        #[test]
        fn keys_order_as_candidates(a in any::<u32>(), b in any::<u32>(), i in 0u16..1000, j in 0u16..1000) {
            for (x, y) in [(a, b), (a, a), (a & 0x7fff_ffff, b & 0x7fff_ffff)] {
                let ca = Candidate { dist2: f32::from_bits(x), index: i };
                let cb = Candidate { dist2: f32::from_bits(y), index: j };
                let (ka, kb) = (key(ca.dist2, i as usize), key(cb.dist2, j as usize));
                prop_assert_eq!(ka.cmp(&kb), order(&ca, &cb));
                prop_assert_eq!(key_dist2((ka >> 32) as u32).to_bits(), x);
                prop_assert_eq!(ka as u16, i);
                prop_assert_eq!(less(dist_key(ca.dist2), i, dist_key(cb.dist2), j), ka < kb);
            }
        }

        /// Stage-1 sizes, random tables: selection with early rejection against full sort.
        #[test]
        fn selection_matches_full_sort_at_stage1_sizes(seed in any::<u64>(), snap in any::<bool>()) {
            let mut rng = <rand_xoshiro::Xoshiro256PlusPlus as rand_core::SeedableRng>::seed_from_u64(seed);
            let mut w = [[0.0f32; 8]; 1000];
            for wk in w.iter_mut() {
                for x in wk.iter_mut() {
                    *x = crate::net::uniform(&mut rng, 0.0, 640.0);
                    if snap {
                        *x = (*x / 64.0).round() * 64.0; // many exact ties
                    }
                }
            }
            let u: [f32; 8] = core::array::from_fn(|_| crate::net::uniform(&mut rng, 100.0, 540.0));
            let mut scratch = RankScratch::<1000>::new();
            let mut full = Ranking::<1000>::new();
            full.compute(&w, &u, &mut scratch, RankMode::FullSort);
            let mut part = Ranking::<128>::new();
            part.compute(&w, &u, &mut scratch, RankMode::PartialSelect);
            for r in 0..128 {
                prop_assert_eq!(part.index(r), full.index(r));
                prop_assert_eq!(part.dist[r], full.dist[r]);
            }
        }
    }

    /// Neurons ordered by distance, closest first (the sample of the first `K` gives too
    /// tight a threshold: the plain scan takes over) and farthest first (everything passes
    /// the threshold): both as the full sort.
    #[test]
    fn selection_with_sorted_layouts() {
        let mut w = [[0.0f32; 2]; 300];
        for (k, wk) in w.iter_mut().enumerate() {
            *wk = [k as f32 * 0.5, (k % 7) as f32];
        }
        let u = [-1.0, 3.0];
        let mut scratch = RankScratch::<300>::new();
        for reverse in [false, true] {
            if reverse {
                w.reverse();
            }
            let mut full = Ranking::<300>::new();
            full.compute(&w, &u, &mut scratch, RankMode::FullSort);
            let mut part = Ranking::<40>::new();
            part.compute(&w, &u, &mut scratch, RankMode::PartialSelect);
            assert_eq!(&part.indices()[..], &full.indices()[..40]);
            assert_eq!(&part.dist[..], &full.dist[..40]);
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
