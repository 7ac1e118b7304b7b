//! One network's learning step as a state machine driven from outside.
//!
//! The caller starts a trial with [`Stage::begin`] and gets the coarse pressure to apply;
//! each camera observation that follows goes to [`Stage::observe`], which answers with the
//! next pressure (a fine move) or with the trial's outcome. Nothing blocks, nothing reads
//! a clock, nothing does I/O.

use crate::config::StageConfig;
use crate::error::{Error, Result};
use crate::law::StageLaw;
use crate::net::Trn;
use crate::rank::{RankMode, RankScratch, Ranking};
use crate::rules::{self, Falloff};
pub use crate::trial::{check_input, FineMoves, StageOutcome, StageStep, TRACE_LEN, ZERO_OUTCOME};
use crate::trial::{distance, sub};

#[derive(Debug, Clone, Copy, PartialEq)]
enum Phase {
    Idle,
    AwaitCoarse,
    AwaitFine,
}

#[derive(Debug, Clone, Copy)]
struct Trial<const D: usize, const M: usize> {
    target: [f32; D],
    p_target: Option<[f32; M]>,
    learn: bool,
    /// A fixed budget of fine moves, if one was asked for.
    exact: Option<u8>,
    /// Coarse pressure P_bar (substep 4), as applied (clamped).
    p_bar: [f32; M],
    /// The coarse output at the target before the clamp (the map's step,
    /// [`StageConfig::map_step`]).
    p_map: [f32; M],
    /// Pressure applied before the last one, and the position it reached.
    p_prev: [f32; M],
    v_prev: [f32; D],
    /// The last pressure applied.
    p_last: [f32; M],
    outcome: StageOutcome,
}

/// One network with its ranking machinery and trial state. `K` is the number of ranks
/// that carry weight (see [`crate::rules`] on the truncation).
#[derive(Clone)]
pub struct Stage<const N: usize, const D: usize, const M: usize, const K: usize> {
    net: Trn<N, D, M>,
    cfg: StageConfig,
    rank_mode: RankMode,
    t: u32,
    ranking: Ranking<K>,
    alpha: Falloff<K>,
    neighbour: Falloff<K>,
    /// The sigma `neighbour` was computed for.
    neighbour_range: f32,
    phase: Phase,
    trial: Trial<D, M>,
    /// In mature operation, the averaged Jacobian of the trial's fine moves: computed for the
    /// first, then corrected by the secant of each move (valid from the trial's second fine
    /// move on; kept outside [`Trial`] so that starting a trial does not write it).
    a_bar: [[f32; D]; M],
    /// Experiment (StageConfig::forward): each neuron's forward Jacobian (D rows of M), and
    /// the trial's rank-averaged one.
    #[cfg(any(test, feature = "std"))]
    fwd: std::vec::Vec<[[f32; M]; D]>,
    #[cfg(any(test, feature = "std"))]
    j_bar: [[f32; M]; D],
}

impl<const N: usize, const D: usize, const M: usize, const K: usize> Stage<N, D, M, K> {
    /// A stage with zero tables. Call [`Stage::init_random`] (or restore a checkpoint)
    /// before use.
    pub const fn new(cfg: StageConfig) -> Self {
        Stage {
            net: Trn::new(),
            cfg,
            rank_mode: RankMode::PartialSelect,
            t: 0,
            ranking: Ranking::new(),
            alpha: Falloff::zero(),
            neighbour: Falloff::zero(),
            neighbour_range: 0.0,
            phase: Phase::Idle,
            trial: Trial {
                target: [0.0; D],
                p_target: None,
                learn: false,
                exact: None,
                p_bar: [0.0; M],
                p_map: [0.0; M],
                p_prev: [0.0; M],
                v_prev: [0.0; D],
                p_last: [0.0; M],
                outcome: ZERO_OUTCOME,
            },
            a_bar: [[0.0; D]; M],
            #[cfg(any(test, feature = "std"))]
            fwd: std::vec::Vec::new(),
            #[cfg(any(test, feature = "std"))]
            j_bar: [[0.0; M]; D],
        }
    }

    /// Random initial tables, learning step 0, precomputed rank tables.
    pub fn init_random(&mut self, rng: &mut impl rand_core::RngCore) {
        self.net.init_random(rng, &self.cfg.init);
        self.t = 0;
        self.phase = Phase::Idle;
        self.prepare();
    }

    /// Recomputes the rank tables from the configuration.
    pub(crate) fn prepare(&mut self) {
        self.alpha.fill(self.cfg.alpha_range);
        // a new configuration may compute the table the other way: no cached range
        self.neighbour_range = f32::NAN;
        self.set_neighbour(self.cfg.sigma);
    }

    /// The neighbourhood table for range `sigma`, recomputed only when sigma changed. With a
    /// fixed sigma (the paper) it is computed once, exactly ([`Falloff::compute`]); with a
    /// shrinking one at every learning step, by [`Falloff::compute_by_blocks`] (16 + K/16
    /// exponentials, as close to the exact values as the direct ones). Either way a function
    /// of the configuration and sigma alone, so a restored checkpoint continues with the same
    /// table.
    fn set_neighbour(&mut self, sigma: f32) {
        if sigma.to_bits() == self.neighbour_range.to_bits() {
            return;
        }
        if self.cfg.sigma_start == self.cfg.sigma {
            self.neighbour.fill(sigma);
        } else {
            self.neighbour.fill_by_blocks(sigma);
        }
        self.neighbour_range = sigma;
    }

    /// Replaces the configuration (between trials).
    pub fn set_config(&mut self, cfg: StageConfig) -> Result<()> {
        if self.phase != Phase::Idle {
            return Err(Error::Busy);
        }
        self.cfg = cfg;
        self.prepare();
        Ok(())
    }

    /// The configuration.
    pub fn config(&self) -> &StageConfig {
        &self.cfg
    }

    /// Chooses full sort (reference) or partial selection for the ranking.
    pub fn set_rank_mode(&mut self, mode: RankMode) {
        self.rank_mode = mode;
    }

    /// The network tables.
    pub fn net(&self) -> &Trn<N, D, M> {
        &self.net
    }

    /// Learning steps completed.
    pub fn learning_step(&self) -> u32 {
        self.t
    }

    pub(crate) fn restore_parts(&mut self, t: u32) {
        self.t = t;
        self.phase = Phase::Idle;
        self.prepare();
    }

    pub(crate) fn net_mut(&mut self) -> &mut Trn<N, D, M> {
        &mut self.net
    }

    /// True while a trial is running.
    pub fn busy(&self) -> bool {
        self.phase != Phase::Idle
    }

    /// The last pressure commanded.
    pub fn last_command(&self) -> [f32; M] {
        self.trial.p_last
    }

    /// Abandons the running trial (updates already made stay: they came from valid data).
    pub fn abort(&mut self) {
        self.phase = Phase::Idle;
    }

    pub(crate) fn check_input(&self, u: &[f32; D]) -> Result<()> {
        check_input(&self.cfg, u)
    }

    /// Starts a trial towards `target`.
    ///
    /// - `p_target = Some(..)` (supervised priming, stage 1): the pressure that produced the
    ///   target is known; substeps 3-6 of the supervised scheme (8.17-8.19).
    /// - `learn = true`, no `p_target`: the unsupervised scheme, substeps 2-4 (8.9-8.11).
    /// - `learn = false`: mature operation; the tables are not touched.
    ///
    /// Returns the coarse pressure (8.5) to apply. The ranking's working memory is the
    /// caller's (`scratch`: the controller shares one between its stages).
    pub fn begin(
        &mut self,
        target: &[f32; D],
        p_target: Option<&[f32; M]>,
        learn: bool,
        scratch: &mut RankScratch,
    ) -> Result<[f32; M]> {
        self.begin_with(target, p_target, learn, FineMoves::Policy, scratch)
    }

    /// [`Stage::begin`] with a choice of how many fine moves the trial makes.
    pub fn begin_with(
        &mut self,
        target: &[f32; D],
        p_target: Option<&[f32; M]>,
        learn: bool,
        fine: FineMoves,
        scratch: &mut RankScratch,
    ) -> Result<[f32; M]> {
        if self.phase != Phase::Idle {
            return Err(Error::Busy);
        }
        self.check_input(target)?;
        if let Some(p) = p_target {
            for (i, &x) in p.iter().enumerate() {
                if !x.is_finite() || x.abs() > self.cfg.pressure_limit {
                    return Err(Error::InvalidPressure { index: i as u8 });
                }
            }
        }
        let learn = learn || p_target.is_some();
        let exact = fine.budget()?;
        self.ranking
            .compute(&self.net.w, target, scratch, self.rank_mode);
        self.begin_ranked(target, p_target, learn, exact)
    }

    fn begin_ranked(
        &mut self,
        target: &[f32; D],
        p_target: Option<&[f32; M]>,
        learn: bool,
        exact: Option<u8>,
    ) -> Result<[f32; M]> {
        if !learn {
            let distance = self.ranking.distance(0);
            if distance > self.cfg.max_target_distance {
                return Err(Error::TargetOutsideLearnedRegion { distance });
            }
        }
        let t = if learn {
            self.t.saturating_add(1)
        } else {
            self.t
        };
        let tolerance = if learn {
            self.cfg.tolerance.at(t)
        } else {
            self.cfg.mature_tolerance
        };
        let p_bar = if learn {
            self.t = t;
            if self.cfg.sigma_start != self.cfg.sigma {
                self.set_neighbour(self.cfg.sigma_at(t));
            }
            // substep 3 (8.9 / 8.17 / 8.25), supervised substep 5 (8.18), and substep 4
            // (8.11 / 8.19 / 8.24, normalised) in one pass
            let pressures = p_target.map(|p| (self.cfg.p.coeff(t), p));
            rules::learn_and_coarse_output(
                &mut self.net,
                &self.ranking,
                &self.neighbour,
                self.cfg.w.coeff(t),
                pressures,
                &self.alpha,
                target,
                self.cfg.coarse_ranks as usize,
            )
        } else {
            // substep 4 (8.11 / 8.19 / 8.24), normalised
            rules::coarse_output(
                &self.net,
                &self.ranking,
                &self.alpha,
                target,
                self.cfg.coarse_ranks as usize,
            )
        };
        let p_map = p_bar;
        let p_bar = rules::clamp(&p_bar, self.cfg.pressure_limit);
        self.trial = Trial {
            target: *target,
            p_target: p_target.copied(),
            learn,
            exact,
            p_bar,
            p_map,
            p_prev: p_bar,
            v_prev: [0.0; D],
            p_last: p_bar,
            outcome: StageOutcome {
                t,
                learned: learn,
                supervised: p_target.is_some(),
                coarse_error: 0.0,
                final_error: 0.0,
                fine_moves: 0,
                cap_hit: false,
                tolerance,
                skipped_updates: 0,
                trace: [0.0; TRACE_LEN],
            },
        };
        self.phase = Phase::AwaitCoarse;
        Ok(p_bar)
    }

    /// Consumes the observation that followed the last command. `scratch` is the ranking's
    /// working memory, as in [`Stage::begin`] (only the map's step,
    /// [`StageConfig::map_step`], ranks again).
    pub fn observe(&mut self, v: &[f32; D], scratch: &mut RankScratch) -> Result<StageStep<M>> {
        if self.phase == Phase::Idle {
            return Err(Error::UnexpectedObservation);
        }
        self.check_input(v)?;
        let target = self.trial.target;
        let d = distance(v, &target);
        let tr = &mut self.trial;
        let t = tr.outcome.t;
        // the averaged Jacobian of the next fine move, when the Jacobian update made it
        let mut a_bar = None;
        match self.phase {
            Phase::AwaitCoarse => {
                tr.outcome.coarse_error = d;
                tr.outcome.trace[0] = d;
                if tr.learn && tr.p_target.is_none() {
                    // substep 6 (8.12 / 8.27): teach each map the pressure that reached v_i
                    rules::update_pressures(
                        &mut self.net,
                        &self.ranking,
                        &self.neighbour,
                        self.cfg.p.coeff(t),
                        &tr.p_bar,
                        v,
                    );
                }
                let over = d > tr.outcome.tolerance;
                match tr.exact {
                    Some(0) => return Ok(self.finish(d, over)),
                    Some(_) => {}
                    None => {
                        let must_refine = tr.learn && self.cfg.min_fine_moves_learning > 0;
                        if (!over && !must_refine) || self.cfg.max_fine_moves == 0 {
                            return Ok(self.finish(d, over));
                        }
                    }
                }
            }
            Phase::AwaitFine => {
                tr.outcome.fine_moves += 1;
                let n = tr.outcome.fine_moves as usize;
                if n < TRACE_LEN {
                    tr.outcome.trace[n] = d;
                }
                // whether the trial ends here (and how), decided before the update: when
                // another fine move follows, the update also gives its averaged Jacobian
                let fine = tr.outcome.fine_moves;
                let over = d > tr.outcome.tolerance;
                let finish = if let Some(n) = tr.exact {
                    (fine >= n).then_some(over)
                } else {
                    let enough = fine >= self.cfg.min_fine_moves_learning || !tr.learn;
                    if !over && enough {
                        Some(false)
                    } else if fine >= self.cfg.max_fine_moves || fine as usize >= TRACE_LEN - 1 {
                        Some(over)
                    } else {
                        None
                    }
                };
                if tr.learn {
                    // substep 9 (8.15), or supervised substep 12 (8.21)
                    let (dp, dv) = match tr.p_target {
                        Some(pt) => (sub(&pt, &tr.p_last), sub(&target, v)),
                        None => (sub(&tr.p_last, &tr.p_prev), sub(v, &tr.v_prev)),
                    };
                    let coeff = self.cfg.j.coeff(t);
                    let updated = if finish.is_none() {
                        rules::update_jacobians_and_mean(
                            &mut self.net,
                            &self.ranking,
                            &self.neighbour,
                            coeff,
                            &dp,
                            &dv,
                            self.cfg.dv_rule(),
                            &self.alpha,
                            self.cfg.fine_ranks as usize,
                        )
                        .map(|a| a_bar = Some(a))
                    } else {
                        rules::update_jacobians(
                            &mut self.net,
                            &self.ranking,
                            &self.neighbour,
                            coeff,
                            &dp,
                            &dv,
                            self.cfg.dv_rule(),
                        )
                    };
                    if updated.is_err() {
                        tr.outcome.skipped_updates = tr.outcome.skipped_updates.saturating_add(1);
                    }
                    #[cfg(any(test, feature = "std"))]
                    if self.cfg.forward > 0.0 && tr.p_target.is_none() {
                        // experiment: the forward rule on the same secant
                        if self.fwd.len() != N {
                            self.fwd = std::vec![[[0.0; M]; D]; N];
                        }
                        let n2: f32 = dp.iter().map(|x| x * x).sum();
                        let c = coeff * self.cfg.forward / (n2 + 1e-6);
                        for (&k, &f) in self
                            .ranking
                            .indices()
                            .iter()
                            .zip(self.neighbour.value.iter())
                        {
                            let j = &mut self.fwd[k as usize];
                            for d in 0..D {
                                let pred: f32 = (0..M).map(|m| j[d][m] * dp[m]).sum();
                                let r = c * f * (dv[d] - pred);
                                for m in 0..M {
                                    j[d][m] += r * dp[m];
                                }
                            }
                        }
                    }
                }
                if let Some(over) = finish {
                    return Ok(self.finish(d, over));
                }
            }
            Phase::Idle => return Err(Error::UnexpectedObservation),
        }
        // substep 7 (8.14 / 8.20 / 8.29): the next fine move from the last applied pressure
        // and the last observed position.
        let tr = &mut self.trial;
        let a_bar = match a_bar {
            Some(a) => a,
            None if !tr.learn && tr.outcome.fine_moves > 0 => {
                // mature operation after the first fine move (this observation followed a
                // fine move): the tables are unchanged, so the average is the one held since
                // the first (the ranking may since be the reached position's, for the map's
                // step: it is not used again); corrected by the secant of the move just made
                // (`StageConfig::trial_secant`)
                let gain = self.cfg.trial_secant;
                if gain > 0.0 {
                    let (dp, dv) = (sub(&tr.p_last, &tr.p_prev), sub(v, &tr.v_prev));
                    let rule = self.cfg.dv_rule();
                    let updated = rules::secant_update(&mut self.a_bar, gain, &dp, &dv, rule);
                    if updated.is_err() {
                        tr.outcome.skipped_updates = tr.outcome.skipped_updates.saturating_add(1);
                    }
                }
                self.a_bar
            }
            None => {
                let a = rules::mean_jacobian(
                    &self.net,
                    &self.ranking,
                    &self.alpha,
                    self.cfg.fine_ranks as usize,
                );
                #[allow(unused_mut)]
                let mut a = a;
                #[cfg(any(test, feature = "std"))]
                if self.cfg.jac_field > 0.0 && !tr.learn {
                    // experiment (StageConfig::jac_field): the average moved to the target
                    let n = (self.cfg.fine_ranks as usize + 1).min(K);
                    let ks = &self.ranking.indices()[..n];
                    let als = &self.alpha.value[..n];
                    let wsum: f32 = als.iter().sum();
                    let mut wbar = [0.0f32; D];
                    for (&k, &al) in ks.iter().zip(als) {
                        let w = self.net.weight(k as usize);
                        for d in 0..D {
                            wbar[d] += al * w[d] / wsum;
                        }
                    }
                    let mut xtx = nalgebra::SMatrix::<f32, D, D>::zeros();
                    let mut rhs = std::vec![nalgebra::SVector::<f32, D>::zeros(); M * D];
                    for (&k, &al) in ks.iter().zip(als) {
                        let w = self.net.weight(k as usize);
                        let x = nalgebra::SVector::<f32, D>::from_fn(|d, _| w[d] - wbar[d]);
                        xtx += x * x.transpose() * al;
                        let ak = self.net.jacobian(k as usize);
                        for m in 0..M {
                            for d in 0..D {
                                rhs[m * D + d] += x * (al * (ak[m][d] - a[m][d]));
                            }
                        }
                    }
                    let ridge = self.cfg.jac_field * xtx.trace() / D as f32;
                    for d in 0..D {
                        xtx[(d, d)] += ridge;
                    }
                    if let Some(ch) = xtx.cholesky() {
                        // the secant from the reading to the target: the field at their midpoint
                        let dx = nalgebra::SVector::<f32, D>::from_fn(|d, _| {
                            0.5 * (target[d] + v[d]) - wbar[d]
                        });
                        for m in 0..M {
                            for d in 0..D {
                                let g = ch.solve(&rhs[m * D + d]);
                                a[m][d] += g.dot(&dx);
                            }
                        }
                    }
                }
                if !tr.learn {
                    // held for the trial's later fine moves
                    self.a_bar = a;
                }
                a
            }
        };
        let limit = self.cfg.pressure_limit;
        let mut p_fine = rules::fine_output(&tr.p_last, &a_bar, &target, v, f32::INFINITY);
        #[cfg(any(test, feature = "std"))]
        if self.cfg.forward > 0.0 && !tr.learn && self.fwd.len() == N {
            // experiment (StageConfig::forward): the step from the forward Jacobians
            if tr.outcome.fine_moves == 0 {
                let n = (self.cfg.fine_ranks as usize + 1).min(K);
                let mut jb = [[0.0f32; M]; D];
                let mut wsum = 0.0f32;
                for (&k, &al) in self.ranking.indices()[..n]
                    .iter()
                    .zip(self.alpha.value[..n].iter())
                {
                    let j = &self.fwd[k as usize];
                    for d in 0..D {
                        for m in 0..M {
                            jb[d][m] += al * j[d][m];
                        }
                    }
                    wsum += al;
                }
                jb.iter_mut().flatten().for_each(|x| *x /= wsum);
                self.j_bar = jb;
            } else if self.cfg.trial_secant > 0.0 {
                let (dp, dv) = (sub(&tr.p_last, &tr.p_prev), sub(v, &tr.v_prev));
                let n2: f32 = dp.iter().map(|x| x * x).sum();
                if n2 > 1e-8 {
                    let g = self.cfg.trial_secant / n2;
                    for d in 0..D {
                        let pred: f32 = (0..M).map(|m| self.j_bar[d][m] * dp[m]).sum();
                        let r = g * (dv[d] - pred);
                        for m in 0..M {
                            self.j_bar[d][m] += r * dp[m];
                        }
                    }
                }
            }
            let j = nalgebra::SMatrix::<f32, D, M>::from_fn(|d, m| self.j_bar[d][m]);
            let e = nalgebra::SVector::<f32, D>::from_fn(|d, _| target[d] - v[d]);
            let mut jtj = j.transpose() * j;
            let ridge = self.cfg.forward_ridge * jtj.trace() / M as f32;
            for m in 0..M {
                jtj[(m, m)] += ridge;
            }
            if let Some(ch) = jtj.cholesky() {
                let dp = ch.solve(&(j.transpose() * e));
                for m in 0..M {
                    p_fine[m] = tr.p_last[m] + dp[m];
                }
            }
        }
        let w = self.cfg.map_step;
        if w > 0.0 && !tr.learn && tr.outcome.fine_moves == 0 {
            // the map's step (StageConfig::map_step): the coarse map's output at the target
            // plus its error where the coarse move arrived, P_bar(target) + p - P_bar(v)
            self.ranking
                .compute(&self.net.w, v, scratch, self.rank_mode);
            let ranks = self.cfg.coarse_ranks as usize;
            let p_v = rules::coarse_output(&self.net, &self.ranking, &self.alpha, v, ranks);
            for m in 0..M {
                let by_map = tr.p_last[m] + tr.p_map[m] - p_v[m];
                p_fine[m] = w * by_map + (1.0 - w) * p_fine[m];
            }
        }
        let noise = self.cfg.step_noise;
        if noise > 0.0 && !tr.learn {
            // the step shortened near the noise floor (StageConfig::step_noise)
            let gain = d * d / (d * d + noise * noise);
            for m in 0..M {
                p_fine[m] = tr.p_last[m] + gain * (p_fine[m] - tr.p_last[m]);
            }
        }
        let g = self.cfg.fine_gain;
        if g > 0.0 && !tr.learn {
            // experiment (StageConfig::fine_gain)
            for m in 0..M {
                p_fine[m] = tr.p_last[m] + g * (p_fine[m] - tr.p_last[m]);
            }
        }
        let probe = self.cfg.probe;
        if probe > 0.0 && tr.learn && tr.p_target.is_none() {
            // experiment (StageConfig::probe): a push across the step, its length a fraction
            // of the step's, its direction from the learning step and the move's index
            let len = distance(&p_fine, &tr.p_last);
            let mut dir = [0.0f32; M];
            let mut h = ((t as u64) << 8) ^ tr.outcome.fine_moves as u64 ^ 0x9E37_79B9_7F4A_7C15;
            for x in dir.iter_mut() {
                // splitmix64
                h = h.wrapping_add(0x9E37_79B9_7F4A_7C15);
                let mut z = h;
                z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
                z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
                z ^= z >> 31;
                *x = (z >> 40) as f32 / (1u64 << 23) as f32 - 1.0;
            }
            let norm = libm::sqrtf(dir.iter().map(|x| x * x).sum::<f32>());
            if norm > 0.0 {
                for m in 0..M {
                    p_fine[m] += probe * len * dir[m] / norm;
                }
            }
        }
        let p_fine = rules::clamp(&p_fine, limit);
        tr.p_prev = tr.p_last;
        tr.v_prev = *v;
        tr.p_last = p_fine;
        self.phase = Phase::AwaitFine;
        Ok(StageStep::Move(p_fine))
    }

    fn finish(&mut self, d: f32, cap_hit: bool) -> StageStep<M> {
        self.trial.outcome.final_error = d;
        self.trial.outcome.cap_hit = cap_hit;
        self.phase = Phase::Idle;
        StageStep::Done(self.trial.outcome)
    }
}

/// The TRN is a stage law: it learns when asked (supervised priming, unsupervised
/// training) and ranks with the controller's shared working memory.
impl<const N: usize, const D: usize, const M: usize, const K: usize> StageLaw<D, M>
    for Stage<N, D, M, K>
{
    fn check_input(&self, u: &[f32; D]) -> Result<()> {
        Stage::check_input(self, u)
    }
    fn begin(
        &mut self,
        target: &[f32; D],
        supervised: Option<&[f32; M]>,
        learn: bool,
        fine: FineMoves,
        scratch: &mut RankScratch,
    ) -> Result<[f32; M]> {
        self.begin_with(target, supervised, learn, fine, scratch)
    }
    fn observe(&mut self, u: &[f32; D], scratch: &mut RankScratch) -> Result<StageStep<M>> {
        Stage::observe(self, u, scratch)
    }
    fn abort(&mut self) {
        Stage::abort(self)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::config::Config;

    const A0: [[f32; 2]; 2] = [[0.01, 0.0], [0.0, 0.02]];
    const V0: [f32; 2] = [380.0, 290.0];
    const TARGET: [f32; 2] = [400.0, 300.0];

    /// The arm: `v = V0 + J p` with `J = 0.5 A0^-1`, so every move of the averaged Jacobian
    /// `A0` goes half as far as it should.
    fn arm(p: &[f32; 2]) -> [f32; 2] {
        [V0[0] + 50.0 * p[0], V0[1] + 25.0 * p[1]]
    }

    /// Four neurons near `V0`, each with the map `A0` and pressure 0 (so the averaged Jacobian
    /// is `A0`), under the project's stage-1 configuration changed by `change` (and every move
    /// of the Jacobian rule learned from).
    fn stage_of_a0(change: impl FnOnce(&mut StageConfig)) -> Stage<4, 2, 2, 4> {
        let mut cfg = Config::project_default().stage1;
        cfg.min_dv = 1e-3;
        change(&mut cfg);
        let mut s: Stage<4, 2, 2, 4> = Stage::new(cfg);
        s.set_config(cfg).unwrap();
        for k in 0..4 {
            let w = [V0[0] + k as f32, V0[1] - k as f32];
            s.net_mut().set_neuron(k, w, [0.0; 2], A0);
        }
        s
    }

    /// The errors after the coarse move and 3 fine moves of a mature trial, with every
    /// neuron's map `A0` (so the averaged Jacobian is `A0`), and whether the tables changed.
    fn errors(gain: f32) -> ([f32; 4], bool) {
        let mut s = stage_of_a0(|cfg| cfg.trial_secant = gain);
        let before = s.net().clone();
        let mut p = s
            .begin_with(
                &TARGET,
                None,
                false,
                FineMoves::Exactly(3),
                &mut RankScratch::new(),
            )
            .unwrap();
        let mut out = [0.0; 4];
        for e in out.iter_mut() {
            let v = arm(&p);
            *e = distance(&v, &TARGET);
            match s.observe(&v, &mut RankScratch::new()).unwrap() {
                StageStep::Move(next) => p = next,
                StageStep::Done(o) => assert_eq!(o.skipped_updates, 0),
            }
        }
        (out, *s.net() != before)
    }

    #[test]
    fn the_trial_secant_corrects_the_averaged_jacobians_gain_within_the_trial() {
        // without the correction every fine move halves the error
        let (e, changed) = errors(0.0);
        assert!(!changed);
        for m in 1..4 {
            assert!((e[m] / e[m - 1] - 0.5).abs() < 1e-3, "{e:?}");
        }
        // full gain: the first fine move's secant gives the true gain along the error's
        // direction (here the only one), so the second fine move lands on the target
        let (e, changed) = errors(1.0);
        assert!(!changed, "nothing is learned in mature operation");
        assert!(
            (e[1] / e[0] - 0.5).abs() < 1e-3,
            "the first fine move is the paper's"
        );
        assert!(e[2] < 1e-3 * e[0], "{e:?}");
        // the project's gain: part of the way, every move better than without
        let (e3, _) = errors(Config::project_default().stage1.trial_secant);
        let (e0, _) = errors(0.0);
        assert!(e3[2] < e0[2] && e3[3] < e0[3], "{e3:?} vs {e0:?}");
    }

    /// With the step's noise (`StageConfig::step_noise`) a mature fine move goes
    /// `|e|^2 / (|e|^2 + step_noise^2)` of the Jacobian's step: nearly all of it far from the
    /// target, half of it at `|e| = step_noise`; a learning trial steps in full.
    #[test]
    fn the_steps_noise_shortens_a_mature_fine_move_near_the_target() {
        let errors = |noise: f32, learn: bool, shift: [f32; 2]| {
            let mut s = stage_of_a0(|cfg| {
                cfg.step_noise = noise;
                cfg.trial_secant = 0.0;
            });
            // an arm whose Jacobian is A0's inverse, off the maps by `shift`: the coarse move
            // lands about `shift` from the target, the Jacobian's step on it
            let exact = |p: &[f32; 2]| {
                [
                    V0[0] + shift[0] + 100.0 * p[0],
                    V0[1] + shift[1] + 50.0 * p[1],
                ]
            };
            let mut scratch = RankScratch::new();
            let p0 = s
                .begin_with(&TARGET, None, learn, FineMoves::Exactly(1), &mut scratch)
                .unwrap();
            let v0 = exact(&p0);
            let StageStep::Move(p1) = s.observe(&v0, &mut scratch).unwrap() else {
                panic!("a fine move follows");
            };
            (distance(&v0, &TARGET), distance(&exact(&p1), &TARGET))
        };
        let (near, far) = ([1.5, 0.5], [20.0, -10.0]);
        for shift in [near, far] {
            let (e0, e1) = errors(0.0, false, shift);
            assert!(e1 < 1e-3 * e0, "off: the full step ({e0} -> {e1})");
            let (_, e1) = errors(0.0, true, shift);
            assert!(e1 < 1e-3 * e0, "learning: the full step ({e0} -> {e1})");
            let (_, e1) = errors(2.5, true, shift);
            assert!(
                e1 < 1e-3 * e0,
                "learning, noise 2.5: the full step ({e0} -> {e1})"
            );
            let (e0, e1) = errors(2.5, false, shift);
            let left = 2.5 * 2.5 / (e0 * e0 + 2.5 * 2.5);
            assert!(
                (e1 / e0 - left).abs() < 1e-3,
                "{e0} -> {e1}, {left} expected"
            );
        }
        // near the target (2 px) more than half of the error is left, 20 px off about 1 %
        let (e0, e1) = errors(2.5, false, near);
        assert!(e0 < 2.5 && e1 / e0 > 0.5, "{e0} -> {e1}");
        let (e0, e1) = errors(2.5, false, far);
        assert!(e0 > 20.0 && e1 / e0 < 0.02, "{e0} -> {e1}");
    }

    /// A mature trial's first fine move with the map's step: `map_step` of
    /// `p + P_bar(target) - P_bar(v)` (the coarse output at the reached position from a
    /// ranking there) and the rest of the Jacobian's step; a learning trial keeps the
    /// Jacobian's step.
    #[test]
    fn the_maps_step_blends_the_coarse_maps_correction_into_the_first_fine_move() {
        let first_fine = |w: f32, learn: bool| {
            let mut cfg = Config::project_default().stage1;
            cfg.map_step = w;
            cfg.min_dv = 1e-3;
            // the average dominated by the nearest neuron, whose map differs at v and target
            cfg.alpha_range = 0.5;
            cfg.mature_tolerance = 0.0;
            cfg.tolerance.floor = 0.0;
            let mut s: Stage<4, 2, 2, 4> = Stage::new(cfg);
            s.set_config(cfg).unwrap();
            // neurons 30 px apart along x with pressures that differ by more than their
            // Jacobians (A0) say, so the map's step and the Jacobian's differ
            for k in 0..4 {
                let w = [V0[0] + 30.0 * k as f32, V0[1]];
                s.net_mut()
                    .set_neuron(k, w, [0.2 * k as f32, -0.1 * k as f32], A0);
            }
            let mut scratch = RankScratch::new();
            let p0 = s
                .begin_with(&TARGET, None, learn, FineMoves::Exactly(2), &mut scratch)
                .unwrap();
            let v = [V0[0] + 2.0, V0[1] + 1.0];
            let StageStep::Move(p1) = s.observe(&v, &mut scratch).unwrap() else {
                panic!("a fine move follows");
            };
            // what the rule says, from the parts
            let mut r: Ranking<4> = Ranking::new();
            r.compute(s.net().weights(), &v, &mut scratch, RankMode::FullSort);
            let alpha = Falloff::<4>::compute(cfg.alpha_range);
            let ranks = cfg.coarse_ranks as usize;
            let p_v = rules::coarse_output(s.net(), &r, &alpha, &v, ranks);
            r.compute(s.net().weights(), &TARGET, &mut scratch, RankMode::FullSort);
            let p_t = rules::coarse_output(s.net(), &r, &alpha, &TARGET, ranks);
            let a = rules::mean_jacobian(s.net(), &r, &alpha, cfg.fine_ranks as usize);
            let by_jacobian = rules::fine_output(&p0, &a, &TARGET, &v, f32::INFINITY);
            (
                p1,
                by_jacobian,
                core::array::from_fn::<f32, 2, _>(|m| p0[m] + p_t[m] - p_v[m]),
            )
        };
        for w in [0.0, 0.5, 1.0] {
            let (got, by_jacobian, by_map) = first_fine(w, false);
            for m in 0..2 {
                let want = w * by_map[m] + (1.0 - w) * by_jacobian[m];
                assert!(
                    (got[m] - want).abs() < 1e-5,
                    "w {w}: {got:?} against {want}"
                );
            }
            let differ = (0..2).any(|m| (by_map[m] - by_jacobian[m]).abs() > 1e-2);
            assert!(differ, "the two steps differ: {by_map:?} {by_jacobian:?}");
        }
        // while learning the fine move is the paper's, whatever the weight
        let (learned, _, _) = first_fine(1.0, true);
        let (paper, _, _) = first_fine(0.0, true);
        assert_eq!(learned, paper);
    }
}
