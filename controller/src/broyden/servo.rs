//! One stage of the Broyden servo (see [`crate::broyden`]): its Jacobian, measured at home
//! and corrected by Broyden's update after every move, and the damped-least-squares step.

use nalgebra::{SMatrix, SVector};

use super::BroydenConfig;
use crate::config::StageConfig;
use crate::error::{Error, Result};
use crate::law::StageLaw;
use crate::rank::RankScratch;
use crate::rules::clamp;
use crate::trial::{
    check_input, distance, sub, FineMoves, StageOutcome, StageStep, TRACE_LEN, ZERO_OUTCOME,
};

/// Fieldless, so that `Idle` is the zero byte of a zeroed controller (firmware `.bss`).
#[derive(Debug, Clone, Copy, PartialEq)]
#[repr(u8)]
enum Phase {
    Idle = 0,
    /// The home move was made; its observation is awaited.
    AwaitHome = 1,
    /// The exploratory move of joint `explored` made.
    AwaitExplore = 2,
    /// A servo move made.
    AwaitServo = 3,
}

/// One stage of the Broyden servo: `D` image coordinates, `M` joints.
#[derive(Debug, Clone)]
pub struct BroydenStage<const D: usize, const M: usize> {
    cfg: StageConfig,
    bcfg: BroydenConfig,
    /// The Jacobian measured at home (valid when `measured`).
    home_jacobian: [[f32; M]; D],
    measured: bool,
    /// The trial's Jacobian, corrected after every move.
    jacobian: [[f32; M]; D],
    phase: Phase,
    /// The joint of the exploratory move in progress.
    explored: u8,
    target: [f32; D],
    exact: Option<u8>,
    /// Observation at home; the last command, and the command and observation before it.
    y_home: [f32; D],
    q_last: [f32; M],
    q_prev: [f32; M],
    y_prev: [f32; D],
    outcome: StageOutcome,
}

impl<const D: usize, const M: usize> BroydenStage<D, M> {
    /// A stage that has measured nothing yet.
    pub const fn new(cfg: StageConfig, bcfg: BroydenConfig) -> Self {
        BroydenStage {
            cfg,
            bcfg,
            home_jacobian: [[0.0; M]; D],
            measured: false,
            jacobian: [[0.0; M]; D],
            phase: Phase::Idle,
            explored: 0,
            target: [0.0; D],
            exact: None,
            y_home: [0.0; D],
            q_last: [0.0; M],
            q_prev: [0.0; M],
            y_prev: [0.0; D],
            outcome: ZERO_OUTCOME,
        }
    }

    /// Replaces the configuration between trials; the Jacobian is measured again.
    pub fn set_config(&mut self, cfg: StageConfig, bcfg: BroydenConfig) -> Result<()> {
        if self.busy() {
            return Err(Error::Busy);
        }
        self.cfg = cfg;
        self.bcfg = bcfg;
        self.measured = false;
        Ok(())
    }

    /// Forgets the Jacobian (the next trial measures it again).
    pub fn reset(&mut self) {
        self.measured = false;
        self.phase = Phase::Idle;
    }

    /// The Jacobian measured at home, once measured.
    pub fn home_jacobian(&self) -> Option<&[[f32; M]; D]> {
        self.measured.then_some(&self.home_jacobian)
    }

    /// True while a trial is running.
    pub fn busy(&self) -> bool {
        self.phase != Phase::Idle
    }

    /// Abandons the running trial.
    pub fn abort(&mut self) {
        self.phase = Phase::Idle;
    }

    /// Checks a target or observation as the TRN stage does.
    pub fn check_input(&self, u: &[f32; D]) -> Result<()> {
        check_input(&self.cfg, u)
    }

    /// Starts a trial towards `target`: the first move goes home. The method does not train:
    /// a supervised trial's pressure is not used, only reported as `supervised` (the
    /// protocol reports priming trials as such).
    pub fn begin_with(
        &mut self,
        target: &[f32; D],
        supervised: bool,
        fine: FineMoves,
    ) -> Result<[f32; M]> {
        if self.busy() {
            return Err(Error::Busy);
        }
        self.check_input(target)?;
        self.exact = fine.budget()?;
        let home = self
            .bcfg
            .home
            .clamp(-self.cfg.pressure_limit, self.cfg.pressure_limit);
        self.target = *target;
        self.q_last = [home; M];
        self.jacobian = self.home_jacobian;
        self.outcome = StageOutcome {
            tolerance: self.cfg.mature_tolerance,
            supervised,
            ..ZERO_OUTCOME
        };
        self.phase = Phase::AwaitHome;
        Ok(self.q_last)
    }

    /// Consumes the observation that followed the last command.
    pub fn observe(&mut self, y: &[f32; D]) -> Result<StageStep<M>> {
        if self.phase == Phase::Idle {
            return Err(Error::UnexpectedObservation);
        }
        self.check_input(y)?;
        let d = distance(y, &self.target);
        let phase = self.phase;
        match phase {
            Phase::AwaitHome => {
                self.outcome.coarse_error = d;
                self.outcome.trace[0] = d;
                self.y_home = *y;
            }
            _ => {
                self.outcome.fine_moves += 1;
                let n = self.outcome.fine_moves as usize;
                if n < TRACE_LEN {
                    self.outcome.trace[n] = d;
                }
            }
        }
        match phase {
            Phase::AwaitExplore => {
                let j = self.explored;
                let step = self.bcfg.explore_step;
                for r in 0..D {
                    self.home_jacobian[r][j as usize] = (y[r] - self.y_home[r]) / step;
                }
            }
            Phase::AwaitServo => self.broyden_update(y),
            _ => {}
        }
        if let Some(step) = self.stop(d) {
            return Ok(step);
        }
        // the next move: explore the next joint while the Jacobian is not measured
        let explore_next = match phase {
            Phase::AwaitHome if !self.measured => Some(0),
            Phase::AwaitExplore if (self.explored as usize) + 1 < M => Some(self.explored + 1),
            Phase::AwaitExplore => {
                self.measured = true;
                self.jacobian = self.home_jacobian;
                None
            }
            _ => None,
        };
        self.q_prev = self.q_last;
        self.y_prev = *y;
        if let Some(j) = explore_next {
            let mut q = [self.bcfg.home; M];
            q[j as usize] += self.bcfg.explore_step;
            self.q_last = clamp(&q, self.cfg.pressure_limit);
            self.phase = Phase::AwaitExplore;
            self.explored = j;
            return Ok(StageStep::Move(self.q_last));
        }
        self.q_last = self.servo_step(y);
        self.phase = Phase::AwaitServo;
        Ok(StageStep::Move(self.q_last))
    }

    /// The trial's end, if it ends here: a fixed budget spent, or (the controller's rule)
    /// within tolerance or at the cap. Exploration must finish before the rule stops a
    /// trial early, so that the Jacobian is measured once.
    fn stop(&mut self, d: f32) -> Option<StageStep<M>> {
        let fine = self.outcome.fine_moves;
        let over = d > self.outcome.tolerance;
        let exploring = !self.measured;
        let done = match self.exact {
            Some(n) => fine >= n,
            None => {
                (!over && !exploring)
                    || fine >= self.bcfg.max_fine_moves
                    || fine as usize >= TRACE_LEN - 1
            }
        };
        if !done {
            return None;
        }
        if exploring && self.phase == Phase::AwaitExplore && self.explored as usize + 1 == M {
            self.measured = true;
        }
        self.outcome.final_error = d;
        self.outcome.cap_hit = over;
        self.phase = Phase::Idle;
        Some(StageStep::Done(self.outcome))
    }

    /// Broyden's rank-one correction from the last move.
    fn broyden_update(&mut self, y: &[f32; D]) {
        let dq = sub(&self.q_last, &self.q_prev);
        let dq2: f32 = dq.iter().map(|x| x * x).sum();
        if libm::sqrtf(dq2) < self.bcfg.min_update_step {
            self.outcome.skipped_updates = self.outcome.skipped_updates.saturating_add(1);
            return;
        }
        let dy = sub(y, &self.y_prev);
        for r in 0..D {
            let predicted: f32 = (0..M).map(|c| self.jacobian[r][c] * dq[c]).sum();
            let k = self.bcfg.alpha * (dy[r] - predicted) / dq2;
            for c in 0..M {
                self.jacobian[r][c] += k * dq[c];
            }
        }
    }

    /// The damped-least-squares step from `y` towards the target, limited in size, joints
    /// at their limits excluded.
    fn servo_step(&self, y: &[f32; D]) -> [f32; M] {
        let limit = self.cfg.pressure_limit;
        let e = SVector::<f32, D>::from_fn(|r, _| self.target[r] - y[r]);
        let mut active = [true; M];
        let mut dq = [0.0; M];
        for _ in 0..2 {
            let j =
                SMatrix::<f32, D, M>::from_fn(
                    |r, c| {
                        if active[c] {
                            self.jacobian[r][c]
                        } else {
                            0.0
                        }
                    },
                );
            let jtj = j.transpose() * j;
            let lambda = (self.bcfg.damping * jtj.trace() / M as f32).max(f32::MIN_POSITIVE);
            let a = jtj + SMatrix::<f32, M, M>::identity() * lambda;
            let b = j.transpose() * e;
            let Some(x) = a.cholesky().map(|c| c.solve(&b)) else {
                return self.q_last;
            };
            dq = core::array::from_fn(|c| if active[c] { x[c] } else { 0.0 });
            // a joint at its limit that the step pushes further is excluded, once
            let mut changed = false;
            for c in 0..M {
                let at_limit = (self.q_last[c] >= limit && dq[c] > 0.0)
                    || (self.q_last[c] <= -limit && dq[c] < 0.0);
                if active[c] && at_limit {
                    active[c] = false;
                    changed = true;
                }
            }
            if !changed {
                break;
            }
        }
        let largest = dq.iter().fold(0.0f32, |m, x| m.max(x.abs()));
        let scale = if largest > self.bcfg.max_step && largest.is_finite() {
            self.bcfg.max_step / largest
        } else if largest.is_finite() {
            1.0
        } else {
            0.0
        };
        let q = core::array::from_fn(|c| self.q_last[c] + scale * dq[c]);
        clamp(&q, limit)
    }
}

/// The Broyden servo is a stage law that never learns: `learn` and a supervised pressure
/// change nothing (a supervised trial is reported as such); it needs no shared memory.
impl<const D: usize, const M: usize> StageLaw<D, M> for BroydenStage<D, M> {
    fn check_input(&self, u: &[f32; D]) -> Result<()> {
        BroydenStage::check_input(self, u)
    }
    fn begin(
        &mut self,
        target: &[f32; D],
        supervised: Option<&[f32; M]>,
        _learn: bool,
        fine: FineMoves,
        _scratch: &mut RankScratch,
    ) -> Result<[f32; M]> {
        self.begin_with(target, supervised.is_some(), fine)
    }
    fn observe(&mut self, u: &[f32; D], _scratch: &mut RankScratch) -> Result<StageStep<M>> {
        BroydenStage::observe(self, u)
    }
    fn abort(&mut self) {
        BroydenStage::abort(self)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Config;

    /// A smooth, coupled plant: 3 pressures to 4 pixel coordinates.
    fn plant(q: &[f32; 3]) -> [f32; 4] {
        [
            500.0 + 200.0 * libm::sinf(q[0]) + 40.0 * q[1],
            400.0 + 150.0 * q[1] + 30.0 * q[2] * q[0],
            520.0 + 180.0 * libm::sinf(q[0]) + 60.0 * q[2],
            390.0 + 140.0 * q[1] - 80.0 * q[2],
        ]
    }

    fn stage() -> BroydenStage<4, 3> {
        BroydenStage::new(Config::project_default().stage2, BroydenConfig::DEFAULT)
    }

    fn run(s: &mut BroydenStage<4, 3>, target: &[f32; 4], fine: FineMoves) -> StageOutcome {
        let mut step = StageStep::Move(s.begin_with(target, false, fine).unwrap());
        loop {
            match step {
                StageStep::Move(q) => step = s.observe(&plant(&q)).unwrap(),
                StageStep::Done(o) => return o,
            }
        }
    }

    #[test]
    fn explores_once_then_servos_to_the_tolerance() {
        let mut s = stage();
        let target = plant(&[0.5, -0.4, 0.3]);
        let first = run(&mut s, &target, FineMoves::Policy);
        assert!(s.home_jacobian().is_some());
        // the exploration (3 moves) is part of the first trial
        assert!(first.fine_moves > 3, "{first:?}");
        assert!(first.final_error <= first.tolerance, "{first:?}");
        // measured Jacobian close to the plant's at home: d y0 / d q0 = 200 cos(0)
        let j = s.home_jacobian().unwrap();
        assert!((j[0][0] - 200.0).abs() < 5.0, "{j:?}");
        let second = run(&mut s, &plant(&[-0.3, 0.2, -0.5]), FineMoves::Policy);
        assert!(second.final_error <= second.tolerance, "{second:?}");
        assert!(
            second.fine_moves < first.fine_moves,
            "{second:?} vs {first:?}"
        );
        assert!(!second.cap_hit);
    }

    /// The whole state of both stages (the README's RAM row): what a Broyden-only build
    /// needs beside its code, against the TRN's 227,200 bytes of tables.
    #[test]
    fn both_stages_fit_in_about_a_kilobyte() {
        let bytes =
            core::mem::size_of::<BroydenStage<8, 5>>() + core::mem::size_of::<BroydenStage<4, 3>>();
        println!("Broyden servo state, both stages: {bytes} bytes");
        assert!(bytes < 1024 + 512, "{bytes} bytes");
    }

    #[test]
    fn a_fixed_budget_makes_exactly_that_many_moves() {
        let mut s = stage();
        run(&mut s, &plant(&[0.1, 0.1, 0.1]), FineMoves::Policy);
        let o = run(&mut s, &plant(&[0.6, -0.2, 0.4]), FineMoves::Exactly(2));
        assert_eq!(o.fine_moves, 2);
        assert!(o.trace[2] < o.trace[0], "{o:?}");
    }

    #[test]
    fn bad_observations_and_states_are_typed_errors() {
        let mut s = stage();
        assert_eq!(s.observe(&[1.0; 4]), Err(Error::UnexpectedObservation));
        let t = plant(&[0.0; 3]);
        assert!(matches!(
            s.begin_with(&[f32::NAN, 0.0, 0.0, 0.0], false, FineMoves::Policy),
            Err(Error::NonFiniteInput { index: 0 })
        ));
        s.begin_with(&t, false, FineMoves::Policy).unwrap();
        assert_eq!(s.begin_with(&t, false, FineMoves::Policy), Err(Error::Busy));
        assert!(matches!(
            s.observe(&[0.0, 1e9, 0.0, 0.0]),
            Err(Error::InputOutOfRange { index: 1, .. })
        ));
        // the trial survives a bad reading
        assert!(s.busy());
        s.abort();
        assert_eq!(
            s.begin_with(&t, false, FineMoves::Exactly(40)),
            Err(Error::FineMoveBudget)
        );
    }

    #[test]
    fn joints_at_their_limits_are_not_pushed_further() {
        let mut s = stage();
        run(&mut s, &plant(&[0.0; 3]), FineMoves::Policy);
        // joint 0 would need 1.3: it stops at the limit, and the other joints find the best
        // the arm can do with it there (a grid search over them says how good that is)
        let target = plant(&[1.3, 0.3, -0.2]);
        let o = run(&mut s, &target, FineMoves::Exactly(15));
        let limit = s.cfg.pressure_limit;
        assert_eq!(s.q_last[0], limit);
        let mut best = f32::INFINITY;
        for a in -100..=100 {
            for b in -100..=100 {
                let q = [limit, a as f32 / 100.0, b as f32 / 100.0];
                best = best.min(distance(&plant(&q), &target));
            }
        }
        assert!(
            o.final_error < best + 1.0,
            "{} vs best {best}: {o:?}",
            o.final_error
        );
    }
}
