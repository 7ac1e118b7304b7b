//! The command line's options as the lab's specifications: built once here, checked by the
//! lab ([`RunSpec::check`]) before anything runs.

use trn_bench::schedule::Plan;
use trn_bench::{BusChoice, Command, LabError, Outputs, Profile, RunSpec};
use trn_studies::compare::CompareSpec;
use trn_studies::lifelong::LifelongSpec;
use trn_studies::sweep::SweepSpec;
use trn_transport::BusSpec;

use trn_studies::study::file::{Overrides, StudyFile};
use trn_studies::study::{self, Study};

use crate::cli::{
    Common, CompareArgs, EvalArgs, LifelongArgs, StudyArgs, StudyOpts, StudyOverrides, SweepArgs,
    TrainArgs,
};

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
        if let Some(v) = self.vision {
            spec.plant.vision = v.into();
        }
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
        let eval_targets = count(self.eval_targets);
        let snapshot_targets = match self.snapshot_targets.map(count) {
            Some(n) if n > eval_targets => {
                return Err(LabError::Usage(format!(
                    "--snapshot-targets {n} is more than --eval-targets {eval_targets}: a snapshot evaluates the first of the held-out targets"
                )))
            }
            Some(n) => n,
            // the default, 50, takes every held-out target when there are fewer
            None => Plan::new(0, 0, 0).snapshot_targets,
        };
        spec.plan = Plan {
            trials,
            eval_targets,
            grasps: count(self.grasps),
            fine_moves: self.fine_moves,
            snapshot_every: count(self.snapshot_every),
            snapshot_targets,
            ..Plan::new(0, 0, 0)
        };
        spec.allow_config_change = self.allow_config_change;
        spec.reset_tables = self.reset_tables;
        spec.tables = self.tables.clone();
        spec.outputs = Outputs {
            report: self.report.clone(),
            plot: self.plot.clone(),
            candump: self.candump.clone(),
            csv: self.csv.clone(),
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

impl StudyOverrides {
    /// The overrides of a study file, with the base plant `plant`.
    pub fn overrides(&self, plant: Option<&str>) -> Overrides {
        Overrides {
            configs: self.configs.clone(),
            seeds: self.seeds,
            first_seed: self.first_seed,
            plant: plant.map(str::to_string),
            trials: self.trials.map(count),
            eval_targets: self.eval_targets.map(count),
            grasps: self.grasps.map(count),
            vision: self.vision.map(Into::into),
        }
    }
}

impl StudyOpts {
    /// How the study runs; its run folder `OUT/runs` unless `--runs` names one.
    pub fn options(&self, out: &std::path::Path) -> study::Options {
        study::Options {
            jobs: self.jobs.map_or_else(cores, count),
            runs: self.runs.clone().unwrap_or_else(|| out.join("runs")),
            resume: self.resume,
            shard: self.shard,
        }
    }
}

/// The cores of this machine (1 when unknown).
pub fn cores() -> usize {
    std::thread::available_parallelism().map_or(1, |n| n.get())
}

impl CompareArgs {
    /// The study of `trn compare`.
    pub fn spec(&self) -> CompareSpec {
        let mut over = self.over.overrides(self.config.as_deref());
        if self.project_only {
            over.configs = vec!["project".into()];
        }
        CompareSpec {
            study: self.study.clone(),
            over,
            out: self.out.clone(),
        }
    }
}

impl SweepArgs {
    /// The study of `trn sweep`.
    pub fn spec(&self) -> SweepSpec {
        SweepSpec {
            study: self.study.clone(),
            over: self.over.overrides(self.config.as_deref()),
            out: self.out.clone(),
        }
    }
}

impl StudyArgs {
    /// The study of `trn study FILE`, where its outputs go (`out`) and its JSON; `stop` is
    /// asked while it is built ([`StudyFile::study_unless`]).
    pub fn study(
        &self,
        stop: &dyn Fn() -> bool,
    ) -> Result<(Study, std::path::PathBuf, std::path::PathBuf), LabError> {
        let file = StudyFile::read(&self.file)?;
        let out = self
            .out
            .clone()
            .unwrap_or_else(|| std::path::Path::new("out").join(study::slug(&file.name)));
        let dir = match self.file.parent() {
            Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
            _ => ".".into(),
        };
        let s = file.study_unless(
            &dir,
            &self.over.overrides(self.config.as_deref()),
            Some(&out),
            stop,
        )?;
        let json = match &self.report {
            Some(p) => p.clone(),
            None => {
                // the study's own folder holds its JSON: made here, as the run folder is
                trn_bench::fsio::create_folder(&out)?;
                out.join(format!("{}.json", study::slug(&file.name)))
            }
        };
        Ok((s, out, json))
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
