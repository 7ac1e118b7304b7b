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
    /// Experiment (`StageConfig::loop_offset`): each channel's side of the loop the coarse
    /// move approached from (+1 rising, -1 falling, 0 unchanged).
    side: [f32; M],
    /// Experiment (`StageConfig::est_noise`): the filtered position, its per-coordinate
    /// variance, the last step's aim.
    est: [f32; D],
    est_var: f32,
    aim: [f32; D],
    /// Experiment (`StageConfig::near_avg`): the trial's readings so far within
    /// `near_avg` times the tolerance.
    near: u8,
    /// Experiment (`StageConfig::replay`): each move's applied pressure and the position it
    /// reached, the coarse move first.
    moves_p: [[f32; M]; TRACE_LEN],
    moves_v: [[f32; D]; TRACE_LEN],
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
    /// Experiment (`StageConfig::anchor_weight`): each neuron's remembered visit.
    anchor_p: [[f32; M]; N],
    anchor_v: [[f32; D]; N],
    anchor_ok: [bool; N],
    /// Experiment (`StageConfig::loop_offset_rate`): each neuron's learned offset per
    /// channel, and the pressures held before the next trial (`StageLaw::note_held`).
    loop_o: [[f32; M]; N],
    held: [f32; M],
    /// Experiment (`StageConfig::jac_rls_forget`): each neuron's inverse covariance of the
    /// Jacobian rule's regressors (`dv`), and whether it was initialised.
    rls_p: [[[f32; D]; D]; N],
    rls_ok: [bool; N],
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
                side: [0.0; M],
                est: [0.0; D],
                est_var: 0.0,
                aim: [0.0; D],
                near: 0,
                moves_p: [[0.0; M]; TRACE_LEN],
                moves_v: [[0.0; D]; TRACE_LEN],
                outcome: ZERO_OUTCOME,
            },
            a_bar: [[0.0; D]; M],
            anchor_p: [[0.0; M]; N],
            anchor_v: [[0.0; D]; N],
            anchor_ok: [false; N],
            loop_o: [[0.0; M]; N],
            held: [0.0; M],
            rls_p: [[[0.0; D]; D]; N],
            rls_ok: [false; N],
        }
    }

    /// Random initial tables, learning step 0, precomputed rank tables.
    pub fn init_random(&mut self, rng: &mut impl rand_core::RngCore) {
        self.net.init_random(rng, &self.cfg.init);
        self.anchor_ok = [false; N];
        self.loop_o = [[0.0; M]; N];
        self.rls_ok = [false; N];
        let active = self.cfg.active_neurons as usize;
        if active > 0 {
            // experiment: the neurons beyond `active` parked far outside any image
            for k in active.min(N)..N {
                for d in 0..D {
                    self.net.w[k][d] = <crate::entry::Table as crate::entry::Entry>::put(
                        1.0e5 + k as f32,
                        crate::entry::TABLE_SCALES.w,
                    );
                }
            }
        }
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

    /// Experiment (`StageConfig::loop_offset_rate`): the learned offsets averaged over the
    /// first `ranks` ranks of the current ranking, weighted as the coarse output.
    fn loop_offset_at(&self, ranks: usize) -> [f32; M] {
        let n = ranks.clamp(1, K);
        let mut out = [0.0; M];
        for (&k, &al) in self.ranking.indices()[..n]
            .iter()
            .zip(self.alpha.value.iter())
        {
            for m in 0..M {
                out[m] += al * self.loop_o[k as usize][m];
            }
        }
        let norm = 1.0 / self.alpha.sum(n);
        out.map(|o| o * norm)
    }

    /// Experiment (`StageConfig::loop_offset`): see [`StageLaw::note_held`].
    pub fn note_held(&mut self, held: &[f32; M]) {
        self.held = *held;
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
        let p = self.begin_ranked(target, p_target, learn, exact)?;
        let aw = self.cfg.anchor_weight;
        if learn || aw <= 0.0 {
            return Ok(p);
        }
        // experiment: the map's error at the remembered visit nearest the target
        let mut best: Option<(f32, usize)> = None;
        for r in 0..(self.cfg.anchor_ranks as usize).min(K) {
            let k = self.ranking.index(r);
            if self.anchor_ok[k] {
                let d = distance(&self.anchor_v[k], target);
                if best.map_or(true, |(b, _)| d < b) {
                    best = Some((d, k));
                }
            }
        }
        let Some((_, k)) = best else {
            return Ok(p);
        };
        let (pa, va) = (self.anchor_p[k], self.anchor_v[k]);
        let kept = self.ranking;
        self.ranking
            .compute(&self.net.w, &va, scratch, self.rank_mode);
        let ranks = self.cfg.coarse_ranks as usize;
        let p_va = rules::coarse_output(&self.net, &self.ranking, &self.alpha, &va, ranks);
        self.ranking = kept;
        let tr = &mut self.trial;
        let mut out = tr.p_map;
        for m in 0..M {
            out[m] += aw * (pa[m] - p_va[m]);
        }
        let out = rules::clamp(&out, self.cfg.pressure_limit);
        tr.p_bar = out;
        tr.p_prev = out;
        tr.p_last = out;
        Ok(out)
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
        let blend = self.cfg.coarse_blend;
        let p_bar = if blend != 0.0 {
            // experiment (StageConfig::coarse_blend): second-order blending of the local maps
            let avg = rules::averaged_map_output(
                &self.net,
                &self.ranking,
                &self.alpha,
                target,
                self.cfg.coarse_ranks as usize,
            );
            core::array::from_fn(|m| (1.0 - blend) * p_bar[m] + blend * avg[m])
        } else {
            p_bar
        };
        let (lo, lr) = (self.cfg.loop_offset, self.cfg.loop_offset_rate);
        let mut side = [0.0f32; M];
        let p_bar = if (lo != 0.0 || lr != 0.0) && p_target.is_none() {
            // experiment (StageConfig::loop_offset): the coarse command moved towards the
            // side of the loop it approaches from
            let learned = if lr != 0.0 {
                self.loop_offset_at(self.cfg.coarse_ranks as usize)
            } else {
                [0.0; M]
            };
            core::array::from_fn(|m| {
                let s = if p_bar[m] > self.held[m] {
                    1.0
                } else if p_bar[m] < self.held[m] {
                    -1.0
                } else {
                    0.0
                };
                side[m] = s;
                p_bar[m] + s * (lo + learned[m])
            })
        } else {
            p_bar
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
            side,
            est: [0.0; D],
            est_var: 0.0,
            aim: [0.0; D],
            near: 0,
            moves_p: [[0.0; M]; TRACE_LEN],
            moves_v: [[0.0; D]; TRACE_LEN],
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
        if tr.learn && tr.p_target.is_none() && self.cfg.anchor_weight > 0.0 {
            // experiment (StageConfig::anchor_weight): remember the visit where it is the
            // closest to a centre
            for r in 0..(self.cfg.anchor_ranks as usize).min(K) {
                let k = self.ranking.index(r);
                let w = self.net.weight(k);
                if !self.anchor_ok[k] || distance(v, &w) < distance(&self.anchor_v[k], &w) {
                    self.anchor_ok[k] = true;
                    self.anchor_p[k] = tr.p_last;
                    self.anchor_v[k] = *v;
                }
            }
        }
        if tr.learn && tr.p_target.is_none() {
            // experiment (StageConfig::replay): the move's pressure and where it arrived
            let n = match self.phase {
                Phase::AwaitCoarse => 0,
                _ => tr.outcome.fine_moves as usize + 1,
            };
            if n < TRACE_LEN {
                tr.moves_p[n] = tr.p_last;
                tr.moves_v[n] = *v;
            }
        }
        let sn = self.cfg.est_noise;
        let filtering = sn > 0.0 && !tr.learn;
        if filtering {
            let r = sn * sn;
            if self.phase == Phase::AwaitFine {
                let pred = tr.est_var;
                let dev = distance(v, &tr.aim);
                if dev * dev > 9.0 * D as f32 * (pred + r) {
                    tr.est = *v;
                    tr.est_var = r;
                } else {
                    let k = pred / (pred + r);
                    for i in 0..D {
                        tr.est[i] = tr.aim[i] + k * (v[i] - tr.aim[i]);
                    }
                    tr.est_var = k * r;
                }
            } else {
                tr.est = *v;
                tr.est_var = r;
            }
        }
        let d_est = if filtering {
            distance(&tr.est, &target)
        } else {
            d
        };
        let mut v_step = *v;
        let d_est = if self.cfg.stop_projected > 0 && !tr.learn {
            // experiment (StageConfig::stop_projected): the error across the directions the
            // pressures move the arm in left out of the stop test
            let a = if self.phase == Phase::AwaitFine {
                self.a_bar
            } else {
                rules::mean_jacobian(
                    &self.net,
                    &self.ranking,
                    &self.alpha,
                    self.cfg.fine_ranks as usize,
                )
            };
            let e = sub(v, &target);
            if self.cfg.stop_projected >= 2 {
                let n = (self.cfg.stop_projected as usize).min(K);
                let mut ws = [[0.0f32; D]; K];
                for (r, w) in ws.iter_mut().enumerate().take(n) {
                    *w = self.net.weight(self.ranking.index(r));
                }
                let pe = pca_project::<D, M>(&ws[..n], &e);
                if self.cfg.step_projected > 0 {
                    for i in 0..D {
                        v_step[i] = target[i] + pe[i];
                    }
                }
                libm::sqrtf(pe.iter().map(|x| x * x).sum())
            } else {
                projected_distance(&a, &e).unwrap_or(d_est)
            }
        } else {
            d_est
        };
        let t = tr.outcome.t;
        // the averaged Jacobian of the next fine move, when the Jacobian update made it
        let mut a_bar = None;
        match self.phase {
            Phase::AwaitCoarse => {
                tr.outcome.coarse_error = d;
                tr.outcome.trace[0] = d;
                if tr.learn && tr.p_target.is_none() {
                    // substep 6 (8.12 / 8.27): teach each map the pressure that reached v_i
                    let blend = self.cfg.coarse_blend;
                    let (lo, lr) = (self.cfg.loop_offset, self.cfg.loop_offset_rate);
                    if lo != 0.0 || lr != 0.0 {
                        // experiment (StageConfig::loop_offset): the rule taught the command
                        // less the offset; the learned offsets beside it
                        let coeff = self.cfg.p.coeff(t);
                        let side = tr.side;
                        let p_applied = tr.p_bar;
                        for (&k, &f) in self
                            .ranking
                            .indices()
                            .iter()
                            .zip(self.neighbour.value.iter())
                        {
                            let k = k as usize;
                            let g = coeff * f;
                            let local = self.net.local_output(k, v);
                            for m in 0..M {
                                let o = lo + self.loop_o[k][m];
                                let e = p_applied[m] - local[m] - side[m] * o;
                                let pm = crate::entry::Entry::get(
                                    self.net.p[k][m],
                                    crate::entry::TABLE_SCALES.p,
                                );
                                self.net.p[k][m] =
                                    <crate::entry::Table as crate::entry::Entry>::put(
                                        pm + g * e,
                                        crate::entry::TABLE_SCALES.p,
                                    );
                                self.loop_o[k][m] += lr * g * side[m] * e;
                            }
                        }
                    } else if blend != 0.0 {
                        // experiment (StageConfig::coarse_blend): the rule with the blended
                        // extrapolation, A_bar over the coarse output's ranks
                        let ranks = (self.cfg.coarse_ranks as usize).max(1);
                        let a_bar =
                            rules::mean_jacobian(&self.net, &self.ranking, &self.alpha, ranks - 1);
                        rules::update_pressures_blended(
                            &mut self.net,
                            &self.ranking,
                            &self.neighbour,
                            self.cfg.p.coeff(t),
                            &tr.p_bar,
                            v,
                            &a_bar,
                            blend,
                        );
                    } else {
                        rules::update_pressures(
                            &mut self.net,
                            &self.ranking,
                            &self.neighbour,
                            self.cfg.p.coeff(t),
                            &tr.p_bar,
                            v,
                        );
                    }
                }
                let over = d_est > tr.outcome.tolerance;
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
                let over = d_est > tr.outcome.tolerance;
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
                    let dv_len = libm::sqrtf(dv.iter().map(|x| x * x).sum::<f32>());
                    let updated =
                        if self.cfg.jac_rls_forget > 0.0 && dv_len >= self.cfg.jac_rls_min_dv {
                            // experiment (StageConfig::jac_rls_forget): recursive least squares
                            let r = rls_update(
                                &mut self.net,
                                &mut self.rls_p,
                                &mut self.rls_ok,
                                &self.ranking,
                                &self.neighbour,
                                &self.cfg,
                                &dp,
                                &dv,
                            );
                            if r.is_ok() && finish.is_none() {
                                a_bar = Some(rules::mean_jacobian(
                                    &self.net,
                                    &self.ranking,
                                    &self.alpha,
                                    self.cfg.fine_ranks as usize,
                                ));
                            }
                            r
                        } else if finish.is_none() {
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
                    let fp = self.cfg.fine_pressure;
                    if fp > 0.0 && tr.p_target.is_none() {
                        // experiment: the pressure rule taught by the fine move too
                        rules::update_pressures(
                            &mut self.net,
                            &self.ranking,
                            &self.neighbour,
                            fp * self.cfg.p.coeff(t),
                            &tr.p_last,
                            v,
                        );
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
                let mut a = rules::mean_jacobian(
                    &self.net,
                    &self.ranking,
                    &self.alpha,
                    self.cfg.fine_ranks as usize,
                );
                let np = (self.cfg.jac_by_pressure as usize).min(K);
                if np > 0 && !tr.learn {
                    // experiment (StageConfig::jac_by_pressure): the Jacobians of the
                    // neurons whose pressures are nearest the last command
                    let mut best = [(f32::INFINITY, 0usize); K];
                    for k in 0..N {
                        let pk = self.net.pressure(k);
                        let d2: f32 = (0..M).map(|m| (pk[m] - tr.p_last[m]).powi(2)).sum();
                        if d2 < best[np - 1].0 {
                            let mut i = np - 1;
                            while i > 0 && best[i - 1].0 > d2 {
                                best[i] = best[i - 1];
                                i -= 1;
                            }
                            best[i] = (d2, k);
                        }
                    }
                    let mut acc = [[0.0f32; D]; M];
                    let mut sum = 0.0;
                    for (r, &(_, k)) in best.iter().enumerate().take(np) {
                        let al = self.alpha.value[r];
                        let ak = self.net.jacobian(k);
                        for m in 0..M {
                            for d in 0..D {
                                acc[m][d] += al * ak[m][d];
                            }
                        }
                        sum += al;
                    }
                    let mix = self.cfg.jac_by_pressure_mix;
                    for m in 0..M {
                        for d in 0..D {
                            a[m][d] = mix * acc[m][d] / sum + (1.0 - mix) * a[m][d];
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
        let from = if filtering { tr.est } else { v_step };
        let mut p_fine = rules::fine_output(&tr.p_last, &a_bar, &target, &from, f32::INFINITY);
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
            let gain = d_est * d_est / (d_est * d_est + noise * noise);
            for m in 0..M {
                p_fine[m] = tr.p_last[m] + gain * (p_fine[m] - tr.p_last[m]);
            }
        }
        let near_avg = self.cfg.near_avg;
        if near_avg > 0.0 && !tr.learn {
            // experiment (StageConfig::near_avg): near the target, the n-th step goes 1 / n
            // of the way, so the command follows the mean of the readings' corrections
            if d_est <= near_avg * tr.outcome.tolerance {
                tr.near = tr.near.saturating_add(1);
                let gain = 1.0 / tr.near as f32;
                for m in 0..M {
                    p_fine[m] = tr.p_last[m] + gain * (p_fine[m] - tr.p_last[m]);
                }
            }
        }
        let dead = self.cfg.step_deadband;
        if dead > 0.0 && !tr.learn && tr.outcome.fine_moves > 0 {
            // experiment (StageConfig::step_deadband): each channel's step soft-thresholded,
            // a play band of the controller's own
            for m in 0..M {
                let step = p_fine[m] - tr.p_last[m];
                let kept = (libm::fabsf(step) - dead).max(0.0);
                p_fine[m] = tr.p_last[m] + libm::copysignf(kept, step);
            }
        }
        let boost = self.cfg.reverse_boost;
        if boost != 0.0 && !tr.learn && tr.outcome.fine_moves > 0 {
            for m in 0..M {
                let before = tr.p_last[m] - tr.p_prev[m];
                let step = p_fine[m] - tr.p_last[m];
                if before * step < 0.0 {
                    p_fine[m] = tr.p_last[m] + (1.0 + boost) * step;
                }
            }
        }
        let p_fine = rules::clamp(&p_fine, limit);
        if filtering {
            // the step aims at the target (scaled by the step's noise gain if on)
            let g = if noise > 0.0 {
                d_est * d_est / (d_est * d_est + noise * noise)
            } else {
                1.0
            };
            let f = self.cfg.est_model;
            for i in 0..D {
                tr.aim[i] = tr.est[i] + g * (target[i] - tr.est[i]);
            }
            let s = g * d_est;
            let b = self.cfg.est_floor;
            tr.est_var += (f * f * s * s + b * b) / D as f32;
        }
        tr.p_prev = tr.p_last;
        tr.v_prev = *v;
        tr.p_last = p_fine;
        self.phase = Phase::AwaitFine;
        Ok(StageStep::Move(p_fine))
    }

    fn finish(&mut self, d: f32, cap_hit: bool) -> StageStep<M> {
        let tr = &self.trial;
        if tr.learn && tr.p_target.is_none() && self.cfg.replay > 0 {
            // experiment (StageConfig::replay): the trial's moves through the rules again
            let t = tr.outcome.t;
            let n = (tr.outcome.fine_moves as usize + 1).min(TRACE_LEN);
            let (mp, mv) = (tr.moves_p, tr.moves_v);
            for _ in 0..self.cfg.replay {
                for k in 0..n {
                    rules::update_pressures(
                        &mut self.net,
                        &self.ranking,
                        &self.neighbour,
                        self.cfg.p.coeff(t),
                        &mp[k],
                        &mv[k],
                    );
                    if k > 0 {
                        let _ = rules::update_jacobians(
                            &mut self.net,
                            &self.ranking,
                            &self.neighbour,
                            self.cfg.j.coeff(t),
                            &sub(&mp[k], &mp[k - 1]),
                            &sub(&mv[k], &mv[k - 1]),
                            self.cfg.dv_rule(),
                        );
                    }
                }
            }
        }
        self.trial.outcome.final_error = d;
        self.trial.outcome.cap_hit = cap_hit;
        self.phase = Phase::Idle;
        StageStep::Done(self.trial.outcome)
    }
}

/// `|P e|` with `P = A^T (A A^T)^-1 A` the projection onto the row space of `a` (M x D):
/// `y = A e`, `|P e|^2 = y^T (A A^T)^-1 y`; `None` when `A A^T` is singular.
fn projected_distance<const D: usize, const M: usize>(
    a: &[[f32; D]; M],
    e: &[f32; D],
) -> Option<f32> {
    let mut g = [[0.0f32; M]; M];
    let mut y = [0.0f32; M];
    for i in 0..M {
        y[i] = (0..D).map(|k| a[i][k] * e[k]).sum();
        for j in 0..M {
            g[i][j] = (0..D).map(|k| a[i][k] * a[j][k]).sum();
        }
    }
    // Gaussian elimination with partial pivoting: z = G^-1 y
    let mut z = y;
    for c in 0..M {
        let piv = (c..M).max_by(|&p, &q| g[p][c].abs().total_cmp(&g[q][c].abs()))?;
        if !(g[piv][c].abs() > 1e-20) {
            return None;
        }
        g.swap(c, piv);
        z.swap(c, piv);
        for r in c + 1..M {
            let f = g[r][c] / g[c][c];
            for k in c..M {
                g[r][k] -= f * g[c][k];
            }
            z[r] -= f * z[c];
        }
    }
    for c in (0..M).rev() {
        let mut s = z[c];
        for k in c + 1..M {
            s -= g[c][k] * z[k];
        }
        z[c] = s / g[c][c];
    }
    let q: f32 = (0..M).map(|i| y[i] * z[i]).sum();
    (q.is_finite() && q >= 0.0).then(|| libm::sqrtf(q))
}

/// `|P e|` with `P` the projection onto the `M` principal directions of the points `ws`
/// (their covariance's leading eigenvectors, cyclic Jacobi).
fn pca_project<const D: usize, const M: usize>(ws: &[[f32; D]], e: &[f32; D]) -> [f32; D] {
    let n = ws.len() as f32;
    let mut mean = [0.0f32; D];
    for w in ws {
        for i in 0..D {
            mean[i] += w[i] / n;
        }
    }
    let mut c = [[0.0f32; D]; D];
    for w in ws {
        for i in 0..D {
            for j in 0..D {
                c[i][j] += (w[i] - mean[i]) * (w[j] - mean[j]);
            }
        }
    }
    let mut v = [[0.0f32; D]; D];
    for i in 0..D {
        v[i][i] = 1.0;
    }
    for _sweep in 0..30 {
        let mut off = 0.0;
        for p in 0..D {
            for q in p + 1..D {
                off += c[p][q] * c[p][q];
            }
        }
        if off < 1e-12 {
            break;
        }
        for p in 0..D {
            for q in p + 1..D {
                if c[p][q].abs() < 1e-20 {
                    continue;
                }
                let theta = (c[q][q] - c[p][p]) / (2.0 * c[p][q]);
                let t = theta.signum() / (theta.abs() + libm::sqrtf(theta * theta + 1.0));
                let t = if theta == 0.0 { 1.0 } else { t };
                let cs = 1.0 / libm::sqrtf(t * t + 1.0);
                let sn = t * cs;
                for k in 0..D {
                    let (ckp, ckq) = (c[k][p], c[k][q]);
                    c[k][p] = cs * ckp - sn * ckq;
                    c[k][q] = sn * ckp + cs * ckq;
                }
                for k in 0..D {
                    let (cpk, cqk) = (c[p][k], c[q][k]);
                    c[p][k] = cs * cpk - sn * cqk;
                    c[q][k] = sn * cpk + cs * cqk;
                }
                for k in 0..D {
                    let (vkp, vkq) = (v[k][p], v[k][q]);
                    v[k][p] = cs * vkp - sn * vkq;
                    v[k][q] = sn * vkp + cs * vkq;
                }
            }
        }
    }
    let mut order: [usize; D] = core::array::from_fn(|i| i);
    order.sort_by(|&a, &b| c[b][b].total_cmp(&c[a][a]));
    let mut out = [0.0f32; D];
    for &k in order.iter().take(M) {
        let y: f32 = (0..D).map(|i| v[i][k] * e[i]).sum();
        for i in 0..D {
            out[i] += y * v[i][k];
        }
    }
    out
}

/// Experiment (`StageConfig::jac_rls_forget`): the Jacobian rule (8.15 / 8.21) as
/// weighted recursive least squares for each ranked neuron. A sample of neighbourhood
/// weight `g` (the rule's falloff at the neuron's rank) forgets with
/// `l = 1 - (1 - forget) g` and enters with gain `K = P dv / (l / g + dv' P dv)`:
/// `A_k += (dp - A_k dv) K'`, `P = (P - K (P dv)') / l`. Ranks of weight below 1e-4 are
/// left alone. Refused as (8.15) refuses it when `dv` is shorter than the rule's minimum.
#[allow(clippy::too_many_arguments)]
fn rls_update<const N: usize, const D: usize, const M: usize, const K: usize>(
    net: &mut Trn<N, D, M>,
    rls_p: &mut [[[f32; D]; D]; N],
    rls_ok: &mut [bool; N],
    ranking: &Ranking<K>,
    neighbour: &Falloff<K>,
    cfg: &StageConfig,
    dp: &[f32; M],
    dv: &[f32; D],
) -> Result<()> {
    let n2: f32 = dv.iter().map(|x| x * x).sum();
    if !(n2.is_finite() && n2 >= cfg.min_dv * cfg.min_dv) || n2 == 0.0 {
        return Err(Error::ZeroLengthDv);
    }
    let forget = cfg.jac_rls_forget;
    let init = cfg.jac_rls_init;
    for (&k, &g) in ranking.indices().iter().zip(neighbour.value.iter()) {
        if g < 1e-4 {
            continue;
        }
        let k = k as usize;
        if !rls_ok[k] {
            rls_p[k] =
                core::array::from_fn(|i| core::array::from_fn(|j| if i == j { init } else { 0.0 }));
            rls_ok[k] = true;
        }
        let l = 1.0 - (1.0 - forget) * g;
        let p = &mut rls_p[k];
        let pdv: [f32; D] = core::array::from_fn(|i| {
            let mut acc = 0.0;
            for j in 0..D {
                acc += p[i][j] * dv[j];
            }
            acc
        });
        let q: f32 = (0..D).map(|i| dv[i] * pdv[i]).sum();
        let denom = l / g + q;
        if !(denom > 0.0) {
            continue;
        }
        let gain: [f32; D] = pdv.map(|x| x / denom);
        let a = &mut net.a[k];
        for m in 0..M {
            let mut pred = 0.0;
            for d in 0..D {
                pred += crate::entry::Entry::get(a[m][d], crate::entry::TABLE_SCALES.a) * dv[d];
            }
            let e = dp[m] - pred;
            for d in 0..D {
                let x = crate::entry::Entry::get(a[m][d], crate::entry::TABLE_SCALES.a);
                a[m][d] = <crate::entry::Table as crate::entry::Entry>::put(
                    x + e * gain[d],
                    crate::entry::TABLE_SCALES.a,
                );
            }
        }
        for i in 0..D {
            for j in 0..D {
                p[i][j] = (p[i][j] - gain[i] * pdv[j]) / l;
            }
        }
    }
    Ok(())
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
    fn note_held(&mut self, held: &[f32; M]) {
        Stage::note_held(self, held)
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
