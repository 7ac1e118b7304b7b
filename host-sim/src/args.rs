//! The command line's options as the lab's specifications: built once here, checked by the
//! lab ([`RunSpec::check`]) before anything runs.

use trn_lab::compare::CompareSpec;
use trn_lab::lifelong::LifelongSpec;
use trn_lab::schedule::Plan;
use trn_lab::sweep::SweepSpec;
use trn_lab::{BusChoice, Command, LabError, Outputs, Profile, RunSpec};
use trn_transport::BusSpec;

use crate::cli::{Common, CompareArgs, EvalArgs, LifelongArgs, SweepArgs, TrainArgs};

/// Training trials per network when `--trials` is not given.
pub const DEFAULT_TRIALS: usize = 300;

/// A count from the command line (already range-checked by clap) as a `usize`.
fn count(n: u64) -> usize {
    usize::try_from(n).unwrap_or(usize::MAX)
}

impl Common {
    /// The run these options describe.
    pub fn spec(&self, command: Command, trials: usize) -> Result<RunSpec, LabError> {
        let mut spec = RunSpec::new(command, self.seed).with_plant(self.config.as_deref())?;
        spec.profile = Profile {
            preset: self.preset,
            ablation: self.ablation,
            law: self.law,
        };
        spec.bus = BusChoice {
            spec: BusSpec::parse(&self.bus)?,
            external_controller: self.external_controller,
            fd: self.fd,
            faults: self.faults,
            timeout_s: self.bus_timeout_s,
            bitrate: self.bitrate,
        };
        spec.plan = Plan {
            trials,
            eval_targets: count(self.eval_targets),
            grasps: count(self.grasps),
            fine_moves: self.fine_moves,
            snapshot_every: count(self.snapshot_every),
            snapshot_targets: count(self.snapshot_targets),
            ..Plan::new(0, 0, 0)
        };
        spec.allow_config_change = self.allow_config_change;
        spec.reset_tables = self.reset_tables;
        spec.tables = self.tables.clone();
        spec.outputs = Outputs {
            report: self.report.clone(),
            plot: self.plot.clone(),
            candump: self.candump.clone(),
            ..Outputs::default()
        };
        Ok(spec)
    }
}

impl TrainArgs {
    /// The run of `trn train`.
    pub fn spec(&self) -> Result<RunSpec, LabError> {
        let trials = self.trials.map_or(DEFAULT_TRIALS, count);
        let mut spec = self.common.spec(Command::Train, trials)?;
        spec.plan.resume = self.resume;
        spec.trials_left = self.resume && self.trials.is_none();
        spec.checkpoint_in = self.checkpoint_in.clone();
        spec.keep_tables = self.keep_tables;
        spec.outputs.checkpoint = self.checkpoint_out.clone();
        spec.outputs.checkpoint_every = count(self.checkpoint_every);
        Ok(spec)
    }
}

impl EvalArgs {
    /// The run of `trn eval` (held-out targets) or `trn grasp` (grasps only).
    pub fn spec(&self, command: Command) -> Result<RunSpec, LabError> {
        let mut spec = self.common.spec(command, 0)?;
        match command {
            Command::Grasp => spec.plan.eval_targets = 0,
            _ => spec.plan.grasps = 0,
        }
        spec.checkpoint_in = self.checkpoint_in.clone();
        spec.outputs.checkpoint = self.checkpoint_out.clone();
        Ok(spec)
    }
}

impl CompareArgs {
    /// The study of `trn compare`.
    pub fn spec(&self) -> CompareSpec {
        CompareSpec {
            seeds: self.seeds,
            trials: count(self.trials),
            project_only: self.project_only,
            config: self.config.clone(),
            report: self.report.clone(),
        }
    }
}

impl SweepArgs {
    /// The study of `trn sweep`.
    pub fn spec(&self) -> SweepSpec {
        SweepSpec {
            seeds: self.seeds,
            trials: count(self.trials),
            config: self.config.clone(),
            out: self.out.clone(),
        }
    }
}

impl LifelongArgs {
    /// The study of `trn lifelong`.
    pub fn spec(&self) -> LifelongSpec {
        LifelongSpec {
            seed: self.seed,
            trials: count(self.trials),
            initial: count(self.initial),
            snapshot_every: count(self.snapshot_every),
            snapshot_targets: count(self.snapshot_targets),
            snapshot_grasps: count(self.snapshot_grasps),
            config: self.config.clone(),
            only: self.only.clone(),
            out: self.out.clone(),
        }
    }
}
