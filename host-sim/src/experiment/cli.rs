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
    /// The conformance suite (protocol/SPEC.md): drives the controller on the bus (the
    /// project's node, or with --external-controller whatever controller is on the bus)
    /// through every trial sequence and checks its answers; fails if any check fails.
    Conformance(ConformanceArgs),
    /// The project preset on a built-in list of plant variants (hysteresis width, camera
    /// noise, coupling, creep, process noise, a skewed loop, outliers, damping), each
    /// changed alone from the base configuration, seeds from 100: how the result degrades.
    Sweep(SweepArgs),
    /// Life-long learning under temperature drift and wear: thousands of trials with frozen
    /// snapshot evaluations (held-out targets and grasps), for the network frozen after its
    /// initial training, the project preset, the lifelong preset and the Broyden servo.
    Lifelong(LifelongArgs),
}

/// `trn lifelong`.
#[derive(Debug, Args, Clone)]
pub struct LifelongArgs {
    /// Seed of the runs (seeds 1-99 are for tuning).
    #[arg(long, default_value_t = 100)]
    pub seed: u64,
    /// Trials per network, in all.
    #[arg(long, default_value_t = 5000, value_parser = clap::value_parser!(u64).range(1..=1_000_000))]
    pub trials: u64,
    /// Training trials before the frozen network stops learning.
    #[arg(long, default_value_t = 300)]
    pub initial: usize,
    /// A snapshot evaluation every this many trials.
    #[arg(long, default_value_t = 250, value_parser = clap::value_parser!(u64).range(1..=1_000_000))]
    pub snapshot_every: u64,
    /// Held-out targets per network in each snapshot.
    #[arg(long, default_value_t = 50)]
    pub snapshot_targets: usize,
    /// Held-out grasps in each snapshot.
    #[arg(long, default_value_t = 40)]
    pub snapshot_grasps: usize,
    /// Simulator configuration: `aging` (the default: the ideal plant with temperature
    /// drift and bounded wear), another built-in one by name, or a TOML file.
    #[arg(long, default_value = "aging")]
    pub config: PathBuf,
    /// Only these controllers (comma-separated: frozen, project, lifelong, broyden).
    #[arg(long, value_delimiter = ',', default_values_t = vec!["frozen".to_string(), "project".into(), "lifelong".into(), "broyden".into()])]
    pub only: Vec<String>,
    /// Where lifelong.json (and, with the plot feature, lifelong.png) go.
    #[arg(long, default_value = "out/lifelong")]
    pub out: PathBuf,
}

/// `trn sweep`.
#[derive(Debug, Args, Clone)]
pub struct SweepArgs {
    /// Seeds to run: 100 .. 100 + N.
    #[arg(long, default_value_t = 3, value_parser = clap::value_parser!(u64).range(1..=1000))]
    pub seeds: u64,
    /// Training trials per network.
    #[arg(long, default_value_t = 300)]
    pub trials: usize,
    /// The base configuration the variants change: a TOML file, `ideal` (the default) or
    /// `realistic` (the last two rows are the realistic plant whatever the base).
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Where the variants' configurations and sweep.json go.
    #[arg(long, default_value = "out/sweep")]
    pub out: PathBuf,
}

/// `trn conformance`.
#[derive(Debug, Args, Clone)]
pub struct ConformanceArgs {
    /// Shared options (the bus, the preset and seed sent in the `SessionConfig`).
    #[command(flatten)]
    pub common: Common,
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

/// The control law (`--controller`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Controller {
    /// The topology representing network (the chapter's method).
    Trn,
    /// Uncalibrated visual servoing with a Broyden Jacobian (no training): the classical
    /// alternative, for comparison.
    Broyden,
    /// The simulator's nominal inverse kinematics: a perfectly calibrated model-based
    /// controller without hysteresis compensation (a reference; in process only).
    Model,
}

impl From<Controller> for trn_controller::Law {
    fn from(c: Controller) -> Self {
        match c {
            Controller::Trn => Self::Trn,
            Controller::Broyden => Self::Broyden,
            Controller::Model => Self::Model,
        }
    }
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
    /// No secant correction of the averaged Jacobian within a trial (mature operation).
    NoTrialSecant,
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
            Ablation::NoTrialSecant => Self::NoTrialSecant,
        }
    }
}

/// A duration in seconds: finite, positive, at most an hour.
fn seconds(s: &str) -> Result<f64, String> {
    let x: f64 = s.parse().map_err(|e| format!("{e}"))?;
    if x.is_finite() && x > 0.0 && x <= 3600.0 {
        Ok(x)
    } else {
        Err(format!("{s} is not a duration in (0, 3600] seconds"))
    }
}

/// Options shared by every subcommand.
#[derive(Debug, Args, Clone)]
pub struct Common {
    /// Seed of the run (plant, targets, initial tables). Seeds 1-99 are for tuning; the
    /// README reports seeds from 100 up.
    #[arg(long, default_value_t = 100)]
    pub seed: u64,
    /// Simulator configuration: a TOML file, or a built-in one by name (`realistic`, the
    /// default: coupling, process noise, skewed loops, creep, camera outliers and
    /// dropouts, occlusion by hand and cylinder, lens distortion; `ideal`: none of it;
    /// `aging`: the ideal plant with temperature drift and bounded wear).
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Bus: `inproc` (the controller node in a thread, the default), `socketcan:IFACE` (a
    /// separate `controller-node` process on IFACE: vcan0 or a real adapter), `slcan:qemu`
    /// (the firmware in QEMU, CAN frames as SLCAN over its UART; build it first with
    /// `bash scripts/cross/pil.sh --build-only`; it takes seed, preset, ablation and CAN mode
    /// from the session's `SessionConfig`) or `slcan:/dev/DEVICE` (a USB-CAN adapter that
    /// speaks serial SLCAN, e.g. /dev/ttyACM0, with a controller elsewhere on the bus:
    /// `--external-controller`).
    #[arg(long, default_value = "inproc")]
    pub bus: String,
    /// The controller runs elsewhere on the bus (a board on `socketcan:IFACE` or behind a
    /// USB-CAN adapter at `slcan:/dev/DEVICE`): start none; it keeps its own tables.
    #[arg(long)]
    pub external_controller: bool,
    /// Use CAN FD framing (one frame per message) instead of CAN 2.0 segmentation.
    #[arg(long)]
    pub fd: bool,
    /// Controller preset.
    #[arg(long, value_enum, default_value_t = Preset::Project)]
    pub preset: Preset,
    /// Ablation.
    #[arg(long, value_enum, default_value_t = Ablation::None)]
    pub ablation: Ablation,
    /// The control law: the TRN, or the Broyden servo baseline (which does not train).
    #[arg(long, value_enum, default_value_t = Controller::Trn)]
    pub controller: Controller,
    /// Held-out targets per network in the evaluation.
    #[arg(long, default_value_t = 100)]
    pub eval_targets: usize,
    /// Grasps in the evaluation.
    #[arg(long, default_value_t = 50)]
    pub grasps: usize,
    /// Fine moves after the coarse move in the held-out evaluation with the fixed move
    /// budget (never stopping early; at most 31).
    #[arg(long, default_value_t = 6, value_parser = clap::value_parser!(u8).range(0..=31))]
    pub fine_moves: u8,
    /// A frozen snapshot evaluation (held-out targets, fixed budget, no learning) every this
    /// many training trials (0: none).
    #[arg(long, default_value_t = 25)]
    pub snapshot_every: usize,
    /// Held-out targets per network in each snapshot (the first of the held-out set).
    #[arg(long, default_value_t = 50)]
    pub snapshot_targets: usize,
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
    /// Seconds without a frame from the controller before the run fails (0 < s <= 3600).
    #[arg(long, default_value_t = 10.0, value_parser = seconds)]
    pub bus_timeout_s: f64,
    /// Use a checkpoint learned under another preset, ablation or configuration.
    #[arg(long)]
    pub allow_config_change: bool,
    /// Faults on the in-process bus, each independent per frame and receiver, seeded by the
    /// run's seed: `drop=P,dup=P,reorder=P,corrupt=P,truncate=P` (any subset, P in [0, 1]).
    #[arg(long)]
    pub faults: Option<trn_protocol::bus::FaultConfig>,
}

impl Common {
    /// Options for a programmatic run: in-process bus, no outputs, no progress bar.
    pub fn inproc(seed: u64, preset: Preset, ablation: Ablation) -> Common {
        Common {
            seed,
            config: None,
            bus: "inproc".into(),
            external_controller: false,
            fd: false,
            preset,
            ablation,
            controller: Controller::Trn,
            eval_targets: 100,
            grasps: 50,
            fine_moves: 6,
            snapshot_every: 25,
            snapshot_targets: 50,
            report: None,
            plot: None,
            candump: None,
            quiet: true,
            bus_timeout_s: 10.0,
            allow_config_change: false,
            faults: None,
        }
    }
}

impl Common {
    /// The plan of a run with `trials` training trials per network.
    pub fn plan(&self, trials: usize) -> crate::experiment::schedule::Plan {
        crate::experiment::schedule::Plan {
            trials,
            eval_targets: self.eval_targets,
            grasps: self.grasps,
            fine_moves: self.fine_moves,
            snapshot_every: self.snapshot_every,
            snapshot_targets: self.snapshot_targets,
            snapshot_grasps: 0,
            learn_trials: None,
            first_trial: 0,
            resume: false,
        }
    }
}

/// `trn train`.
#[derive(Debug, Args, Clone)]
pub struct TrainArgs {
    /// Shared options.
    #[command(flatten)]
    pub common: Common,
    /// Training trials per network (at least 1: `trn eval` evaluates without training).
    #[arg(long, default_value_t = 300, value_parser = clap::value_parser!(u64).range(1..=1_000_000))]
    pub trials: u64,
    /// Continue from this checkpoint (life-long learning).
    #[arg(long)]
    pub checkpoint_in: Option<PathBuf>,
    /// Save the trained networks here (written atomically), and the simulator's state at
    /// the end of training beside it (`CHECKPOINT.sim`, for `--continue`).
    #[arg(long)]
    pub checkpoint_out: Option<PathBuf>,
    /// Continue the run that wrote `--checkpoint-in` where it stopped: its plant (drift,
    /// wear, hysteresis), training targets and held-out sets from `CHECKPOINT.sim`, its
    /// schedule from the trial it reached. Without it a checkpoint continues its schedule
    /// (the learning steps it holds) on a new plant.
    #[arg(long = "continue", requires = "checkpoint_in")]
    pub resume: bool,
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
    /// Seeds to run: 100 .. 100 + N (tuning uses seeds 1-99 only).
    #[arg(long, default_value_t = 10, value_parser = clap::value_parser!(u64).range(1..=1000))]
    pub seeds: u64,
    /// Training trials per network.
    #[arg(long, default_value_t = 300)]
    pub trials: usize,
    /// Only the project preset (the test suite's band check).
    #[arg(long)]
    pub project_only: bool,
    /// Simulator configuration: a TOML file, or a built-in one by name (`realistic`, the
    /// default: coupling, process noise, skewed loops, creep, camera outliers and
    /// dropouts, occlusion by hand and cylinder, lens distortion; `ideal`: none of it;
    /// `aging`: the ideal plant with temperature drift and bounded wear).
    #[arg(long)]
    pub config: Option<PathBuf>,
    /// Write every seed's figures as JSON here.
    #[arg(long)]
    pub report: Option<PathBuf>,
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::CommandFactory;

    /// `trn train --help` names every bus form `BusSpec::parse` accepts.
    #[test]
    fn train_help_lists_every_bus_form() {
        let mut cli = Cli::command();
        let help = cli
            .find_subcommand_mut("train")
            .unwrap()
            .render_long_help()
            .to_string();
        for form in [
            "inproc",
            "socketcan:IFACE",
            "slcan:qemu",
            "slcan:/dev/DEVICE",
        ] {
            assert!(help.contains(form), "{form} missing from trn train --help");
        }
    }
}
