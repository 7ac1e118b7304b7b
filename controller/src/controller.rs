//! Both networks and the two-stage grasp, behind one state machine.

use crate::broyden::BroydenPair;
#[cfg(feature = "broyden")]
use crate::broyden::BroydenStage;
use crate::config::{Config, Law};
use crate::error::{Error, Result};
use crate::law::StageLaw;
use crate::rank::RankScratch;
use crate::stage::Stage;
use crate::trial::{FineMoves, StageOutcome, StageStep, ZERO_OUTCOME};

/// Experiment (`StageConfig::loop_from_drives`): the pressures the drives hold at the start
/// of the next trial (`f32` bits), published by the harness before it sends the target. One
/// set per process: runs that read it must not run beside each other (`--jobs 1`).
pub static EXP_START: [core::sync::atomic::AtomicU32; 5] =
    [const { core::sync::atomic::AtomicU32::new(0) }; 5];

fn exp_start() -> [f32; 5] {
    core::array::from_fn(|i| {
        f32::from_bits(EXP_START[i].load(core::sync::atomic::Ordering::Relaxed))
    })
}

/// Ranks that carry weight in the averages and updates (see [`crate::rules`]).
pub const RANKS: usize = 128;

/// The stage-1 learner: 1000 neurons, 8-D lights, 5 pressures.
pub type Stage1 = Stage<1000, 8, 5, RANKS>;
/// The stage-2 learner: 200 neurons, 4-D gripper centre, 3 pressures (joints 0..3).
pub type Stage2 = Stage<200, 4, 3, RANKS>;

/// Number of joints of the arm.
pub const JOINTS: usize = 5;

/// What the controller is asked to do.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Task {
    /// One stage-1 trial towards the lights `v` (8-D). With `supervised = Some(P_target)`
    /// it is a supervised priming step (8.17-8.21); otherwise it learns when `learn`.
    Stage1 {
        /// Target lights p and q in both cameras.
        v: [f32; 8],
        /// The pressure that produced `v`, when known (priming).
        supervised: Option<[f32; 5]>,
        /// Update the tables.
        learn: bool,
    },
    /// One stage-2 trial towards the gripper-centre image `c` (4-D), moving joints 0..3.
    Stage2 {
        /// Target gripper centre in both cameras.
        c: [f32; 4],
        /// Update the tables.
        learn: bool,
    },
    /// A full grasp: stage 1 to the pre-grasp pose given lights p and q, stage 2 onto the
    /// cylinder centre, then close the gripper (Sec. 8.4.2).
    Grasp {
        /// Lights p and q in front of the cylinder.
        v: [f32; 8],
        /// Cylinder centre in both cameras.
        c: [f32; 4],
        /// Update the tables on the way (life-long learning).
        learn: bool,
    },
}

/// Which camera reading a move asks for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ObserveKind {
    /// The two gripper lights in both cameras (8-D).
    Lights,
    /// The gripper-centre light in both cameras (4-D).
    Centre,
}

/// A camera reading.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Observation {
    /// The two gripper lights in both cameras (8-D).
    Lights([f32; 8]),
    /// The gripper-centre light in both cameras (4-D).
    Centre([f32; 4]),
}

/// The outcome of a task.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Outcome {
    /// Stage-1 result, if stage 1 ran.
    pub stage1: Option<StageOutcome>,
    /// Stage-2 result, if stage 2 ran.
    pub stage2: Option<StageOutcome>,
    /// True at the end of a grasp: close the gripper.
    pub close_gripper: bool,
}

/// What the caller must do next.
// `Done` carries the outcome by value: there is no heap to box it on.
#[allow(clippy::large_enum_variant)]
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Command {
    /// Apply `pressures[..joints]` (the others hold), let the arm settle, then pass the
    /// observation of kind `observe` to [`Controller::observe`].
    Move {
        /// Pressure differences, normalised to [-1, 1].
        pressures: [f32; JOINTS],
        /// Joints commanded: 5 in stage 1, 3 in stage 2.
        joints: u8,
        /// The reading to take after the move.
        observe: ObserveKind,
    },
    /// The task is over.
    Done(Outcome),
}

/// The task in progress. Fieldless, so that `Idle` is the zero byte of a zeroed controller;
/// a grasp's stage-2 target waits in `Controller::grasp_c`.
#[derive(Debug, Clone, Copy, PartialEq)]
#[repr(u8)]
enum Running {
    Idle = 0,
    Stage1 = 1,
    /// Stage 1 of a grasp: stage 2 follows.
    GraspStage1 = 2,
    Stage2 = 3,
}

/// Both networks, the configuration and the task in progress.
///
/// ```
/// use trn_controller::{Command, Config, Controller, Observation, Task};
/// let mut ctrl = Box::new(Controller::new(Config::project_default()));
/// ctrl.init_random(42);
/// let v = [300.0, 200.0, 310.0, 210.0, 320.0, 220.0, 330.0, 230.0];
/// let mut cmd = ctrl.begin(Task::Stage1 { v, supervised: None, learn: true }).unwrap();
/// // a plant that always lands 3 px to the right of the target
/// let outcome = loop {
///     match cmd {
///         Command::Move { .. } => {
///             let mut seen = v;
///             seen[0] += 3.0;
///             cmd = ctrl.observe(Observation::Lights(seen)).unwrap();
///         }
///         Command::Done(outcome) => break outcome,
///     }
/// };
/// assert_eq!(outcome.stage1.unwrap().final_error, 3.0);
/// ```
#[derive(Clone)]
pub struct Controller {
    cfg: Config,
    stage1: Stage1,
    stage2: Stage2,
    /// The ranking's working memory, shared by the stages (they never rank at once).
    scratch: RankScratch,
    running: Running,
    /// The stage-2 target of the grasp in progress.
    grasp_c: [f32; 4],
    /// Stage 1's result while stage 2 of a grasp runs (valid when `stage1_done`). Kept as a
    /// plain value, not an `Option`, so that a zeroed controller is all zero bytes.
    stage1_outcome: StageOutcome,
    stage1_done: bool,
    /// Last pressures commanded to each joint.
    held: [f32; JOINTS],
    /// The fine-move rule of the task in progress (a grasp's stage 2 uses it too).
    fine: FineMoves,
    /// The Broyden servo's stages, run instead of the networks under [`Law::Broyden`]
    /// (nothing without the cargo feature `broyden`).
    broyden: BroydenPair,
}

impl Controller {
    /// A controller with zero tables (a `const fn`: firmware can put it in a `static`).
    /// Call [`Controller::init_random`] or restore a checkpoint before use.
    pub const fn new(cfg: Config) -> Self {
        Controller {
            cfg,
            stage1: Stage::new(cfg.stage1),
            stage2: Stage::new(cfg.stage2),
            scratch: RankScratch::new(),
            running: Running::Idle,
            grasp_c: [0.0; 4],
            stage1_outcome: ZERO_OUTCOME,
            stage1_done: false,
            held: [0.0; JOINTS],
            fine: FineMoves::Policy,
            broyden: BroydenPair::new(cfg.stage1, cfg.stage2, cfg.broyden),
        }
    }

    /// A controller whose every byte is zero, configuration included: firmware declares it
    /// as a `static`, which the linker then places in `.bss` (zeroed at boot, no flash image
    /// of 240 KB), and calls [`Controller::set_config`] and [`Controller::init_random`] at
    /// start-up. `budget.sh` checks the section sizes of the real link.
    pub const fn new_zeroed() -> Self {
        Self::new(Config::zeroed())
    }

    /// Random initial tables for both networks from `seed`.
    pub fn init_random(&mut self, seed: u64) {
        use rand_core::SeedableRng;
        let mut rng = rand_xoshiro::Xoshiro256PlusPlus::seed_from_u64(seed);
        self.stage1.init_random(&mut rng);
        self.stage2.init_random(&mut rng);
        // the Broyden servo starts afresh too: it measures its Jacobian again
        self.broyden.reset();
        self.running = Running::Idle;
    }

    /// The Broyden servo's stage 1 (run under [`Law::Broyden`]).
    #[cfg(feature = "broyden")]
    pub fn broyden1(&self) -> &BroydenStage<8, 5> {
        &self.broyden.stage1
    }

    /// The Broyden servo's stage 2.
    #[cfg(feature = "broyden")]
    pub fn broyden2(&self) -> &BroydenStage<4, 3> {
        &self.broyden.stage2
    }

    /// Whether this build runs `law`: the TRN always, the Broyden servo with the cargo
    /// feature `broyden` (a default). The host-side laws are no [`Law`]s
    /// ([`Law::HOST_CODES`]: [`Law::decode`] answers them as unsupported).
    pub const fn runs(law: Law) -> bool {
        match law {
            Law::Trn => true,
            Law::Broyden => BroydenPair::BUILT,
        }
    }

    /// The configuration.
    pub fn config(&self) -> &Config {
        &self.cfg
    }

    /// Replaces the configuration between tasks (the tables stay).
    pub fn set_config(&mut self, cfg: Config) -> Result<()> {
        if self.busy() {
            return Err(Error::Busy);
        }
        if !Self::runs(cfg.law) {
            return Err(Error::UnsupportedLaw);
        }
        self.stage1.set_config(cfg.stage1)?;
        self.stage2.set_config(cfg.stage2)?;
        self.broyden
            .set_config(cfg.stage1, cfg.stage2, cfg.broyden)?;
        self.cfg = cfg;
        Ok(())
    }

    /// The stage-1 learner.
    pub fn stage1(&self) -> &Stage1 {
        &self.stage1
    }

    /// The stage-2 learner.
    pub fn stage2(&self) -> &Stage2 {
        &self.stage2
    }

    /// Mutable access to the stage-1 learner (rank mode, config).
    pub fn stage1_mut(&mut self) -> &mut Stage1 {
        &mut self.stage1
    }

    /// Mutable access to the stage-2 learner.
    pub fn stage2_mut(&mut self) -> &mut Stage2 {
        &mut self.stage2
    }

    /// True while a task is running.
    pub fn busy(&self) -> bool {
        self.running != Running::Idle
    }

    /// Abandons the running task.
    pub fn abort(&mut self) {
        self.law1().0.abort();
        self.law2().0.abort();
        self.running = Running::Idle;
    }

    /// Starts a task and returns its first command; fine moves by the controller's rule
    /// (tolerance and cap).
    pub fn begin(&mut self, task: Task) -> Result<Command> {
        self.begin_with(task, FineMoves::Policy)
    }

    /// Starts a task whose stages make `fine` fine moves: the controller's rule, or exactly
    /// `n` (the evaluation's fixed move budget).
    pub fn begin_with(&mut self, task: Task, fine: FineMoves) -> Result<Command> {
        if self.busy() {
            return Err(Error::Busy);
        }
        self.stage1_done = false;
        self.fine = fine;
        match task {
            Task::Stage1 {
                v,
                supervised,
                learn,
            } => {
                let p = self.begin1(&v, supervised.as_ref(), learn)?;
                self.running = Running::Stage1;
                Ok(self.move1(p))
            }
            Task::Stage2 { c, learn } => self.begin2(&c, learn),
            Task::Grasp { v, c, learn } => {
                // validate the stage-2 target now, so a bad one fails before the arm moves
                self.law2().0.check_input(&c)?;
                let p = self.begin1(&v, None, learn)?;
                self.grasp_c = c;
                self.running = Running::GraspStage1;
                Ok(self.move1(p))
            }
        }
    }

    /// Stage 1's law under the configured law, and the ranking memory the stages share
    /// (the one place the controller picks a law).
    fn law1(&mut self) -> (&mut dyn StageLaw<8, 5>, &mut RankScratch) {
        match self.cfg.law {
            Law::Broyden => (self.broyden.law1(), &mut self.scratch),
            Law::Trn => (&mut self.stage1, &mut self.scratch),
        }
    }

    /// Stage 2's law, as [`Controller::law1`].
    fn law2(&mut self) -> (&mut dyn StageLaw<4, 3>, &mut RankScratch) {
        match self.cfg.law {
            Law::Broyden => (self.broyden.law2(), &mut self.scratch),
            Law::Trn => (&mut self.stage2, &mut self.scratch),
        }
    }

    /// Stage 1's first move under the configured law (a law that does not train ignores
    /// `supervised` and `learn`).
    fn begin1(
        &mut self,
        v: &[f32; 8],
        supervised: Option<&[f32; 5]>,
        learn: bool,
    ) -> Result<[f32; 5]> {
        let fine = self.fine;
        let held = if self.cfg.stage1.loop_from_drives != 0 {
            exp_start()
        } else {
            self.held
        };
        let (law, scratch) = self.law1();
        law.note_held(&held);
        law.begin(v, supervised, learn, fine, scratch)
    }

    fn begin2(&mut self, c: &[f32; 4], learn: bool) -> Result<Command> {
        let fine = self.fine;
        let from = if self.cfg.stage2.loop_from_drives != 0 {
            exp_start()
        } else {
            self.held
        };
        let held: [f32; 3] = core::array::from_fn(|i| from[i]);
        let (law, scratch) = self.law2();
        law.note_held(&held);
        let p = law.begin(c, None, learn, fine, scratch)?;
        self.running = Running::Stage2;
        Ok(self.move2(p))
    }

    fn move1(&mut self, p: [f32; 5]) -> Command {
        self.held = p;
        Command::Move {
            pressures: p,
            joints: 5,
            observe: ObserveKind::Lights,
        }
    }

    fn move2(&mut self, p: [f32; 3]) -> Command {
        self.held[..3].copy_from_slice(&p);
        Command::Move {
            pressures: self.held,
            joints: 3,
            observe: ObserveKind::Centre,
        }
    }

    /// Consumes the observation that followed the last [`Command::Move`].
    pub fn observe(&mut self, obs: Observation) -> Result<Command> {
        match (self.running, obs) {
            (Running::Idle, _) => Err(Error::UnexpectedObservation),
            (Running::Stage1 | Running::GraspStage1, Observation::Lights(v)) => {
                let then_c = if self.running == Running::GraspStage1 {
                    Some(self.grasp_c)
                } else {
                    None
                };
                let (law, scratch) = self.law1();
                match law.observe(&v, scratch)? {
                    StageStep::Move(p) => Ok(self.move1(p)),
                    StageStep::Done(o) => {
                        self.stage1_outcome = o;
                        self.stage1_done = true;
                        match then_c {
                            None => Ok(self.done(None)),
                            Some(c) => {
                                let learn = o.learned;
                                match self.begin2(&c, learn) {
                                    Ok(cmd) => Ok(cmd),
                                    Err(e) => {
                                        self.running = Running::Idle;
                                        Err(e)
                                    }
                                }
                            }
                        }
                    }
                }
            }
            (Running::Stage2, Observation::Centre(c)) => {
                let (law, scratch) = self.law2();
                match law.observe(&c, scratch)? {
                    StageStep::Move(p) => Ok(self.move2(p)),
                    StageStep::Done(o) => Ok(self.done(Some(o))),
                }
            }
            _ => Err(Error::WrongObservationKind),
        }
    }

    fn done(&mut self, stage2: Option<StageOutcome>) -> Command {
        self.running = Running::Idle;
        let stage1 = if self.stage1_done {
            Some(self.stage1_outcome)
        } else {
            None
        };
        Command::Done(Outcome {
            stage1,
            stage2,
            close_gripper: stage1.is_some() && stage2.is_some(),
        })
    }

    pub(crate) fn parts_mut(&mut self) -> (&mut Stage1, &mut Stage2) {
        (&mut self.stage1, &mut self.stage2)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The Broyden servo runs exactly when it is built (feature `broyden`); without it a
    /// configuration asking for it is refused and changes nothing, and the TRN still runs.
    #[test]
    fn the_broyden_law_is_refused_exactly_when_it_is_left_out() {
        let built = cfg!(feature = "broyden");
        assert_eq!(Controller::runs(Law::Broyden), built);
        assert!(Controller::runs(Law::Trn));
        let mut c = std::boxed::Box::new(Controller::new(Config::project_default()));
        c.init_random(3);
        let broyden = Config {
            law: Law::Broyden,
            ..Config::project_default()
        };
        match c.set_config(broyden) {
            Ok(()) => assert!(built),
            Err(e) => {
                assert!(!built);
                assert_eq!(e, Error::UnsupportedLaw);
                assert_eq!(*c.config(), Config::project_default());
            }
        }
        let v = [300.0, 200.0, 310.0, 210.0, 320.0, 220.0, 330.0, 230.0];
        let task = Task::Stage1 {
            v,
            supervised: None,
            learn: true,
        };
        assert!(matches!(c.begin(task), Ok(Command::Move { .. })));
    }

    /// The static RAM budget is checked on the firmware link (scripts/cross/budget.sh);
    /// this only keeps the controller's own state from growing unnoticed.
    #[test]
    fn controller_state_is_small_beside_the_tables() {
        let size = core::mem::size_of::<Controller>();
        let tables = crate::Stage1Net::TABLE_BYTES + crate::Stage2Net::TABLE_BYTES;
        assert_eq!(
            tables,
            if cfg!(feature = "compact") {
                113_600
            } else {
                227_200
            }
        );
        println!("Controller: {size} bytes, of which tables {tables}");
        assert!(
            size - tables < 16 * 1024,
            "controller state {} bytes beyond the tables",
            size - tables
        );
    }
}
