//! Command-line options of `trn` (clap).

use clap::{Args, Parser, Subcommand, ValueEnum};
use std::path::PathBuf;

/// Train and evaluate the TRN controller of a hysteretic soft arm on the simulated plant.
#[derive(Debug, Parser)]
#[command(name = "trn", version, about)]
pub struct Cli {
    /// What to do.
    #[command(subcommand)]
    pub command: Cmd,
}

/// The subcommands.
#[derive(Debug, Subcommand)]
pub enum Cmd {
    /// Train both networks (stage 1: supervised priming, then unsupervised; stage 2:
    /// unsupervised), then evaluate on held-out targets and grasps.
    Train(TrainArgs),
    /// Evaluate a checkpoint on held-out targets (no learning).
    Eval(EvalArgs),
    /// Full two-stage grasps of random cylinders from a checkpoint.
    Grasp(EvalArgs),
    /// Run the paper/project presets and the ablations over several seeds (README table).
    Compare(CompareArgs),
}

/// Controller presets.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Preset {
    /// The project's defaults.
    Project,
    /// The chapter's printed constants (errata fixed).
    Paper,
    /// The project's defaults with a floor on the rates (life-long learning).
    Lifelong,
}

/// Ablations of the method.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Ablation {
    /// None: the full method.
    None,
    /// No neighbourhood: only the closest neuron learns and answers (a plain VQ look-up table).
    NoNeighbourhood,
    /// No supervised priming.
    NoPriming,
    /// No fine moves (coarse move only).
    NoFine,
}

impl Preset {
    /// Its name on the command line.
    pub fn name(self) -> &'static str {
        trn_controller::presets::Preset::from(self).name()
    }
}

impl From<Preset> for trn_controller::presets::Preset {
    fn from(p: Preset) -> Self {
        match p {
            Preset::Project => Self::Project,
            Preset::Paper => Self::Paper,
            Preset::Lifelong => Self::Lifelong,
        }
    }
}

impl Ablation {
    /// Its name on the command line.
    pub fn name(self) -> &'static str {
        trn_controller::presets::Ablation::from(self).name()
    }
}

impl From<Ablation> for trn_controller::presets::Ablation {
    fn from(a: Ablation) -> Self {
        match a {
            Ablation::None => Self::None,
            Ablation::NoNeighbourhood => Self::NoNeighbourhood,
            Ablation::NoPriming => Self::NoPriming,
            Ablation::NoFine => Self::NoFine,
        }
    }
}

/// Options shared by every subcommand.
#[derive(Debug, Args, Clone)]
pub struct Common {
    /// Seed of the run (plant, targets, initial tables).
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Simulator configuration (TOML); the built-in defaults when absent.
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Bus: `inproc` (controller node in a thread) or `socketcan:IFACE` (a separate
    /// `controller-node` process on IFACE).
    #[arg(long, default_value = "inproc")]
    pub bus: String,
    /// Use CAN FD framing (one frame per message) instead of CAN 2.0 segmentation.
    #[arg(long)]
    pub fd: bool,
    /// Controller preset.
    #[arg(long, value_enum, default_value_t = Preset::Project)]
    pub preset: Preset,
    /// Ablation.
    #[arg(long, value_enum, default_value_t = Ablation::None)]
    pub ablation: Ablation,
    /// Held-out targets per network in the evaluation.
    #[arg(long, default_value_t = 100)]
    pub eval_targets: usize,
    /// Grasps in the evaluation.
    #[arg(long, default_value_t = 50)]
    pub grasps: usize,
    /// Write the JSON report here.
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// Write learning curves here (.png or .svg).
    #[arg(long)]
    pub plot: Option<PathBuf>,
    /// Record the bus traffic as a candump log here.
    #[arg(long)]
    pub candump: Option<PathBuf>,
    /// No progress bar.
    #[arg(long)]
    pub quiet: bool,
    /// Seconds without a frame from the controller before the run fails.
    #[arg(long, default_value_t = 10.0)]
    pub bus_timeout_s: f64,
}

impl Common {
    /// Options for a programmatic run: in-process bus, no outputs, no progress bar.
    pub fn inproc(seed: u64, preset: Preset, ablation: Ablation) -> Common {
        Common {
            seed,
            config: None,
            bus: "inproc".into(),
            fd: false,
            preset,
            ablation,
            eval_targets: 100,
            grasps: 50,
            report: None,
            plot: None,
            candump: None,
            quiet: true,
            bus_timeout_s: 10.0,
        }
    }
}

/// `trn train`.
#[derive(Debug, Args, Clone)]
pub struct TrainArgs {
    /// Shared options.
    #[command(flatten)]
    pub common: Common,
    /// Training trials per network.
    #[arg(long, default_value_t = 300)]
    pub trials: usize,
    /// Continue from this checkpoint (life-long learning).
    #[arg(long)]
    pub checkpoint_in: Option<PathBuf>,
    /// Save the trained networks here (written atomically).
    #[arg(long)]
    pub checkpoint_out: Option<PathBuf>,
}

/// `trn eval` and `trn grasp`.
#[derive(Debug, Args, Clone)]
pub struct EvalArgs {
    /// Shared options.
    #[command(flatten)]
    pub common: Common,
    /// The trained networks.
    #[arg(long)]
    pub checkpoint_in: PathBuf,
}

/// `trn compare`.
#[derive(Debug, Args, Clone)]
pub struct CompareArgs {
    /// Seeds to run (1..=N).
    #[arg(long, default_value_t = 5)]
    pub seeds: u64,
    /// Training trials per network.
    #[arg(long, default_value_t = 300)]
    pub trials: usize,
    /// Write the comparison as JSON here.
    #[arg(long)]
    pub report: Option<PathBuf>,
}
