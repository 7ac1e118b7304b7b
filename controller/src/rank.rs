//! Closeness ranking (8.2-8.4): which neurons are closest to an input.

use crate::entry::{Entry, TABLE_SCALES};
#[cfg(test)]
use core::cmp::Ordering;

/// How the ranking is computed.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RankMode {
    /// Keep the neurons below a cut in a histogram of the squared distances while scanning
    /// (the cut comes down as closer neurons come in; a neuron is rejected as soon as its
    /// partial squared distance reaches the cut), then sort the `K` closest only (a heap
    /// scan when the histogram cannot decide). Gives exactly the first `K` ranks of
    /// [`RankMode::FullSort`] (ties broken by index in both), at a fraction of the cost,
    /// with no `N`-sized scratch.
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
fn dist2<E: Entry, const D: usize>(w: &[E; D], u: &[f32; D]) -> f32 {
    let mut s = 0.0;
    for d in 0..D {
        let diff = u[d] - w[d].get(TABLE_SCALES.w);
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

/// Scratch space for a ranking: the buffers of [`RankMode::PartialSelect`]'s bucketed scan
/// (2,048 bytes, whatever the number of neurons), kept by the ranking's owner rather than on
/// the stack, where zeroing them at every call cost about 1,500 instructions on the
/// Cortex-M4F. Nothing in it outlives a call, so rankings that never run at the same time
/// share one (the controller's two stages do). [`RankMode::FullSort`] (the host reference)
/// sorts on the stack.
#[derive(Debug, Clone)]
pub struct RankScratch {
    buf: Buffers,
}

impl Default for RankScratch {
    fn default() -> Self {
        Self::new()
    }
}

impl RankScratch {
    /// Zeroed scratch.
    pub const fn new() -> Self {
        RankScratch {
            buf: Buffers::new(),
        }
    }
}

/// Buckets of [`Ranking::select_bucketed`]'s histogram (bucket numbers fit a `u8`).
const BUCKETS: usize = 128;
/// Neurons [`Ranking::select_bucketed`] keeps at once (on the stack: 7 bytes each).
const CAPACITY: usize = 256;

/// `s < edge`; false for NaN (a NaN distance is never kept).
#[inline(always)]
fn below(s: f32, edge: f32) -> bool {
    s < edge
}

/// The least non-negative f32 `s` with `(s * scale) as u32 >= c` (`c` >= 1): a value is in
/// bucket `c` or above exactly when it is not below this.
fn edge_of(c: usize, scale: f32) -> f32 {
    let cf = c as f32;
    let mut s = cf / scale;
    while s * scale < cf {
        s = next_up(s);
    }
    while s > 0.0 {
        let below = f32::from_bits(s.to_bits() - 1);
        if below * scale >= cf {
            s = below;
        } else {
            break;
        }
    }
    s
}

/// The terms `q1..D` of a squared distance added to the partial sum `s` of the first `q1`
/// (in `d` order), tested against `edge` after `q2` and after all; `None` once not below.
#[inline(always)]
fn rest_of_sum<E: Entry, const D: usize>(
    wk: &[E; D],
    u: &[f32; D],
    mut s: f32,
    q1: usize,
    q2: usize,
    edge: f32,
) -> Option<f32> {
    for d in q1..q2 {
        let diff = u[d] - wk[d].get(TABLE_SCALES.w);
        s += diff * diff;
    }
    if !below(s, edge) {
        return None;
    }
    for d in q2..D {
        let diff = u[d] - wk[d].get(TABLE_SCALES.w);
        s += diff * diff;
    }
    if !below(s, edge) {
        return None;
    }
    Some(s)
}

/// The next larger f32 of a non-negative finite value.
#[inline(always)]
fn next_up(x: f32) -> f32 {
    f32::from_bits(x.to_bits() + 1)
}

/// A value near the `r`-th smallest (1-based) of the squared distances `bits` (f32 bits),
/// at or above it when that is at most `max`: a 64-bucket histogram over `[0, max]` (the
/// values above `max` in the last bucket), then over the bucket that holds it, at most
/// three times. Speeds the scan up; the result does not depend on it.
fn sample_quantile(bits: &[u32], r: usize, max: f32) -> f32 {
    let mut range = max;
    for level in 0..3 {
        let s = 64.0 / range;
        let mut h = [0u16; 65];
        for &x in bits {
            let b = ((f32::from_bits(x) * s) as usize).min(64);
            h[b] += 1;
        }
        let mut cum = 0;
        let mut j = 0;
        while j < 64 {
            cum += h[j] as usize;
            if cum >= r {
                break;
            }
            j += 1;
        }
        if j >= 64 {
            return range;
        }
        let t = (j + 1) as f32 / s;
        if j >= 8 || level == 2 || !below(0.0, t) {
            return t;
        }
        range = t;
    }
    range
}

/// The neurons kept by [`Ranking::select_bucketed`] and its histogram (in [`RankScratch`]).
#[derive(Debug, Clone)]
struct Buffers {
    /// [`dist_key`] of each kept neuron's squared distance.
    key: [u32; CAPACITY],
    index: [u16; CAPACITY],
    bucket: [u8; CAPACITY],
    /// Kept neurons per bucket.
    hist: [u16; BUCKETS],
}

/// [`Ranking::select_bucketed`]'s state: the buffers and the scalars (kept apart, so that
/// the scalars can live in registers through the scan).
struct Collector<'a> {
    buf: &'a mut Buffers,
    kept: usize,
    /// The cut: neurons of bucket `cut` and above are not kept.
    cut: usize,
    /// Kept neurons below the cut.
    live: usize,
    scale: f32,
    /// The least squared distance of bucket `cut`: a neuron is kept only when below it.
    edge: f32,
}

impl Buffers {
    const fn new() -> Self {
        Buffers {
            key: [0; CAPACITY],
            index: [0; CAPACITY],
            bucket: [0; CAPACITY],
            hist: [0; BUCKETS],
        }
    }
}

impl<'a> Collector<'a> {
    fn new(buf: &'a mut Buffers) -> Self {
        Collector {
            buf,
            kept: 0,
            cut: BUCKETS,
            live: 0,
            scale: 1.0,
            edge: 0.0,
        }
    }

    fn set_scale(&mut self, scale: f32) {
        self.scale = scale;
        self.edge = edge_of(self.cut, scale);
    }

    /// Keeps neuron `k` at squared distance `s` (below `edge`, so below the cut) and lowers
    /// the cut while the buckets below its last one hold `K` kept neurons. False when the
    /// buffer is full of live neurons.
    #[inline(always)]
    fn push<const K: usize>(&mut self, s: f32, k: usize) -> bool {
        if self.kept == CAPACITY {
            self.kept = self.buf.compact(self.kept, self.cut);
            if self.kept == CAPACITY {
                return false;
            }
        }
        let b = ((s * self.scale) as usize).min(BUCKETS - 1);
        let n = self.kept;
        let buf = &mut *self.buf;
        buf.key[n] = dist_key(s);
        buf.index[n] = k as u16;
        buf.bucket[n] = b as u8;
        self.kept = n + 1;
        buf.hist[b] += 1;
        self.live += 1;
        if self.live >= K && self.live - buf.hist[self.cut - 1] as usize >= K {
            while self.live - buf.hist[self.cut - 1] as usize >= K {
                self.cut -= 1;
                self.live -= buf.hist[self.cut] as usize;
            }
            self.edge = edge_of(self.cut, self.scale);
        }
        true
    }
}

impl Buffers {
    /// Drops the kept neurons at or above the cut; returns how many stay.
    #[cold]
    fn compact(&mut self, kept: usize, cut: usize) -> usize {
        let mut n = 0;
        for j in 0..kept {
            if (self.bucket[j] as usize) < cut {
                self.key[n] = self.key[j];
                self.index[n] = self.index[j];
                self.bucket[n] = self.bucket[j];
                n += 1;
            }
        }
        n
    }

    /// The `K` closest kept neurons, sorted by (squared distance, index), into `dist` and
    /// `index` (at least `K` live).
    fn emit<const K: usize>(
        &mut self,
        kept: usize,
        cut: usize,
        live: usize,
        dist: &mut [u32; K],
        index: &mut [u16; K],
    ) {
        // bucket counts to start positions
        let mut acc = 0u16;
        for h in self.hist[..cut].iter_mut() {
            let n = *h;
            *h = acc;
            acc += n;
        }
        let last = cut - 1;
        let last_start = self.hist[last] as usize;
        // counting sort by bucket, index order within a bucket; the last bucket's neurons
        // beyond position K wait
        let (keys, indices, buckets) =
            (&self.key[..kept], &self.index[..kept], &self.bucket[..kept]);
        let hist = &mut self.hist[..cut];
        for ((&x, &i), &b) in keys.iter().zip(indices.iter()).zip(buckets.iter()) {
            if let Some(h) = hist.get_mut(b as usize) {
                let p = *h as usize;
                *h += 1;
                if p < K {
                    dist[p] = x;
                    index[p] = i;
                }
            }
        }
        // insertion sort: stable, and only within buckets (the buckets are in order)
        for i in 1..K {
            let x = dist[i];
            if dist[i - 1] <= x {
                continue;
            }
            let xi = index[i];
            let mut p = i;
            while p > 0 && dist[p - 1] > x {
                dist[p] = dist[p - 1];
                index[p] = index[p - 1];
                p -= 1;
            }
            dist[p] = x;
            index[p] = xi;
        }
        // the last bucket's surplus, in index order (after every neuron of that bucket
        // already placed): each enters when strictly closer than the K-th
        if live > K {
            let mut skip = K - last_start;
            let mut surplus = live - K;
            for ((&x, &i), &b) in keys.iter().zip(indices.iter()).zip(buckets.iter()) {
                if b as usize != last {
                    continue;
                }
                if skip > 0 {
                    skip -= 1;
                    continue;
                }
                if x < dist[K - 1] {
                    let mut p = K - 1;
                    while p > 0 && dist[p - 1] > x {
                        dist[p] = dist[p - 1];
                        index[p] = index[p - 1];
                        p -= 1;
                    }
                    dist[p] = x;
                    index[p] = i;
                }
                surplus -= 1;
                if surplus == 0 {
                    break;
                }
            }
        }
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
    /// (`N` keys on the stack: the host reference). [`RankMode::PartialSelect`] keeps the
    /// neurons below a cut in a histogram of the squared distances (in `scratch`), lowers the
    /// cut as closer neurons come in, and skips a neuron as soon as a partial sum of its
    /// squared distance reaches the cut: the partial sums of non-negative terms never
    /// decrease (rounding is monotonic), so such a neuron's full distance is larger too and
    /// it could not enter (see `select_bucketed`; the heap scan when it cannot decide). The tables are finite (inputs are checked,
    /// checkpoints must be finite, the weight update is a convex step), so no NaN reaches the
    /// order.
    pub fn compute<E: Entry, const N: usize, const D: usize>(
        &mut self,
        w: &[[E; D]; N],
        u: &[f32; D],
        scratch: &mut RankScratch,
        mode: RankMode,
    ) {
        const { assert!(K <= N && K > 0 && N <= u16::MAX as usize) };
        match mode {
            RankMode::FullSort => self.full_sort(w, u),
            RankMode::PartialSelect => self.select(w, u, &mut scratch.buf),
        }
    }

    /// [`RankMode::FullSort`]: all `N` keys sorted (on the stack), the first `K` kept.
    #[inline(never)]
    fn full_sort<E: Entry, const N: usize, const D: usize>(
        &mut self,
        w: &[[E; D]; N],
        u: &[f32; D],
    ) {
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

    /// [`RankMode::PartialSelect`]: the bucketed scan, or (when it cannot decide) the heap.
    /// Not inlined: inlined into a caller that holds the ranking deep inside a larger
    /// struct, the ranking's addresses took extra instructions on every access (measured on
    /// the Cortex-M4F: +36k instructions per ranking in `Controller::begin`).
    #[inline(never)]
    fn select<E: Entry, const N: usize, const D: usize>(
        &mut self,
        w: &[[E; D]; N],
        u: &[f32; D],
        buf: &mut Buffers,
    ) {
        if !self.select_bucketed(w, u, buf) {
            self.select_plain(w, u);
        }
    }

    /// The scan with a histogram of the squared distances instead of a heap.
    ///
    /// Buckets are linear in the squared distance: `b(s) = (s * scale) as u32`, which never
    /// decreases as `s` grows (a rounded product and a truncation are both monotonic), so a
    /// neuron in a lower bucket is strictly closer than one in a higher bucket. `scale` puts
    /// [`BUCKETS`] buckets below a threshold from a sample (the first `K` neurons: the
    /// `r`-th smallest of their distances, `r` chosen so that about `1.75 K` of all `N` are
    /// expected below it). The scan keeps every neuron whose bucket is below the cut `c`;
    /// `c` starts at [`BUCKETS`] and comes down whenever the buckets below `c - 1` alone hold
    /// `K` kept neurons, so a neuron of bucket `c` or above could not be among the `K`
    /// closest. A neuron is skipped as soon as a partial sum of its squared distance reaches
    /// `edge(c)`, the least value of bucket `c` (partial sums of non-negative terms never
    /// decrease). At the end the kept neurons below the cut, at least `K`, are placed by
    /// bucket (a counting sort, index order within a bucket) and sorted by an insertion sort
    /// that only moves neurons within a bucket; the last bucket's surplus is merged in.
    /// Exactly the pairs and order of [`RankMode::FullSort`].
    ///
    /// Returns false, leaving the ranking to the heap scan, when it cannot decide: fewer
    /// than `K` neurons below the threshold (an unlucky sample), more than [`CAPACITY`] kept
    /// at once (many equal distances), no usable scale (all sample distances zero), or `K`
    /// too large for the buffers.
    fn select_bucketed<E: Entry, const N: usize, const D: usize>(
        &mut self,
        w: &[[E; D]; N],
        u: &[f32; D],
        buf: &mut Buffers,
    ) -> bool {
        if 2 * K > CAPACITY {
            return false;
        }
        let (first, rest) = w.split_at(K);
        // the buffers hold the last call's neurons: only the histogram must start at zero
        buf.hist = [0; BUCKETS];
        let mut c = Collector::new(buf);
        // the sample: the first K distances, in `c.key` as f32 bits for now
        let mut sum = 0.0f32;
        for (x, wk) in c.buf.key.iter_mut().zip(first.iter()) {
            let s = dist2(wk, u);
            sum += s;
            *x = s.to_bits();
        }
        let r = (7 * K * K).div_ceil(4 * N).clamp(1, K);
        // the r-th smallest (r about a fifth of K) lies below twice the mean in any but
        // very skewed samples; when not, the histogram's last bucket holds it and the
        // threshold is just tighter (the scan may then fall back to the heap)
        let threshold = sample_quantile(&c.buf.key[..K], r, 2.0 * sum / K as f32);
        let scale = BUCKETS as f32 / threshold;
        if !(scale.is_finite() && scale > 0.0) {
            return false;
        }
        c.set_scale(scale);
        for k in 0..K {
            let s = f32::from_bits(c.buf.key[k]);
            if s < c.edge && !c.push::<K>(s, k) {
                return false;
            }
        }
        // the scan: the cut's edge in a local (the collector only changes it in `push`),
        // and each neuron's number from its address (one pointer steps through the table).
        // The partial sums are tested after 5, 7 and 8 of 8 terms (measured on the
        // Cortex-M4F against 4/6/8, 5/6/8 and 6/7/8: fewest instructions).
        let (q1, q2) = (5 * D / 8, 7 * D / 8);
        let mut edge = c.edge;
        let base = w.as_ptr() as usize;
        // an opaque table address: with the address of a static known, the loop indexed
        // from it (two more instructions per neuron) instead of stepping a pointer
        let rest = core::hint::black_box(rest);
        let number = |wk: &[E; D]| (wk.as_ptr() as usize - base) / core::mem::size_of::<[E; D]>();
        // two neurons per step: their first terms together (the loop's own instructions
        // once per pair)
        let mut pairs = rest.chunks_exact(2);
        for pair in &mut pairs {
            let (wa, wb) = (&pair[0], &pair[1]);
            let (mut sa, mut sb) = (0.0, 0.0);
            for d in 0..q1 {
                let da = u[d] - wa[d].get(TABLE_SCALES.w);
                sa += da * da;
                let db = u[d] - wb[d].get(TABLE_SCALES.w);
                sb += db * db;
            }
            // NaN fails the comparison too: it is never kept
            if below(sa, edge) {
                if let Some(s) = rest_of_sum(wa, u, sa, q1, q2, edge) {
                    if !c.push::<K>(s, number(wa)) {
                        return false;
                    }
                    edge = c.edge;
                }
            }
            if below(sb, edge) {
                if let Some(s) = rest_of_sum(wb, u, sb, q1, q2, edge) {
                    if !c.push::<K>(s, number(wb)) {
                        return false;
                    }
                    edge = c.edge;
                }
            }
        }
        for wk in pairs.remainder() {
            let mut s = 0.0;
            for d in 0..q1 {
                let diff = u[d] - wk[d].get(TABLE_SCALES.w);
                s += diff * diff;
            }
            if below(s, edge) {
                if let Some(s) = rest_of_sum(wk, u, s, q1, q2, edge) {
                    if !c.push::<K>(s, number(wk)) {
                        return false;
                    }
                    edge = c.edge;
                }
            }
        }
        if c.live < K {
            return false;
        }
        let (kept, cut, live) = (c.kept, c.cut, c.live);
        buf.emit(kept, cut, live, &mut self.dist, &mut self.index);
        true
    }

    /// The plain heap scan: the first `K` neurons make the heap, every later one that is
    /// closer than the `K`-th best so far replaces it.
    fn select_plain<E: Entry, const N: usize, const D: usize>(
        &mut self,
        w: &[[E; D]; N],
        u: &[f32; D],
    ) {
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
                let diff = u[d] - wk[d].get(TABLE_SCALES.w);
                s += diff * diff;
            }
            if s > worst {
                continue;
            }
            for d in half..D {
                let diff = u[d] - wk[d].get(TABLE_SCALES.w);
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
        // a fixed seed: the same cases every run
        #![proptest_config(ProptestConfig {
            rng_seed: proptest::test_runner::RngSeed::Fixed(0x7a4c),
            ..ProptestConfig::default()
        })]
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
            let mut scratch = RankScratch::new();
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
        // a fixed seed: the same cases every run
        #![proptest_config(ProptestConfig {
            rng_seed: proptest::test_runner::RngSeed::Fixed(0x7a4d),
            ..ProptestConfig::default()
        })]
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
            let mut scratch = RankScratch::new();
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

    /// The bucketed scan on its own (no heap fallback): when it decides, exactly the full
    /// sort; on random stage-1 tables it decides nearly always. Snapped coordinates make
    /// many equal distances (equal keys within a bucket, a last bucket with a surplus).
    #[test]
    fn bucketed_scan_matches_full_sort_and_decides() {
        use rand_core::SeedableRng;
        for snap in [false, true] {
            let mut decided = 0;
            for seed in 0..200u64 {
                let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(seed);
                let mut w = [[0.0f32; 8]; 1000];
                for wk in w.iter_mut() {
                    for x in wk.iter_mut() {
                        *x = crate::net::uniform(&mut rng, 0.0, 640.0);
                        if snap {
                            *x = (*x / 128.0).round() * 128.0;
                        }
                    }
                }
                let u: [f32; 8] =
                    core::array::from_fn(|_| crate::net::uniform(&mut rng, 100.0, 540.0));
                let mut full = Ranking::<1000>::new();
                full.full_sort(&w, &u);
                let mut part = Ranking::<128>::new();
                let mut scratch = RankScratch::new();
                if part.select_bucketed(&w, &u, &mut scratch.buf) {
                    decided += 1;
                    assert_eq!(
                        &part.index[..],
                        &full.index[..128],
                        "seed {seed} snap {snap}"
                    );
                    assert_eq!(&part.dist[..], &full.dist[..128], "seed {seed} snap {snap}");
                }
            }
            assert!(decided >= 190, "decided {decided} of 200 (snap {snap})");
        }
    }

    /// Equal distances across the last bucket: a surplus of equal keys, ordered by index.
    #[test]
    fn bucketed_scan_with_a_surplus_of_equal_distances() {
        // 300 neurons on 3 shells around u: 30 close, 200 at one distance, 70 far
        let mut w = [[0.0f32; 2]; 300];
        for (k, wk) in w.iter_mut().enumerate() {
            let r = if k % 10 == 3 {
                1.0
            } else if k % 10 < 8 {
                5.0
            } else {
                9.0
            };
            *wk = if k % 2 == 0 { [r, 0.0] } else { [0.0, -r] };
        }
        let u = [0.0, 0.0];
        let mut full = Ranking::<300>::new();
        full.full_sort(&w, &u);
        let mut part = Ranking::<40>::new();
        part.compute(&w, &u, &mut RankScratch::new(), RankMode::PartialSelect);
        assert_eq!(&part.indices()[..], &full.indices()[..40]);
        assert_eq!(&part.dist[..], &full.dist[..40]);
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
        let mut scratch = RankScratch::new();
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
        let mut s = RankScratch::new();
        let mut r = Ranking::<4>::new();
        r.compute(&w, &[2.9, 0.0], &mut s, RankMode::FullSort);
        assert_eq!(r.indices(), &[3, 2, 1, 0]);
        assert!((r.distance(0) - 0.1).abs() < 1e-6);
    }
}
