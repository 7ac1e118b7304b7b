//! The learning and control rules of the chapter, as pure functions over a network and a
//! ranking. The state machine in [`crate::stage`] calls them in the paper's order.
//!
//! Two deliberate deviations apply to every rule here, both named in READING-NOTES.md:
//! - **Normalised averages** (8.5, 8.11, 8.14, 8.19, 8.20, 8.24, 8.29): as printed the sums
//!   of `alpha(r) = exp(-r/10)` are not normalised (their total is about 10.5), which scales
//!   every output about tenfold and makes the fine loop diverge. Here each average is divided
//!   by the sum of the weights over the ranks summed.
//! - **Truncation to the `K` closest ranks.** The paper sums and updates over all `N`
//!   neurons. Only the ranks `r < K` are used here. In the averages (`alpha`, range 10) the
//!   weight dropped is below `exp(-K/10)` (`K = 128`: 2.8e-6 relative), and with the paper's
//!   neighbourhood (`sigma = 5`) the update rates dropped are below `exp(-K/5)` (7.6e-12):
//!   under f32 resolution; `tests::truncation_*` bound the difference against the full sums.
//!   **Not so with the project preset's shrinking neighbourhood**, which starts at
//!   `sigma = 50` ([`crate::Config::project_default`]): there the cut at rank 128 drops
//!   `exp(-128/50)` = 7.7 % of each update's mass in the first learning steps (0.15 % at step
//!   50, under f32 resolution from step 100). Measured against the untruncated updates
//!   (`K = N`, host build, sigma's earlier time constant of 100 steps; tuning seeds 1-3, 300
//!   trials, the fixed-budget evaluation):
//!   combined noise-free error after the coarse move + 2 fine moves 4.44 px truncated against
//!   3.80 px untruncated, 3.74 against 3.36 fine moves with the stop rule. `K = N` does not
//!   fit the firmware's RAM budget (the rankings and rate tables of 1000 ranks); the cost is
//!   named here and left for the neighbourhood schedule to recover.

pub use crate::config::DvRule;
use crate::entry::{Entry, Table, TABLE_SCALES};
use crate::error::{Error, Result};
use crate::net::Trn;
use crate::rank::Ranking;

/// `exp(-r / range)` for `r < K`: the averaging weights `alpha(r)` (8.6, range 10) or the
/// neighbourhood factor of the learning rates (8.10, range `sigma` = 5).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Falloff<const K: usize> {
    /// `exp(-r / range)` for each rank.
    pub value: [f32; K],
}

impl<const K: usize> Falloff<K> {
    /// All zero (before [`Falloff::compute`]).
    pub const fn zero() -> Self {
        Falloff { value: [0.0; K] }
    }

    /// `exp(-r / range)` for `r = 0..K` (`libm::expf`, bit for bit; see `exp_nonpositive`).
    pub fn compute(range: f32) -> Self {
        let mut table = Self::zero();
        table.fill(range);
        table
    }

    /// [`Falloff::compute`] in place: the table a stage holds is rewritten where it is, with
    /// no second table on the stack (512 bytes at `K = 128`, on the compact build's deepest
    /// call chain: a session's configuration preparing both stages).
    pub fn fill(&mut self, range: f32) {
        for (r, v) in self.value.iter_mut().enumerate() {
            *v = exp_nonpositive(-(r as f32) / range);
        }
    }

    /// `exp(-r / range)` for `r = 0..K` as products `exp(-16 i / range) exp(-j / range)`
    /// (`r = 16 i + j`): `K / 16 + 16` exponentials instead of `K`, for the neighbourhood
    /// table that a shrinking sigma changes at every learning step (issue 18: 7,800 of a
    /// learning step's instructions on the Cortex-M4F went to its 128 exponentials). The
    /// ranks below 16 are [`Falloff::compute`]'s values bit for bit; above, a value differs
    /// from it by a few ulp (one more rounding), and is as close to the exact exponential
    /// as it: about 1e-6 relative either way, from rounding `r / range`
    /// (`tests::block_products_are_as_close_as_the_direct_exponentials`).
    pub fn compute_by_blocks(range: f32) -> Self {
        let mut table = Self::zero();
        table.fill_by_blocks(range);
        table
    }

    /// [`Falloff::compute_by_blocks`] in place (see [`Falloff::fill`]).
    pub fn fill_by_blocks(&mut self, range: f32) {
        const BLOCK: usize = 16;
        let mut low = [0.0f32; BLOCK];
        for (j, v) in low.iter_mut().enumerate() {
            *v = exp_nonpositive(-(j as f32) / range);
        }
        for (i, block) in self.value.chunks_mut(BLOCK).enumerate() {
            let high = if i == 0 {
                1.0
            } else {
                exp_nonpositive(-((i * BLOCK) as f32) / range)
            };
            for (v, &l) in block.iter_mut().zip(low.iter()) {
                *v = high * l;
            }
        }
    }

    /// Sum of the first `n` values (`n` is capped at `K`).
    pub fn sum(&self, n: usize) -> f32 {
        self.value[..n.min(K)].iter().sum()
    }
}

/// `libm::expf(x)`, bit for bit, with its common case inlined: for `-64 < x <= 0` the same
/// operations as libm's `expf` (FreeBSD's `e_expf.c`: argument reduction by `k ln 2`, the
/// rational approximation, then `* 2^k`), without the call, the checks for NaN, overflow
/// and underflow, or `scalbnf` (for `k >= -93` the result is normal and `y * 2^k` exact, as
/// `scalbnf` gives it). Anything else goes to `libm::expf`. The neighbourhood table is
/// recomputed at every learning step while sigma shrinks: 128 of these per step.
#[inline(always)]
pub(crate) fn exp_nonpositive(x: f32) -> f32 {
    const LN2_HI: f32 = f32::from_bits(0x3f31_7200);
    const LN2_LO: f32 = f32::from_bits(0x35bf_be8e);
    const INV_LN2: f32 = f32::from_bits(0x3fb8_aa3b);
    const P1: f32 = f32::from_bits(0x3e2a_aa8f);
    const P2: f32 = f32::from_bits(0xbb35_5215);
    let bits = x.to_bits();
    let hx = bits & 0x7fff_ffff;
    // positive, |x| >= 64, NaN: libm
    if bits >> 31 == 0 || hx >= 0x4280_0000 {
        return libm::expf(x);
    }
    let (k, hi, lo, xr);
    if hx > 0x3eb1_7218 {
        // |x| > 0.5 ln 2
        k = if hx > 0x3f85_1592 {
            // |x| > 1.5 ln 2 (x negative: the rounding offset is -0.5)
            (INV_LN2 * x + -0.5) as i32
        } else {
            -1
        };
        let kf = k as f32;
        hi = x - kf * LN2_HI;
        lo = kf * LN2_LO;
        xr = hi - lo;
    } else if hx > 0x3900_0000 {
        // |x| > 2^-14
        k = 0;
        hi = x;
        lo = 0.0;
        xr = x;
    } else {
        return 1.0 + x;
    }
    let xx = xr * xr;
    let c = xr - xx * (P1 + xx * P2);
    let y = 1.0 + (xr * c / (2.0 - c) - lo + hi);
    if k == 0 {
        y
    } else {
        y * f32::from_bits(((0x7f + k) as u32) << 23)
    }
}

/// (8.9, 8.17, 8.25): `w_k += gamma(r(k)) (target - w_k)` for the ranked neurons.
/// The rate of rank `r` is `coeff * gamma.value[r]` (`coeff` = prefactor x time factor).
#[inline(never)]
pub fn update_weights<const N: usize, const D: usize, const M: usize, const K: usize>(
    net: &mut Trn<N, D, M>,
    ranking: &Ranking<K>,
    gamma: &Falloff<K>,
    coeff: f32,
    target: &[f32; D],
) {
    for (&k, &f) in ranking.indices().iter().zip(gamma.value.iter()) {
        let g = coeff * f;
        let w = &mut net.w[k as usize];
        for d in 0..D {
            let x = w[d].get(TABLE_SCALES.w);
            w[d] = Table::put(x + g * (target[d] - x), TABLE_SCALES.w);
        }
    }
}

/// (8.5, 8.11, 8.19, 8.24), normalised: the average over ranks `r < min(ranks, K)` of the
/// neurons' local maps (8.1) at `u`, weighted by `alpha(r)`. The paper sums all `N`
/// ([`crate::StageConfig::coarse_ranks`]).
#[inline(never)]
pub fn coarse_output<const N: usize, const D: usize, const M: usize, const K: usize>(
    net: &Trn<N, D, M>,
    ranking: &Ranking<K>,
    alpha: &Falloff<K>,
    u: &[f32; D],
    ranks: usize,
) -> [f32; M] {
    let n = ranks.clamp(1, K);
    let mut out = [0.0; M];
    for (&k, &al) in ranking.indices()[..n].iter().zip(alpha.value.iter()) {
        let local = net.local_output(k as usize, u);
        for m in 0..M {
            out[m] += al * local[m];
        }
    }
    let norm = 1.0 / alpha.sum(n);
    out.iter_mut().for_each(|o| *o *= norm);
    out
}

/// The start of a learning trial in one pass over the ranked neurons: the weight update
/// [`update_weights`] towards `u`, then (supervised, `pressures = Some((coeff, p_ref))`)
/// the pressure update [`update_pressures`] at `x = u`, then [`coarse_output`] at `u` over
/// the first `ranks` ranks. Each neuron's `A_k (u - w_k)` is computed once, from the
/// updated weight, for both the pressure update and the average (the same products:
/// neither changes `A_k` or `w_k`), and not at all for a rank beyond the average when no
/// pressure update needs it. Every value is computed by the same operations in the same
/// order as the three functions one after the other (each neuron's updates touch only its
/// own entries; the average is summed in rank order), so the tables and the output are bit
/// for bit theirs.
#[inline(never)]
#[allow(clippy::too_many_arguments)]
pub fn learn_and_coarse_output<const N: usize, const D: usize, const M: usize, const K: usize>(
    net: &mut Trn<N, D, M>,
    ranking: &Ranking<K>,
    gamma: &Falloff<K>,
    w_coeff: f32,
    pressures: Option<(f32, &[f32; M])>,
    alpha: &Falloff<K>,
    u: &[f32; D],
    ranks: usize,
) -> [f32; M] {
    let n = ranks.clamp(1, K);
    let (ks_avg, ks_rest) = ranking.indices().split_at(n);
    let (g_avg, g_rest) = gamma.value.split_at(n);
    let mut out = [0.0; M];
    for ((&k, &f), &al) in ks_avg.iter().zip(g_avg.iter()).zip(alpha.value.iter()) {
        let local = learn_neuron(net, k as usize, w_coeff * f, pressures, f, u);
        for m in 0..M {
            out[m] += al * local[m];
        }
    }
    for (&k, &f) in ks_rest.iter().zip(g_rest.iter()) {
        let k = k as usize;
        if pressures.is_some() {
            learn_neuron(net, k, w_coeff * f, pressures, f, u);
        } else {
            let g = w_coeff * f;
            let w = &mut net.w[k];
            for d in 0..D {
                let x = w[d].get(TABLE_SCALES.w);
                w[d] = Table::put(x + g * (u[d] - x), TABLE_SCALES.w);
            }
        }
    }
    let norm = 1.0 / alpha.sum(n);
    out.iter_mut().for_each(|o| *o *= norm);
    out
}

/// One neuron of [`learn_and_coarse_output`]: the weight update with rate `g`, the pressure
/// update (rate `p_coeff * f`) when supervised, and the local map's output at `u` after both.
#[inline(always)]
fn learn_neuron<const N: usize, const D: usize, const M: usize>(
    net: &mut Trn<N, D, M>,
    k: usize,
    g: f32,
    pressures: Option<(f32, &[f32; M])>,
    f: f32,
    u: &[f32; D],
) -> [f32; M] {
    let s = TABLE_SCALES;
    let w = &mut net.w[k];
    for d in 0..D {
        let x = w[d].get(s.w);
        w[d] = Table::put(x + g * (u[d] - x), s.w);
    }
    let diff: [f32; D] = core::array::from_fn(|d| u[d] - w[d].get(s.w));
    let a = &net.a[k];
    let mut ad = [0.0; M];
    for (x, row) in ad.iter_mut().zip(a.iter()) {
        let mut acc = 0.0;
        for d in 0..D {
            acc += row[d].get(s.a) * diff[d];
        }
        *x = acc;
    }
    let p = &mut net.p[k];
    if let Some((p_coeff, p_ref)) = pressures {
        let gp = p_coeff * f;
        for m in 0..M {
            let pm = p[m].get(s.p);
            let local = pm + ad[m];
            p[m] = Table::put(pm + gp * (p_ref[m] - local), s.p);
        }
    }
    core::array::from_fn(|m| p[m].get(s.p) + ad[m])
}

/// (8.12, 8.18, 8.27): `P_k += gamma(r(k)) [p_ref - P_k - A_k (x - w_k)]`.
///
/// Unsupervised (8.12, 8.27): `p_ref` is the coarse pressure and `x` the position it reached
/// (`v_i`): each local map is taught to produce the applied pressure there.
/// Supervised (8.18): `p_ref = P_target` and `x = v_target`.
#[inline(never)]
pub fn update_pressures<const N: usize, const D: usize, const M: usize, const K: usize>(
    net: &mut Trn<N, D, M>,
    ranking: &Ranking<K>,
    gamma: &Falloff<K>,
    coeff: f32,
    p_ref: &[f32; M],
    x: &[f32; D],
) {
    for (&k, &f) in ranking.indices().iter().zip(gamma.value.iter()) {
        let g = coeff * f;
        let k = k as usize;
        let local = net.local_output(k, x);
        let p = &mut net.p[k];
        for m in 0..M {
            // p_ref - P_k - A_k (x - w_k) = p_ref - local
            let pm = p[m].get(TABLE_SCALES.p);
            p[m] = Table::put(pm + g * (p_ref[m] - local[m]), TABLE_SCALES.p);
        }
    }
}

/// The averaged Jacobian of the fine move (8.14, 8.20, 8.29), normalised, over ranks
/// `r <= fine_ranks` (S) and `r < K`.
#[inline(never)]
pub fn mean_jacobian<const N: usize, const D: usize, const M: usize, const K: usize>(
    net: &Trn<N, D, M>,
    ranking: &Ranking<K>,
    alpha: &Falloff<K>,
    fine_ranks: usize,
) -> [[f32; D]; M] {
    let n = (fine_ranks + 1).min(K);
    let mut a_bar = [[0.0; D]; M];
    // three rows, then two, then one at a time (their sums stay in registers: one pass
    // over the ranks per group, not 40 sums through memory); every entry is still summed
    // over the ranks in rank order
    let (ks, als) = (&ranking.indices()[..n], &alpha.value[..n]);
    let mut m = 0;
    while m + 3 <= M {
        let [r0, r1, r2] = weighted_rows::<N, D, M, 3>(net, ks, als, m);
        a_bar[m] = r0;
        a_bar[m + 1] = r1;
        a_bar[m + 2] = r2;
        m += 3;
    }
    while m + 2 <= M {
        let [r0, r1] = weighted_rows::<N, D, M, 2>(net, ks, als, m);
        a_bar[m] = r0;
        a_bar[m + 1] = r1;
        m += 2;
    }
    if m < M {
        let [r0] = weighted_rows::<N, D, M, 1>(net, ks, als, m);
        a_bar[m] = r0;
    }
    let norm = 1.0 / alpha.sum(n);
    a_bar.iter_mut().flatten().for_each(|x| *x *= norm);
    a_bar
}

/// Rows `m0..m0 + R` of `sum_r alpha(r) A_k(r)` over the ranks given, summed in rank order.
#[inline(always)]
fn weighted_rows<const N: usize, const D: usize, const M: usize, const R: usize>(
    net: &Trn<N, D, M>,
    ks: &[u16],
    als: &[f32],
    m0: usize,
) -> [[f32; D]; R] {
    assert!(m0 + R <= M);
    let mut acc = [[0.0; D]; R];
    for (&k, &al) in ks.iter().zip(als.iter()) {
        let a = &net.a[k as usize];
        for j in 0..R {
            for d in 0..D {
                acc[j][d] += al * a[m0 + j][d].get(TABLE_SCALES.a);
            }
        }
    }
    acc
}

/// One fine move (8.14): `p_prev + A_bar (target - observed)`, clamped to `±limit`.
pub fn fine_output<const D: usize, const M: usize>(
    p_prev: &[f32; M],
    a_bar: &[[f32; D]; M],
    target: &[f32; D],
    observed: &[f32; D],
    limit: f32,
) -> [f32; M] {
    let a = nalgebra::SMatrix::<f32, M, D>::from_fn(|m, d| a_bar[m][d]);
    let e = nalgebra::SVector::<f32, D>::from_fn(|d, _| target[d] - observed[d]);
    let p = nalgebra::SVector::<f32, M>::from_column_slice(p_prev) + a * e;
    clamp(&p.into(), limit)
}

/// Clamps every pressure to `[-limit, limit]`.
pub fn clamp<const M: usize>(p: &[f32; M], limit: f32) -> [f32; M] {
    let mut out = *p;
    out.iter_mut().for_each(|x| *x = x.clamp(-limit, limit));
    out
}

/// `1 / (||dv||^2 + noise^2)` for the Jacobian rule, or [`Error::ZeroLengthDv`] when
/// `||dv|| < min` (NaN fails every comparison, so it is rejected too).
fn inverse_dv_norm2<const D: usize>(dv: &[f32; D], rule: DvRule) -> Result<f32> {
    let norm2: f32 = dv.iter().map(|x| x * x).sum();
    if norm2 >= rule.min * rule.min && norm2 > 0.0 && norm2.is_finite() {
        Ok(1.0 / (norm2 + rule.noise * rule.noise))
    } else {
        Err(Error::ZeroLengthDv)
    }
}

/// The trial's secant correction of the averaged Jacobian in mature operation
/// ([`crate::StageConfig::trial_secant`]): the rank-one rule of (8.15) applied to the trial's
/// copy `A_bar` of the average instead of the tables,
/// `A_bar += gain (dp - A_bar dv) dv^T / ||dv||^2` (`+ noise^2` with the rule's
/// regularisation, [`DvRule`]), with `dp` the last fine move's pressure change and `dv` the
/// change of position it made. Returns [`Error::ZeroLengthDv`] without touching `a_bar` when
/// `||dv||` is below the rule's minimum (camera noise would dominate the secant).
pub fn secant_update<const D: usize, const M: usize>(
    a_bar: &mut [[f32; D]; M],
    gain: f32,
    dp: &[f32; M],
    dv: &[f32; D],
    rule: DvRule,
) -> Result<()> {
    let inv = inverse_dv_norm2(dv, rule)?;
    secant_rows(a_bar.as_flattened_mut(), gain * inv, dp, dv);
    Ok(())
}

/// The rows of [`secant_update`], `row += g (dp_m - row . dv) dv` with `g = gain / ||dv||^2`;
/// one copy for every size (a cold path: once per fine move, a few hundred instructions),
/// so that the firmware's flash holds no unrolled copy per stage.
#[inline(never)]
fn secant_rows(a: &mut [f32], g: f32, dp: &[f32], dv: &[f32]) {
    for (row, &dpm) in a.chunks_exact_mut(dv.len()).zip(dp.iter()) {
        let predicted: f32 = row.iter().zip(dv.iter()).map(|(a, v)| a * v).sum();
        let gm = g * (dpm - predicted);
        row.iter_mut()
            .zip(dv.iter())
            .for_each(|(a, v)| *a += gm * v);
    }
}

/// (8.15, 8.21, 8.30 in the stage-1 form): the Widrow-Hoff / Broyden rank-one update
/// `A_k += gamma(r(k)) (dp - A_k dv) dv^T / ||dv||^2`.
///
/// Unsupervised (8.15): `dp = P_fine - P_prev`, `dv = v_f - v_prev`.
/// Supervised (8.21): `dp = P_target - P_fine`, `dv = v_target - v_f`.
///
/// (8.30) is printed as `a_k += eps e^{-r/5} a_k (c_target - c_f) dc^T / ||dc||^2`; with
/// `dp = a_bar (c_target - c_i)` that equals this form when `a_k` is close to `a_bar`
/// (READING-NOTES.md); this form is used for both stages.
///
/// The normalisation is `||dv||^2 + noise^2` with the rule's regularisation ([`DvRule`]).
/// Returns [`Error::ZeroLengthDv`] without touching the tables when `||dv||` is below the
/// rule's minimum.
#[inline(never)]
pub fn update_jacobians<const N: usize, const D: usize, const M: usize, const K: usize>(
    net: &mut Trn<N, D, M>,
    ranking: &Ranking<K>,
    gamma: &Falloff<K>,
    coeff: f32,
    dp: &[f32; M],
    dv: &[f32; D],
    rule: DvRule,
) -> Result<()> {
    let inv = inverse_dv_norm2(dv, rule)?;
    let ks = ranking.indices();
    for m in 0..M {
        jacobian_rows(
            &mut net.a,
            m,
            (ks, &gamma.value, &[]),
            coeff,
            dp[m],
            dv,
            inv,
        );
    }
    Ok(())
}

/// [`update_jacobians`] followed by [`mean_jacobian`] of the updated tables, in one pass:
/// row by row, each neuron's row is updated and, for the ranks averaged, added to the
/// average while it is in registers. Every value is computed by the same operations in the
/// same order as the two functions one after the other (rows are updated independently;
/// each entry of the average is summed over the ranks in rank order), so the tables and
/// the average are bit for bit theirs.
///
/// Returns [`Error::ZeroLengthDv`] without touching the tables (and without an average)
/// when `||dv||` is below the rule's minimum.
#[allow(clippy::too_many_arguments)]
#[inline(never)]
pub fn update_jacobians_and_mean<const N: usize, const D: usize, const M: usize, const K: usize>(
    net: &mut Trn<N, D, M>,
    ranking: &Ranking<K>,
    gamma: &Falloff<K>,
    coeff: f32,
    dp: &[f32; M],
    dv: &[f32; D],
    rule: DvRule,
    alpha: &Falloff<K>,
    fine_ranks: usize,
) -> Result<[[f32; D]; M]> {
    let inv = inverse_dv_norm2(dv, rule)?;
    let n = (fine_ranks + 1).min(K);
    let ranked = (
        ranking.indices().as_slice(),
        &gamma.value[..],
        &alpha.value[..n],
    );
    let mut a_bar = [[0.0; D]; M];
    for (m, out) in a_bar.iter_mut().enumerate() {
        *out = jacobian_rows(&mut net.a, m, ranked, coeff, dp[m], dv, inv);
    }
    let norm = 1.0 / alpha.sum(n);
    a_bar.iter_mut().flatten().for_each(|x| *x *= norm);
    Ok(a_bar)
}

/// Row `m` of the Jacobian rule (8.15, 8.21) for the ranked neurons `ks`, at rates
/// `coeff * gamma(r)`: `s = g (dp_m - A_k,m dv) / ||dv||^2`, `A_k,m += s dv`; returns
/// `sum_r alpha(r) A_k(r),m` over the first `als.len()` ranks (the updated rows, in rank
/// order). On the Cortex-M4F with `D = 8` the same operations run as a hand-written kernel
/// ([`crate::kernels`]), bit for bit.
#[allow(clippy::too_many_arguments)]
#[inline(never)]
fn jacobian_rows<const N: usize, const D: usize, const M: usize>(
    a: &mut [[[Table; D]; M]; N],
    m: usize,
    (ks, gamma, als): (&[u16], &[f32], &[f32]),
    coeff: f32,
    dpm: f32,
    dv: &[f32; D],
    inv: f32,
) -> [f32; D] {
    #[cfg(all(target_arch = "arm", target_abi = "eabihf", not(feature = "compact")))]
    if let Some(acc) = crate::kernels::jacobian_rows(a, m, (ks, gamma, als), coeff, dpm, dv, inv) {
        return acc;
    }
    let n = als.len();
    let (ks_avg, ks_rest) = ks.split_at(n.min(ks.len()));
    let (g_avg, g_rest) = gamma.split_at(n.min(gamma.len()));
    let sa = TABLE_SCALES.a;
    // the row updated in f32 and stored; returns the stored row's values
    let update = |stored: &mut [Table; D], g: f32| -> [f32; D] {
        let mut row = stored.map(|x| x.get(sa));
        let mut adv = 0.0;
        for d in 0..D {
            adv += row[d] * dv[d];
        }
        let s = g * (dpm - adv) * inv;
        for d in 0..D {
            row[d] += s * dv[d];
        }
        *stored = row.map(|x| Table::put(x, sa));
        stored.map(|x| x.get(sa))
    };
    let mut acc = [0.0; D];
    for ((&k, &f), &al) in ks_avg.iter().zip(g_avg.iter()).zip(als.iter()) {
        let row = update(&mut a[k as usize][m], coeff * f);
        for d in 0..D {
            acc[d] += al * row[d];
        }
    }
    for (&k, &f) in ks_rest.iter().zip(g_rest.iter()) {
        update(&mut a[k as usize][m], coeff * f);
    }
    acc
}

#[cfg(test)]
#[allow(clippy::needless_range_loop)]
mod tests {
    use super::*;
    use crate::rank::{RankMode, RankScratch};
    use proptest::prelude::*;

    fn ranked<const N: usize, const D: usize, const M: usize, const K: usize>(
        net: &Trn<N, D, M>,
        u: &[f32; D],
    ) -> Ranking<K> {
        let mut s = RankScratch::new();
        let mut r = Ranking::<K>::new();
        r.compute(&net.w, u, &mut s, RankMode::FullSort);
        r
    }

    fn two_neurons() -> Trn<2, 2, 1> {
        let mut net = Trn::<2, 2, 1>::new();
        net.set_neuron(0, [0.0, 0.0], [1.0], [[0.5, 0.0]]);
        net.set_neuron(1, [4.0, 0.0], [3.0], [[0.0, 1.0]]);
        net
    }

    // by-hand values beyond the compact build's table ranges (Jacobian entries of 0.5)
    #[cfg(not(feature = "compact"))]
    #[test]
    fn coarse_output_by_hand() {
        let net = two_neurons();
        let u = [1.0, 2.0];
        let r: Ranking<2> = ranked(&net, &u);
        assert_eq!(r.indices(), &[0, 1]);
        let alpha = Falloff::<2>::compute(10.0);
        // neuron 0: 1 + 0.5*1 = 1.5; neuron 1: 3 + 1*2 = 5
        let a1 = (-0.1f32).exp();
        let expect = (1.5 + a1 * 5.0) / (1.0 + a1);
        let out = coarse_output(&net, &r, &alpha, &u, usize::MAX);
        assert!((out[0] - expect).abs() < 1e-6, "{} vs {}", out[0], expect);
    }

    // by-hand values beyond the compact build's table ranges (Jacobian entries of 0.5)
    #[cfg(not(feature = "compact"))]
    #[test]
    fn weight_update_by_hand() {
        let mut net = two_neurons();
        let u = [1.0, 0.0];
        let r: Ranking<2> = ranked(&net, &u);
        update_weights(&mut net, &r, &Falloff { value: [0.5, 0.25] }, 1.0, &u);
        assert_eq!(net.w[0], [0.5, 0.0]);
        assert_eq!(net.w[1], [3.25, 0.0]);
    }

    // by-hand values beyond the compact build's table ranges (Jacobian entries of 0.5)
    #[cfg(not(feature = "compact"))]
    #[test]
    fn pressure_update_by_hand() {
        let mut net = two_neurons();
        let x = [2.0, 0.0];
        let r: Ranking<2> = ranked(&net, &x); // tie at distance 2: index order
        update_pressures(
            &mut net,
            &r,
            &Falloff { value: [1.0, 1.0] },
            0.5,
            &[2.0],
            &x,
        );
        // neuron 0: local = 1 + 0.5*2 = 2 -> no change; neuron 1: local = 3 + 0 = 3 -> 3 + 0.5*(2-3)
        assert_eq!(net.p[0], [1.0]);
        assert_eq!(net.p[1], [2.5]);
    }

    // by-hand values beyond the compact build's table ranges (Jacobian entries of 0.5)
    #[cfg(not(feature = "compact"))]
    #[test]
    fn jacobian_update_by_hand() {
        let mut net = two_neurons();
        let r: Ranking<2> = ranked(&net, &[0.0, 0.0]);
        // neuron 0: A=[0.5,0], dv=[2,0], dp=[3] -> A dv = 1, (3-1)/4 * dv = [1, 0] * gamma 1
        update_jacobians(
            &mut net,
            &r,
            &Falloff { value: [1.0, 0.0] },
            1.0,
            &[3.0],
            &[2.0, 0.0],
            DvRule::at_least(1e-3),
        )
        .unwrap();
        assert_eq!(net.a[0], [[1.5, 0.0]]);
        assert_eq!(net.a[1], [[0.0, 1.0]]);
        // with gamma = 1 the updated Jacobian maps dv exactly to dp (Broyden)
        assert_eq!(net.a[0][0][0] * 2.0, 3.0);
    }

    #[test]
    fn zero_dv_is_rejected_and_tables_untouched() {
        let mut net = two_neurons();
        let before = net.clone();
        let r: Ranking<2> = ranked(&net, &[0.0, 0.0]);
        let ones = Falloff { value: [1.0, 1.0] };
        let e = update_jacobians(
            &mut net,
            &r,
            &ones,
            1.0,
            &[3.0],
            &[0.0, 0.0],
            DvRule::at_least(1e-3),
        );
        assert_eq!(e, Err(Error::ZeroLengthDv));
        let e = update_jacobians(
            &mut net,
            &r,
            &ones,
            1.0,
            &[3.0],
            &[f32::NAN, 0.0],
            DvRule::at_least(1e-3),
        );
        assert_eq!(e, Err(Error::ZeroLengthDv));
        assert!(net == before);
    }

    /// The fused update and average against the two functions one after the other, bit
    /// for bit (stage-1 sizes, random tables; every S from 0 to past K).
    #[test]
    fn fused_jacobian_update_and_mean_are_the_two_steps() {
        use rand_core::SeedableRng;
        let cfg = crate::Config::project_default().stage1;
        for (seed, fine_ranks) in [(1u64, 0usize), (2, 5), (3, 127), (4, 400)] {
            let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(seed);
            let mut a = crate::net::Stage1Net::new();
            a.init_random(&mut rng, &cfg.init);
            let mut b = a.clone();
            let u = [300.0, 200.0, 310.0, 210.0, 320.0, 220.0, 330.0, 230.0];
            let r: Ranking<128> = ranked(&a, &u);
            let gamma = Falloff::<128>::compute(cfg.sigma_at(3));
            let alpha = Falloff::<128>::compute(cfg.alpha_range);
            let (dp, dv) = (
                [0.1, -0.2, 0.05, 0.3, -0.01],
                [3.0, -2.0, 1.5, 0.5, -4.0, 2.0, 1.0, -1.0],
            );
            let coeff = cfg.j.coeff(3);
            update_jacobians(&mut a, &r, &gamma, coeff, &dp, &dv, cfg.dv_rule()).unwrap();
            let want = mean_jacobian(&a, &r, &alpha, fine_ranks);
            let got = update_jacobians_and_mean(
                &mut b,
                &r,
                &gamma,
                coeff,
                &dp,
                &dv,
                cfg.dv_rule(),
                &alpha,
                fine_ranks,
            )
            .unwrap();
            assert!(a == b, "tables differ (seed {seed})");
            for m in 0..5 {
                for d in 0..8 {
                    assert_eq!(got[m][d].to_bits(), want[m][d].to_bits());
                }
            }
        }
        let mut net = two_neurons();
        let before = net.clone();
        let r: Ranking<2> = ranked(&net, &[0.0, 0.0]);
        let ones = Falloff { value: [1.0, 1.0] };
        let e = update_jacobians_and_mean(
            &mut net,
            &r,
            &ones,
            1.0,
            &[3.0],
            &[0.0, 0.0],
            DvRule::at_least(1e-3),
            &ones,
            1,
        );
        assert_eq!(e, Err(Error::ZeroLengthDv));
        assert!(net == before);
    }

    /// The inlined exponential against libm's, bit for bit: every rank over many ranges,
    /// and a sweep of bit patterns across (-70, 0] and beyond.
    #[test]
    fn inlined_exp_is_libms() {
        for range in [
            5.0f32, 5.3, 10.0, 17.7, 49.99, 50.0, 1.0, 0.3, 1e-3, -2.0, 1e6,
        ] {
            for r in 0..1000 {
                let x = -(r as f32) / range;
                assert_eq!(exp_nonpositive(x).to_bits(), libm::expf(x).to_bits(), "{x}");
            }
        }
        let mut b = 0u32;
        while b < 0x7f80_0000 {
            for x in [f32::from_bits(b), -f32::from_bits(b)] {
                assert_eq!(exp_nonpositive(x).to_bits(), libm::expf(x).to_bits(), "{x}");
            }
            b += 997;
        }
        let sigma = crate::Config::project_default().stage1;
        for t in 0..3000 {
            let f = Falloff::<128>::compute(sigma.sigma_at(t));
            for r in 0..128 {
                let want = libm::expf(-(r as f32) / sigma.sigma_at(t));
                assert_eq!(f.value[r].to_bits(), want.to_bits());
            }
        }
    }

    /// The neighbourhood table by block products against the exponential of each rank and
    /// against the exact value (f64): the ranks below 16 are `compute`'s bit for bit; every
    /// value is about as close to the exact value as `compute`'s.
    #[test]
    fn block_products_are_as_close_as_the_direct_exponentials() {
        let sigma = crate::Config::project_default().stage1;
        let (mut worst_blocks, mut worst_exact) = (0.0f64, 0.0f64);
        for t in (0..3000).step_by(7) {
            let range = sigma.sigma_at(t);
            let exact = Falloff::<128>::compute(range);
            let blocks = Falloff::<128>::compute_by_blocks(range);
            for r in 0..128 {
                let (a, b) = (exact.value[r], blocks.value[r]);
                if r < 16 {
                    assert_eq!(a.to_bits(), b.to_bits(), "rank {r}, range {range}");
                }
                let truth = libm::exp(-(r as f64) / range as f64);
                worst_blocks = worst_blocks.max((b as f64 - truth).abs() / truth);
                worst_exact = worst_exact.max((a as f64 - truth).abs() / truth);
            }
        }
        // measured: 1.11e-6 by blocks, 1.01e-6 directly (the rounding of -r / range
        // dominates both); a product of wrong factors would be far off
        assert!(
            worst_blocks < 1.25 * worst_exact,
            "{worst_blocks} vs {worst_exact}"
        );
        assert!(worst_exact < 2e-6, "{worst_exact}");
    }

    /// A table rewritten in place holds every value a new table would, whatever it held
    /// before (also where `K` is not a multiple of the 16-rank blocks).
    #[test]
    fn tables_filled_in_place_equal_new_ones() {
        fn check<const K: usize>(range: f32) {
            let mut t = Falloff::<K> {
                value: [f32::NAN; K],
            };
            t.fill(range);
            assert!(t
                .value
                .iter()
                .zip(Falloff::<K>::compute(range).value)
                .all(|(a, b)| a.to_bits() == b.to_bits()));
            let mut t = Falloff::<K> { value: [7.0; K] };
            t.fill_by_blocks(range);
            let new = Falloff::<K>::compute_by_blocks(range);
            assert!(t
                .value
                .iter()
                .zip(new.value)
                .all(|(a, b)| a.to_bits() == b.to_bits()));
            assert!(t
                .value
                .iter()
                .all(|v| v.is_finite() && *v > 0.0 && *v <= 1.0));
        }
        check::<128>(5.0);
        check::<40>(2.5);
        check::<1>(10.0);
    }

    /// The fused start of a trial against the three functions one after the other, bit for
    /// bit, unsupervised and supervised, with the average over all `K` ranks and over fewer.
    #[test]
    fn fused_learning_begin_is_the_three_steps() {
        use rand_core::SeedableRng;
        let cfg = crate::Config::project_default().stage1;
        for (seed, supervised, ranks) in [
            (5u64, false, 128),
            (6, true, 128),
            (7, true, 128),
            (8, false, 64),
            (9, true, 64),
        ] {
            let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(seed);
            let mut a = crate::net::Stage1Net::new();
            a.init_random(&mut rng, &cfg.init);
            let mut b = a.clone();
            let u = [300.0, 200.0, 310.0, 210.0, 320.0, 220.0, 330.0, 230.0];
            let p_ref = [0.1, -0.2, 0.05, 0.3, -0.01];
            let r: Ranking<128> = ranked(&a, &u);
            let gamma = Falloff::<128>::compute(cfg.sigma_at(2));
            let alpha = Falloff::<128>::compute(cfg.alpha_range);
            let (wc, pc) = (cfg.w.coeff(2), cfg.p.coeff(2));
            update_weights(&mut a, &r, &gamma, wc, &u);
            if supervised {
                update_pressures(&mut a, &r, &gamma, pc, &p_ref, &u);
            }
            let want = coarse_output(&a, &r, &alpha, &u, ranks);
            let pressures = supervised.then_some((pc, &p_ref));
            let got = learn_and_coarse_output(&mut b, &r, &gamma, wc, pressures, &alpha, &u, ranks);
            assert!(a == b, "tables differ (seed {seed})");
            for m in 0..5 {
                assert_eq!(got[m].to_bits(), want[m].to_bits());
            }
        }
    }

    #[test]
    fn secant_update_matches_the_move_and_keeps_the_orthogonal_directions() {
        let a0 = [[0.01, -0.02, 0.03], [0.0, 0.04, -0.01]];
        let (dp, dv) = ([0.05, -0.02], [3.0, 4.0, 0.0]);
        let w = [4.0, -3.0, 2.0]; // orthogonal to dv
        let apply = |a: &[[f32; 3]; 2], x: &[f32; 3]| {
            a.map(|row| row.iter().zip(x.iter()).map(|(r, v)| r * v).sum::<f32>())
        };
        // full gain: the corrected average reproduces the move exactly
        let mut a = a0;
        secant_update(&mut a, 1.0, &dp, &dv, DvRule::at_least(1.0)).unwrap();
        let got = apply(&a, &dv);
        assert!((got[0] - dp[0]).abs() < 1e-6 && (got[1] - dp[1]).abs() < 1e-6);
        let (before, after) = (apply(&a0, &w), apply(&a, &w));
        assert!((before[0] - after[0]).abs() < 1e-6 && (before[1] - after[1]).abs() < 1e-6);
        // gain 0.3: 30 % of the way from the old prediction to the move
        let mut b = a0;
        secant_update(&mut b, 0.3, &dp, &dv, DvRule::at_least(1.0)).unwrap();
        let (old, new) = (apply(&a0, &dv), apply(&b, &dv));
        for m in 0..2 {
            assert!((new[m] - (old[m] + 0.3 * (dp[m] - old[m]))).abs() < 1e-6);
        }
        // a move shorter than min_dv (or NaN) changes nothing
        let mut c = a0;
        assert_eq!(
            secant_update(&mut c, 0.3, &dp, &[0.5, 0.0, 0.0], DvRule::at_least(1.0)),
            Err(Error::ZeroLengthDv)
        );
        assert_eq!(
            secant_update(
                &mut c,
                0.3,
                &dp,
                &[f32::NAN, 3.0, 0.0],
                DvRule::at_least(1.0)
            ),
            Err(Error::ZeroLengthDv)
        );
        assert_eq!(c, a0);
    }

    /// The regularised rule (`StageConfig::dv_noise`): a move of length `|dv|` takes the
    /// prediction `|dv|^2 / (|dv|^2 + noise^2)` of the way to the move, so a move as long as
    /// the noise teaches half as much (noise 0: the whole way, the test above).
    #[test]
    fn the_regularised_rule_teaches_a_short_move_less() {
        let a0 = [[0.01, -0.02, 0.03], [0.0, 0.04, -0.01]];
        let (dp, dv) = ([0.05, -0.02], [3.0, 4.0, 0.0]); // |dv| = 5
        let apply = |a: &[[f32; 3]; 2]| {
            a.map(|row| row.iter().zip(dv.iter()).map(|(r, v)| r * v).sum::<f32>())
        };
        let rule = DvRule {
            min: 1.0,
            noise: 5.0,
        };
        let mut a = a0;
        secant_update(&mut a, 1.0, &dp, &dv, rule).unwrap();
        let (old, new) = (apply(&a0), apply(&a));
        for m in 0..2 {
            assert!(
                (new[m] - (old[m] + 0.5 * (dp[m] - old[m]))).abs() < 1e-6,
                "{new:?}"
            );
        }
    }

    #[test]
    fn fine_output_by_hand_and_clamped() {
        let p = fine_output(
            &[0.1, 0.0],
            &[[0.1, 0.0], [0.0, -0.2]],
            &[3.0, 1.0],
            &[1.0, 2.0],
            1.0,
        );
        assert!((p[0] - 0.3).abs() < 1e-6 && (p[1] - 0.2).abs() < 1e-6);
        let p = fine_output(
            &[0.9, 0.0],
            &[[1.0, 0.0], [0.0, 0.0]],
            &[3.0, 1.0],
            &[1.0, 1.0],
            1.0,
        );
        assert_eq!(p[0], 1.0);
    }

    // by-hand values beyond the compact build's table ranges (Jacobian entries of 0.5)
    #[cfg(not(feature = "compact"))]
    #[test]
    fn mean_jacobian_normalised_and_limited_to_s() {
        let net = two_neurons();
        let r: Ranking<2> = ranked(&net, &[0.0, 0.0]);
        let alpha = Falloff::<2>::compute(10.0);
        let a = mean_jacobian(&net, &r, &alpha, 0); // S = 0: closest only
        assert_eq!(a, [[0.5, 0.0]]);
        let a = mean_jacobian(&net, &r, &alpha, 400);
        let a1 = (-0.1f32).exp();
        assert!((a[0][1] - a1 / (1.0 + a1)).abs() < 1e-6);
    }

    /// The truncation to K ranks against the full sum over all N (stage-1 sizes).
    #[test]
    fn truncation_of_the_average_is_bounded() {
        use rand_core::SeedableRng;
        let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(3);
        let mut net = crate::net::Stage1Net::new();
        net.init_random(&mut rng, &crate::Config::paper().stage1.init);
        let u = [320.0, 240.0, 300.0, 250.0, 340.0, 230.0, 330.0, 220.0];
        let mut s = RankScratch::new();
        let mut full = Ranking::<1000>::new();
        full.compute(&net.w, &u, &mut s, RankMode::FullSort);
        let mut part = Ranking::<128>::new();
        part.compute(&net.w, &u, &mut s, RankMode::PartialSelect);
        let pf = coarse_output(&net, &full, &Falloff::<1000>::compute(10.0), &u, 1000);
        let pp = coarse_output(&net, &part, &Falloff::<128>::compute(10.0), &u, 1000);
        let af = mean_jacobian(&net, &full, &Falloff::<1000>::compute(10.0), 400);
        let ap = mean_jacobian(&net, &part, &Falloff::<128>::compute(10.0), 400);
        for m in 0..5 {
            // outputs are O(1); the dropped weight is 2.8e-6 of the total
            assert!(
                (pf[m] - pp[m]).abs() < 2e-5,
                "coarse {m}: {} vs {}",
                pf[m],
                pp[m]
            );
            for d in 0..8 {
                assert!((af[m][d] - ap[m][d]).abs() < 1e-6);
            }
        }
    }

    #[test]
    fn truncation_of_the_updates_is_exact_in_f32() {
        use rand_core::SeedableRng;
        let cfg = crate::Config::paper().stage1;
        let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(4);
        let mut a = crate::net::Stage1Net::new();
        a.init_random(&mut rng, &cfg.init);
        let mut b = a.clone();
        let u = [300.0, 200.0, 310.0, 210.0, 320.0, 220.0, 330.0, 230.0];
        let mut s = RankScratch::new();
        let mut full = Ranking::<1000>::new();
        full.compute(&a.w, &u, &mut s, RankMode::FullSort);
        let mut part = Ranking::<128>::new();
        part.compute(&b.w, &u, &mut s, RankMode::PartialSelect);
        let coeff = cfg.w.coeff(1);
        update_weights(
            &mut a,
            &full,
            &Falloff::<1000>::compute(cfg.sigma),
            coeff,
            &u,
        );
        update_weights(
            &mut b,
            &part,
            &Falloff::<128>::compute(cfg.sigma),
            coeff,
            &u,
        );
        let mut max = 0.0f32;
        for k in 0..1000 {
            for d in 0..8 {
                max = max.max((a.weight(k)[d] - b.weight(k)[d]).abs());
            }
        }
        assert_eq!(max, 0.0, "weights differ by {max}");
    }

    proptest! {
        // a fixed seed: the same cases every run
        #![proptest_config(ProptestConfig {
            rng_seed: proptest::test_runner::RngSeed::Fixed(0x4b1e),
            ..ProptestConfig::default()
        })]
        /// The weight update moves each w_k towards the target and never past it (f32
        /// tables: a compact entry rounds to its step, which may pass the target by half a
        /// step).
        #[cfg(not(feature = "compact"))]
        #[test]
        fn weights_move_towards_target_never_past(
            seed in any::<u64>(), t in 1u32..2000,
            target in prop::array::uniform8(0.0f32..640.0),
        ) {
            use rand_core::SeedableRng;
            let cfg = crate::Config::paper().stage1;
            let mut net = Trn::<40, 8, 5>::new();
            net.init_random(&mut rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(seed), &cfg.init);
            let before = net.clone();
            let r: Ranking<40> = ranked(&net, &target);
            update_weights(&mut net, &r, &Falloff::<40>::compute(cfg.sigma), cfg.w.coeff(t), &target);
            for k in 0..40 {
                for d in 0..8 {
                    let (old, new, x) = (before.w[k][d], net.w[k][d], target[d]);
                    let (lo, hi) = if old <= x { (old, x) } else { (x, old) };
                    prop_assert!(new >= lo && new <= hi, "k {k} d {d}: {old} -> {new}, target {x}");
                    prop_assert!((new - x).abs() <= (old - x).abs());
                }
            }
        }

        /// With rate 1 the Jacobian update solves A dv = dp for the winner (Broyden property),
        /// and with any rate in (0, 1] it never increases the residual (f32 tables: the
        /// solutions can be beyond a compact table's range).
        #[cfg(not(feature = "compact"))]
        #[test]
        fn jacobian_update_reduces_residual(
            dp in prop::array::uniform3(-1.0f32..1.0),
            dv in prop::array::uniform4(-50.0f32..50.0),
            g in 0.01f32..1.0,
        ) {
            prop_assume!(dv.iter().map(|x| x * x).sum::<f32>() > 1.0);
            let mut net = Trn::<1, 4, 3>::new();
            net.set_neuron(0, [0.0; 4], [0.0; 3], [[0.01, -0.02, 0.0, 0.03]; 3]);
            let r: Ranking<1> = ranked(&net, &[0.0; 4]);
            let resid = |n: &Trn<1, 4, 3>| -> f32 {
                (0..3).map(|m| {
                    let adv: f32 = (0..4).map(|d| n.a[0][m][d] * dv[d]).sum();
                    (dp[m] - adv).abs()
                }).sum()
            };
            let before = resid(&net);
            let rule = DvRule::at_least(1e-3);
            update_jacobians(&mut net, &r, &Falloff { value: [1.0] }, g, &dp, &dv, rule).unwrap();
            prop_assert!(resid(&net) <= before * (1.0 - g) + 1e-4);
        }
    }
}
