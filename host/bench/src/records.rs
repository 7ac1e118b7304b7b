//! What the runner saw of each trial: the target, every capture (a move), the controller's
//! reports and errors, the grasp score. The run's log is one list of these records; scoring
//! and the report read them, nothing else keeps parallel lists.

use trn_protocol::TrialReport;

use trn_plant::nodes::Capture;
use trn_plant::targets::Target;
use trn_plant::GraspScore;

/// What kind of trial to run.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TrialKind {
    /// Stage 1; `supervised` sends the target pressure (priming).
    Stage1 {
        /// Priming step.
        supervised: bool,
        /// Update the tables.
        learn: bool,
    },
    /// Stage 2.
    Stage2 {
        /// Update the tables.
        learn: bool,
    },
    /// A full grasp of a random cylinder.
    Grasp {
        /// Update the tables on the way.
        learn: bool,
    },
}

impl TrialKind {
    /// True for a grasp.
    pub fn is_grasp(self) -> bool {
        matches!(self, TrialKind::Grasp { .. })
    }

    /// True when the trial runs stage 1.
    pub fn runs_stage1(self) -> bool {
        matches!(self, TrialKind::Stage1 { .. } | TrialKind::Grasp { .. })
    }

    /// True when the trial runs stage 2.
    pub fn runs_stage2(self) -> bool {
        matches!(self, TrialKind::Stage2 { .. } | TrialKind::Grasp { .. })
    }
}

/// Which part of a run a trial belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Phase {
    /// Training (learning on, the paper's visit-then-return targets).
    Training,
    /// A frozen snapshot after this many training trials per network: the held-out
    /// targets with the fixed move budget, no learning.
    Snapshot(usize),
    /// The held-out grasps of the snapshot after this many training trials (stop rule).
    SnapshotGrasp(usize),
    /// The final held-out evaluation with the fixed move budget (deployment-style targets).
    Deployment,
    /// The final held-out evaluation with the controller's own stop rule (the same
    /// deployment-style targets): what a user sees in operation.
    Evaluation,
    /// The paper's protocol as a secondary evaluation: visit-then-return targets, the
    /// controller's stop rule.
    VisitAndReturn,
    /// Full grasps of deployment-style cylinders, the controller's stop rule.
    Grasping,
}

impl Phase {
    /// True for every phase without learning.
    pub fn is_evaluation(self) -> bool {
        self != Phase::Training
    }
}

/// One trial as the runner saw it.
#[derive(Debug, Clone, PartialEq)]
pub struct TrialRecord {
    /// Trial number on the bus.
    pub trial: u32,
    /// What was asked.
    pub kind: TrialKind,
    /// The part of the run.
    pub phase: Phase,
    /// The fine moves asked for (`FINE_MOVES_POLICY`: the controller's rule).
    pub fine_moves: u8,
    /// The target (`Target::NONE` when it could not be seen).
    pub target: Target,
    /// False when the target could not be realised (a light out of view from the twin):
    /// nothing was sent.
    pub target_seen: bool,
    /// Every capture served during the trial, in order: each is one move.
    pub captures: Vec<Capture>,
    /// The controller's reports (one per stage run).
    pub reports: Vec<TrialReport>,
    /// `ErrorReport`s received during the trial (code, detail).
    pub errors: Vec<(u16, u32)>,
    /// The controller aborted the trial (its reason is in `errors`).
    pub aborted: bool,
    /// No answer came to the trial's start after every repeat: given up.
    pub gave_up: bool,
    /// Grasp score at the gripper's close.
    pub grasp: Option<GraspScore>,
    /// The plant's simulated time when the trial's start was sent (s), after the set-up.
    pub started_s: f64,
}

impl TrialRecord {
    /// The report of stage `stage` (1 also finds a priming report, stage 0).
    pub fn report(&self, stage: u8) -> Option<&TrialReport> {
        self.reports.iter().find(|r| match stage {
            1 => r.stage <= 1,
            s => r.stage == s,
        })
    }

    /// Simulated time from the trial's start to its last capture (s): every pressure ramp,
    /// settle and capture of every move the controller made, including any extra command
    /// a method adds (0 without a capture).
    pub fn sim_time_s(&self) -> f64 {
        self.captures
            .last()
            .map_or(0.0, |c| (c.time_s - self.started_s).max(0.0))
    }

    /// True when any stage ended at the cap on fine moves.
    pub fn cap_hits(&self) -> usize {
        self.reports.iter().filter(|r| r.cap_hit).count()
    }
}

/// The log of a run: every trial's record, in order.
#[derive(Debug, Clone, Default)]
pub struct RunLog {
    /// The records.
    pub trials: Vec<TrialRecord>,
    /// The simulator's state at the end of training (for a simulator checkpoint).
    pub end_of_training: Option<Box<super::sim_state::SimState>>,
    /// The run stopped early at an interrupt; the records are what it did.
    pub interrupted: bool,
}

impl RunLog {
    /// The records of one phase, in order.
    pub fn phase(&self, phase: Phase) -> impl Iterator<Item = &TrialRecord> {
        self.trials.iter().filter(move |r| r.phase == phase)
    }

    /// Stage-1 and stage-2 trials of one phase, paired in the order they ran (the training
    /// and evaluation loops alternate them).
    pub fn pairs(&self, phase: Phase) -> Vec<(&TrialRecord, &TrialRecord)> {
        let ones = self
            .phase(phase)
            .filter(|r| matches!(r.kind, TrialKind::Stage1 { .. }));
        let twos = self
            .phase(phase)
            .filter(|r| matches!(r.kind, TrialKind::Stage2 { .. }));
        ones.zip(twos).collect()
    }
}
