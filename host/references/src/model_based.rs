//! Controllers that solve for a target on a model of the arm instead of learning: the
//! learning-free references of the comparison. Each runs in process behind the same
//! [`Control`] seam, in the same CAN node, so it is scored exactly like the TRN and the
//! Broyden servo; neither is a controller for the MCU (each carries the simulator).
//!
//! - [`crate::nominal::NominalIk`] (`--controller model`): a perfectly calibrated model without hysteresis
//!   compensation: the arm's links, cameras and each joint's pressure-to-angle curve, but
//!   loops of zero width, no drift, no wear, no dynamics ([`crate::nominal`]).
//! - [`crate::oracle::Oracle`] (`--controller oracle`): the physical limit: it solves on an
//!   exact copy of the plant as it is now (hysteresis history, drift, wear), so that only
//!   process noise, creep and camera noise stand between it and the target.
//!
//! The coarse move is a damped least-squares solve (Levenberg-Marquardt) on the model; a
//! fine move is a Gauss-Newton step from the pressure commanded last with the observed
//! error (the nominal model), or a new solve from the plant's state after the move (the
//! oracle). The stop rule is the TRN's mature tolerance and cap.

use nalgebra::{SMatrix, SVector};
use trn_controller::presets::SessionProfile;
use trn_controller::stage::{StageOutcome, TRACE_LEN, ZERO_OUTCOME};
use trn_controller::{
    Command, Config, Control, Error, FineMoves, Law, Observation, ObserveKind, Outcome, Task,
};

/// Levenberg-Marquardt iterations of a solve, at most.
const IK_ITERATIONS: usize = 60;
/// A solve is done when the model's image is this close to the target (px squared over
/// all coordinates: a hundredth of a pixel).
const SOLVED_PX2: f64 = 1e-4;
/// A solve that ends farther than this from the target (px squared: 1 px) tries other
/// starts.
const RETRY_PX2: f64 = 1.0;

#[derive(Debug, Clone, Copy, PartialEq)]
enum Stage {
    One,
    Two,
}

#[derive(Debug, Clone, Copy)]
struct Trial {
    stage: Stage,
    target1: [f32; 8],
    target2: Option<[f32; 4]>,
    exact: Option<u8>,
    /// A supervised (priming) trial: reported as such, its pressure not used.
    supervised: bool,
    outcome: StageOutcome,
    stage1: Option<StageOutcome>,
    awaiting_first: bool,
}

/// What a model-based controller knows of the arm.
pub trait ArmModel {
    /// The image of the lights (`D = 8`: p and q in both cameras; `D = 4`: the gripper
    /// centre) when pressures `p` are commanded now, if all are in view.
    fn image<const D: usize>(&mut self, p: &[f64; 5]) -> Option<SVector<f64, D>>;
    /// Where a stage's solve starts: the nominal model from zero pressure (it does not know
    /// where the arm is), the oracle from the pressures the arm holds.
    fn start(&self, held: [f64; 5], joints: usize) -> [f64; 5];
    /// True when a fine move is a new solve on the model (it knows the arm's state after the
    /// move); false: one Gauss-Newton step with the observed error.
    fn resolves(&self) -> bool;
    /// The host-side controller this model runs as: its law code on the wire
    /// ([`crate::law_code`]).
    fn law_code(&self) -> u8;
    /// The finite-difference step of the model's Jacobian (normalised pressure): at least a
    /// step of the servo drives' 12-bit command where the model goes through them.
    fn step_size(&self) -> f64;
}

/// A model-based controller over model `A`.
pub struct ModelBased<A> {
    model: A,
    cfg: Config,
    /// Pressures commanded last, all joints.
    held: [f64; 5],
    trial: Option<Trial>,
}

impl<A: ArmModel> ModelBased<A> {
    /// The controller on `model` with `cfg` (its stop rule).
    pub fn on(model: A, cfg: Config) -> Self {
        ModelBased {
            model,
            cfg,
            held: [0.0; 5],
            trial: None,
        }
    }

    /// The model it solves on (the Python binding hands the oracle's model the arm's plant
    /// before each decision).
    pub fn model_mut(&mut self) -> &mut A {
        &mut self.model
    }

    fn limit(&self) -> f64 {
        self.cfg.stage1.pressure_limit as f64
    }

    fn image<const D: usize>(&mut self, p: &[f64; 5]) -> Option<SVector<f64, D>> {
        self.model.image::<D>(p)
    }

    /// The model Jacobian of the image over the first `M` joints at `p`, whose image is
    /// `y0`.
    fn jacobian_at<const D: usize, const M: usize>(
        &mut self,
        p: &[f64; 5],
        y0: &SVector<f64, D>,
    ) -> Option<SMatrix<f64, D, M>> {
        let h = self.model.step_size();
        let mut j = SMatrix::<f64, D, M>::zeros();
        for c in 0..M {
            let mut q = *p;
            // away from the pressure limit
            let dh = if q[c] + h > self.limit() { -h } else { h };
            q[c] += dh;
            let y = self.image::<D>(&q)?;
            j.set_column(c, &((y - y0) / dh));
        }
        Some(j)
    }

    /// One damped Gauss-Newton step with Jacobian `j` over the first `M` joints from `p`
    /// towards `err` (target - image), clamped to the pressure limits.
    fn damped<const D: usize, const M: usize>(
        &self,
        j: &SMatrix<f64, D, M>,
        p: &[f64; 5],
        err: &SVector<f64, D>,
        lambda: f64,
    ) -> Option<[f64; 5]> {
        let jtj = j.transpose() * j;
        let scale = jtj.trace() / M as f64;
        let a = jtj + SMatrix::<f64, M, M>::identity() * (lambda * scale).max(1e-12);
        let dq = a.cholesky()?.solve(&(j.transpose() * err));
        let limit = self.limit();
        let mut q = *p;
        for c in 0..M {
            q[c] = (q[c] + dq[c]).clamp(-limit, limit);
        }
        Some(q)
    }

    /// One Gauss-Newton step from `p` towards `err` with the model's Jacobian there.
    fn step<const D: usize, const M: usize>(
        &mut self,
        p: &[f64; 5],
        err: &SVector<f64, D>,
        lambda: f64,
    ) -> Option<[f64; 5]> {
        let y0 = self.image::<D>(p)?;
        let j = self.jacobian_at::<D, M>(p, &y0)?;
        self.damped(&j, p, err, lambda)
    }

    /// The pressures over the first `M` joints whose image on the model is `target`:
    /// [`Self::descend`] from `start`, and where that stops short of the target (a local
    /// minimum of a non-smooth map), from a few other starts too; the closest wins.
    fn solve<const D: usize, const M: usize>(
        &mut self,
        target: &[f32],
        start: [f64; 5],
    ) -> [f64; 5] {
        let (mut best, mut cost) = self.descend::<D, M>(target, start);
        let limit = self.limit();
        for guess in [0.0, -0.5 * limit, 0.5 * limit] {
            if cost < RETRY_PX2 {
                break;
            }
            let mut other = start;
            other[..M].fill(guess);
            let (p, c) = self.descend::<D, M>(target, other);
            if c < cost {
                (best, cost) = (p, c);
            }
        }
        best
    }

    /// Levenberg-Marquardt from `start` (the Jacobian measured again only after an
    /// accepted step): the pressures reached and their squared image error.
    fn descend<const D: usize, const M: usize>(
        &mut self,
        target: &[f32],
        start: [f64; 5],
    ) -> ([f64; 5], f64) {
        let t = SVector::<f64, D>::from_fn(|i, _| target[i] as f64);
        let mut p = start;
        let Some(mut y) = self.image::<D>(&p) else {
            return (p, f64::INFINITY);
        };
        let mut cost = (t - y).norm_squared();
        let mut lambda = 1e-3;
        let mut jac = None;
        for _ in 0..IK_ITERATIONS {
            if cost < SOLVED_PX2 {
                break;
            }
            if jac.is_none() {
                jac = self.jacobian_at::<D, M>(&p, &y);
            }
            let Some(j) = &jac else { break };
            let Some(q) = self.damped(j, &p, &(t - y), lambda) else {
                break;
            };
            match self.image::<D>(&q) {
                Some(yq) if (t - yq).norm_squared() < cost => {
                    let c = (t - yq).norm_squared();
                    let done = cost - c < 1e-9 * cost.max(1.0);
                    (p, y, cost, lambda, jac) = (q, yq, c, lambda * 0.3, None);
                    if done {
                        break;
                    }
                }
                _ if lambda > 1e8 => break,
                _ => lambda *= 10.0,
            }
        }
        (p, cost)
    }

    fn command(&self, stage: Stage) -> Command {
        let pressures = self.held.map(|x| x as f32);
        match stage {
            Stage::One => Command::Move {
                pressures,
                joints: 5,
                observe: ObserveKind::Lights,
            },
            Stage::Two => Command::Move {
                pressures,
                joints: 3,
                observe: ObserveKind::Centre,
            },
        }
    }

    fn begin_stage(&mut self, stage: Stage, tr: &mut Trial) -> Command {
        let scfg = match stage {
            Stage::One => self.cfg.stage1,
            Stage::Two => self.cfg.stage2,
        };
        tr.stage = stage;
        tr.awaiting_first = true;
        tr.outcome = StageOutcome {
            tolerance: scfg.mature_tolerance,
            supervised: tr.supervised && stage == Stage::One,
            ..ZERO_OUTCOME
        };
        self.held = match (stage, tr.target2) {
            (Stage::One, _) => {
                let start = self.model.start(self.held, 5);
                self.solve::<8, 5>(&tr.target1, start)
            }
            (Stage::Two, Some(c)) => {
                let start = self.model.start(self.held, 3);
                self.solve::<4, 3>(&c, start)
            }
            (Stage::Two, None) => self.held,
        };
        self.command(stage)
    }

    fn check<const D: usize>(&self, u: &[f32; D]) -> trn_controller::Result<()> {
        trn_controller::stage::check_input(&self.cfg.stage1, u)
    }
}

fn distance(a: &[f32], b: &[f32]) -> f32 {
    a.iter()
        .zip(b)
        .map(|(x, y)| (x - y) * (x - y))
        .sum::<f32>()
        .sqrt()
}

impl<A: ArmModel> Control for ModelBased<A> {
    fn begin_with(&mut self, task: Task, fine: FineMoves) -> trn_controller::Result<Command> {
        if self.trial.is_some() {
            return Err(Error::Busy);
        }
        let exact = fine.budget()?;
        let supervised = matches!(
            task,
            Task::Stage1 {
                supervised: Some(_),
                ..
            }
        );
        let (stage, target1, target2) = match task {
            Task::Stage1 { v, .. } => {
                self.check(&v)?;
                (Stage::One, v, None)
            }
            Task::Stage2 { c, .. } => {
                self.check(&c)?;
                (Stage::Two, [0.0; 8], Some(c))
            }
            Task::Grasp { v, c, .. } => {
                self.check(&v)?;
                self.check(&c)?;
                (Stage::One, v, Some(c))
            }
        };
        let mut tr = Trial {
            stage,
            target1,
            target2,
            exact,
            supervised,
            outcome: ZERO_OUTCOME,
            stage1: None,
            awaiting_first: true,
        };
        let cmd = self.begin_stage(stage, &mut tr);
        self.trial = Some(tr);
        Ok(cmd)
    }

    fn observe(&mut self, obs: Observation) -> trn_controller::Result<Command> {
        let Some(mut tr) = self.trial else {
            return Err(Error::UnexpectedObservation);
        };
        let (seen, target): (&[f32], Vec<f32>) = match (tr.stage, &obs) {
            (Stage::One, Observation::Lights(v)) => {
                self.check(v)?;
                (v, tr.target1.to_vec())
            }
            (Stage::Two, Observation::Centre(c)) => {
                self.check(c)?;
                (c, tr.target2.unwrap_or([0.0; 4]).to_vec())
            }
            _ => return Err(Error::WrongObservationKind),
        };
        let d = distance(seen, &target);
        let o = &mut tr.outcome;
        if tr.awaiting_first {
            o.coarse_error = d;
            o.trace[0] = d;
            tr.awaiting_first = false;
        } else {
            o.fine_moves += 1;
            if (o.fine_moves as usize) < TRACE_LEN {
                o.trace[o.fine_moves as usize] = d;
            }
        }
        let scfg = match tr.stage {
            Stage::One => self.cfg.stage1,
            Stage::Two => self.cfg.stage2,
        };
        let over = d > o.tolerance;
        let done = match tr.exact {
            Some(n) => o.fine_moves >= n,
            None => !over || o.fine_moves >= scfg.max_fine_moves,
        };
        if done {
            o.final_error = d;
            o.cap_hit = over;
            match (tr.stage, tr.target2) {
                (Stage::One, Some(_)) => {
                    tr.stage1 = Some(tr.outcome);
                    let cmd = self.begin_stage(Stage::Two, &mut tr);
                    self.trial = Some(tr);
                    return Ok(cmd);
                }
                _ => {
                    self.trial = None;
                    let (stage1, stage2) = match tr.stage {
                        Stage::One => (Some(tr.outcome), None),
                        Stage::Two => (tr.stage1, Some(tr.outcome)),
                    };
                    return Ok(Command::Done(Outcome {
                        stage1,
                        stage2,
                        close_gripper: stage1.is_some() && stage2.is_some(),
                    }));
                }
            }
        }
        // a fine move: a new solve from the arm's state now (a model that knows it), or the
        // model's Gauss-Newton step from the pressure commanded last with the observed error
        let p = self.held;
        if self.model.resolves() {
            self.held = match tr.stage {
                Stage::One => self.solve::<8, 5>(&tr.target1, p),
                Stage::Two => self.solve::<4, 3>(&tr.target2.unwrap_or([0.0; 4]), p),
            };
            self.trial = Some(tr);
            return Ok(self.command(tr.stage));
        }
        let next = match tr.stage {
            Stage::One => {
                let e = SVector::<f64, 8>::from_fn(|i, _| (target[i] - seen[i]) as f64);
                self.step::<8, 5>(&p, &e, 1e-3)
            }
            Stage::Two => {
                let e = SVector::<f64, 4>::from_fn(|i, _| (target[i] - seen[i]) as f64);
                self.step::<4, 3>(&p, &e, 1e-3)
            }
        };
        self.held = next.unwrap_or(p);
        self.trial = Some(tr);
        Ok(self.command(tr.stage))
    }

    fn abort(&mut self) {
        self.trial = None;
    }

    fn busy(&self) -> bool {
        self.trial.is_some()
    }

    fn config(&self) -> &Config {
        &self.cfg
    }

    /// A configuration whose law is the TRN's (of which it uses the stop rule: its own
    /// law is the host-side code, [`ArmModel::law`], that [`Control::session_config`]
    /// checks).
    fn set_config(&mut self, cfg: Config) -> trn_controller::Result<()> {
        if self.busy() {
            return Err(Error::Busy);
        }
        if cfg.law != Law::Trn {
            return Err(Error::UnsupportedLaw);
        }
        self.cfg = cfg;
        Ok(())
    }

    /// Its own law code only: the configuration of the asked preset and ablation with the
    /// TRN's law (of which it uses the stop rule), fingerprinted with its own code.
    fn session_config(&self, asked: SessionProfile) -> trn_controller::Result<(Config, u32)> {
        if asked.law != self.model.law_code() {
            return Err(Error::UnsupportedLaw);
        }
        let cfg = trn_controller::presets::Profile {
            preset: asked.preset,
            ablation: asked.ablation,
            law: Law::Trn,
        }
        .config(asked.image);
        Ok((cfg, cfg.fingerprint_as(self.model.law_code())))
    }

    fn fingerprint(&self) -> u32 {
        self.cfg.fingerprint_as(self.model.law_code())
    }

    /// Nothing to draw: the model is the calibration.
    fn init_random(&mut self, _seed: u64) {}
}
