//! The neuron tables of a topology representing network.

use crate::config::Init;
use crate::entry::{Entry, Table, TABLE_SCALES};
use rand_core::RngCore;

/// A topology representing network of `N` neurons mapping `D`-dimensional camera
/// coordinates to `M` pressures. Each neuron `k` holds a weight `w_k` (a point of the
/// input space), a pressure `P_k` and a Jacobian `A_k` (M x D) of the local affine map
/// `P(u) = P_k + A_k (u - w_k)` (8.1, 8.23).
///
/// All tables are statically sized; [`Trn::new`] is a `const fn`, so firmware can place a
/// network in a `static`. Entries are [`Table`]: `f32`, or `i16` fixed point with the
/// `compact` feature (steps in [`TABLE_SCALES`]); the accessors give f32 values either way.
#[derive(Clone, PartialEq)]
pub struct Trn<const N: usize, const D: usize, const M: usize> {
    pub(crate) w: [[Table; D]; N],
    pub(crate) p: [[Table; M]; N],
    pub(crate) a: [[[Table; D]; M]; N],
}

/// The stage-1 network: 1000 neurons, 8-D lights, 5 pressures, 5x8 Jacobians (212,000 bytes;
/// 106,000 compact).
pub type Stage1Net = Trn<1000, 8, 5>;
/// The stage-2 network: 200 neurons, 4-D gripper centre, 3 pressures, 3x4 Jacobians (15,200
/// bytes; 7,600 compact).
pub type Stage2Net = Trn<200, 4, 3>;

impl<const N: usize, const D: usize, const M: usize> Default for Trn<N, D, M> {
    fn default() -> Self {
        Self::new()
    }
}

impl<const N: usize, const D: usize, const M: usize> core::fmt::Debug for Trn<N, D, M> {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "Trn<{N}, {D}, {M}>")
    }
}

/// Uniform f32 in `[lo, hi)` from 24 random bits.
pub(crate) fn uniform(rng: &mut impl RngCore, lo: f32, hi: f32) -> f32 {
    let u = (rng.next_u32() >> 8) as f32 * (1.0 / 16_777_216.0);
    lo + (hi - lo) * u
}

impl<const N: usize, const D: usize, const M: usize> Trn<N, D, M> {
    /// Number of neurons.
    pub const NEURONS: usize = N;
    /// Bytes of the three tables.
    pub const TABLE_BYTES: usize = Self::VALUES * core::mem::size_of::<Table>();
    /// Values in the three tables.
    pub const VALUES: usize = N * (D + M + M * D);

    /// A network with all tables zero.
    pub const fn new() -> Self {
        Trn {
            w: [[Table::ZERO; D]; N],
            p: [[Table::ZERO; M]; N],
            a: [[[Table::ZERO; D]; M]; N],
        }
    }

    /// Assigns random initial values (Sec. 8.4.1: "all of the weights, pressures and
    /// Jacobians initially were assigned randomly"). Even coordinates are x, odd ones y.
    pub fn init_random(&mut self, rng: &mut impl RngCore, init: &Init) {
        for k in 0..N {
            for d in 0..D {
                let (lo, hi) = if d % 2 == 0 { init.x } else { init.y };
                self.w[k][d] = Table::put(uniform(rng, lo, hi), TABLE_SCALES.w);
            }
            for m in 0..M {
                let x = uniform(rng, -init.pressure, init.pressure);
                self.p[k][m] = Table::put(x, TABLE_SCALES.p);
            }
            for m in 0..M {
                for d in 0..D {
                    let x = uniform(rng, -init.jacobian, init.jacobian);
                    self.a[k][m][d] = Table::put(x, TABLE_SCALES.a);
                }
            }
        }
    }

    /// All weights as stored (for ranking; steps [`TABLE_SCALES`]`.w`).
    pub fn weights(&self) -> &[[Table; D]; N] {
        &self.w
    }

    /// The weight `w_k`.
    pub fn weight(&self, k: usize) -> [f32; D] {
        self.w[k].map(|x| x.get(TABLE_SCALES.w))
    }

    /// The pressure `P_k`.
    pub fn pressure(&self, k: usize) -> [f32; M] {
        self.p[k].map(|x| x.get(TABLE_SCALES.p))
    }

    /// The Jacobian `A_k`, row-major (M rows of D).
    pub fn jacobian(&self, k: usize) -> [[f32; D]; M] {
        self.a[k].map(|row| row.map(|x| x.get(TABLE_SCALES.a)))
    }

    /// Sets neuron `k`'s entries (tests, tools; rounded to the steps in a compact build).
    pub fn set_neuron(&mut self, k: usize, w: [f32; D], p: [f32; M], a: [[f32; D]; M]) {
        self.w[k] = w.map(|x| Table::put(x, TABLE_SCALES.w));
        self.p[k] = p.map(|x| Table::put(x, TABLE_SCALES.p));
        self.a[k] = a.map(|row| row.map(|x| Table::put(x, TABLE_SCALES.a)));
    }

    /// The local affine map of neuron `k` at `u` (8.1): `P_k + A_k (u - w_k)`.
    #[inline(always)]
    pub fn local_output(&self, k: usize, u: &[f32; D]) -> [f32; M] {
        let (w, p, a) = (&self.w[k], &self.p[k], &self.a[k]);
        let (sw, sa) = (TABLE_SCALES.w, TABLE_SCALES.a);
        // u - w_k once, not once per row (the same values)
        let diff: [f32; D] = core::array::from_fn(|d| u[d] - w[d].get(sw));
        let mut out = p.map(|x| x.get(TABLE_SCALES.p));
        for (o, row) in out.iter_mut().zip(a.iter()) {
            let mut acc = 0.0;
            for d in 0..D {
                acc += row[d].get(sa) * diff[d];
            }
            *o += acc;
        }
        out
    }

    /// True when every table entry is finite.
    pub fn is_finite(&self) -> bool {
        let s = TABLE_SCALES;
        self.w.iter().flatten().all(|x| x.get(s.w).is_finite())
            && self.p.iter().flatten().all(|x| x.get(s.p).is_finite())
            && self
                .a
                .iter()
                .flatten()
                .flatten()
                .all(|x| x.get(s.a).is_finite())
    }

    /// Calls `f` on every table value in checkpoint order: all weights, all pressures,
    /// all Jacobians, neuron by neuron.
    pub(crate) fn for_each_value(&self, mut f: impl FnMut(f32)) {
        let s = TABLE_SCALES;
        self.w.iter().flatten().for_each(|&x| f(x.get(s.w)));
        self.p.iter().flatten().for_each(|&x| f(x.get(s.p)));
        self.a
            .iter()
            .flatten()
            .flatten()
            .for_each(|&x| f(x.get(s.a)));
    }

    /// Value `i` in checkpoint order ([`Trn::for_each_value`]): weights, pressures, then
    /// Jacobians, neuron by neuron; `None` beyond [`Trn::VALUES`].
    pub(crate) fn value(&self, i: usize) -> Option<f32> {
        let s = TABLE_SCALES;
        let (weights, pressures) = (N * D, N * M);
        if i < weights {
            Some(self.w[i / D][i % D].get(s.w))
        } else if i < weights + pressures {
            let j = i - weights;
            Some(self.p[j / M][j % M].get(s.p))
        } else if i < Self::VALUES {
            let j = i - weights - pressures;
            let (k, r) = (j / (M * D), j % (M * D));
            Some(self.a[k][r / D][r % D].get(s.a))
        } else {
            None
        }
    }

    /// Mutable counterpart of [`Trn::for_each_value`] (each value read, passed to `f`,
    /// written back; rounded to the steps in a compact build).
    pub(crate) fn for_each_value_mut(&mut self, mut f: impl FnMut(&mut f32)) {
        let s = TABLE_SCALES;
        let mut through = |e: &mut Table, scale| {
            let mut x = e.get(scale);
            f(&mut x);
            *e = Table::put(x, scale);
        };
        // one loop per table over its flat slice (not loops nested per neuron, which the
        // optimiser unrolls around every call of `f`)
        self.w
            .as_flattened_mut()
            .iter_mut()
            .for_each(|e| through(e, s.w));
        self.p
            .as_flattened_mut()
            .iter_mut()
            .for_each(|e| through(e, s.p));
        self.a
            .as_flattened_mut()
            .as_flattened_mut()
            .iter_mut()
            .for_each(|e| through(e, s.a));
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand_core::SeedableRng;

    #[test]
    fn table_sizes_match_the_reading_notes() {
        let (s1, s2) = if cfg!(feature = "compact") {
            (106_000, 7_600)
        } else {
            (212_000, 15_200)
        };
        assert_eq!(Stage1Net::TABLE_BYTES, s1);
        assert_eq!(Stage2Net::TABLE_BYTES, s2);
        assert_eq!(core::mem::size_of::<Stage1Net>(), s1);
        assert_eq!(core::mem::size_of::<Stage2Net>(), s2);
    }

    #[test]
    fn local_output_is_8_1() {
        let mut net = Trn::<1, 2, 1>::new();
        net.set_neuron(0, [1.0, 2.0], [0.5], [[0.01, -0.02]]);
        let out = net.local_output(0, &[3.0, 1.0]);
        // 0.5 + 0.01*2 + (-0.02)*(-1) = 0.54 (within the rounding of a compact build's
        // Jacobian entries, 2^-19 each)
        assert!((out[0] - 0.54).abs() < 1e-5, "{}", out[0]);
    }

    #[test]
    fn random_init_is_seeded_and_in_range() {
        let init = crate::Config::paper().stage1.init;
        let mut a = Trn::<50, 4, 2>::new();
        let mut b = Trn::<50, 4, 2>::new();
        a.init_random(
            &mut rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(7),
            &init,
        );
        b.init_random(
            &mut rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(7),
            &init,
        );
        assert!(a == b);
        assert!((0..50).all(|k| {
            let w = a.weight(k);
            (0.0..=640.0).contains(&w[0]) && (0.0..=480.0).contains(&w[1])
        }));
        assert!((0..50).all(|k| a.pressure(k).iter().all(|p| p.abs() <= 1.0)));
    }
}
