//! Command-line options of `trn` (clap): what each subcommand takes. [`crate::args`] turns
//! them into the lab's specifications.

use clap::{Args, Parser, Subcommand};
use std::path::PathBuf;
use trn_bench::spec::ControllerChoice;
use trn_controller::presets::{Ablation, Preset};

/// `trn`: train, evaluate and compare the TRN controller of a hysteretic soft arm (and its
/// baselines) on the simulated SoftArm, or check any controller on a CAN bus against the
/// protocol. The controller runs as a CAN node: in this process on a simulated clock, as a
/// `controller-node` process on SocketCAN, as firmware in QEMU, or on a board.
#[derive(Debug, Parser)]
#[command(name = "trn", version)]
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
    /// Run the paper/project presets, the ablations and the baselines over several seeds
    /// (the README's table; the rows of studies/compare.toml, built in).
    Compare(CompareArgs),
    /// The conformance suite (protocol/SPEC.md): drives the controller on the bus (the
    /// project's node, or with --external-controller whatever controller is on the bus)
    /// through every trial sequence and checks its answers; fails if any check fails.
    Conformance(ConformanceArgs),
    /// The project preset on the plant variants of studies/sweep.toml (built in: hysteresis
    /// width, camera noise, coupling, creep, process noise, a skewed loop, outliers,
    /// damping), each changed alone from the base configuration, seeds from 100: how the
    /// result degrades.
    Sweep(SweepArgs),
    /// Life-long learning under temperature drift and wear: thousands of trials with frozen
    /// snapshot evaluations (held-out targets and grasps), for the network frozen after its
    /// initial training, the project preset, the lifelong preset and the Broyden servo.
    Lifelong(LifelongArgs),
    /// Any study file (rows, grid axes over sim.toml keys, presets, ablations, laws, seeds,
    /// the evaluation's size; see studies/compare.toml): its runs in parallel, its table
    /// and JSON.
    Study(StudyArgs),
    /// The table and JSON of a study from its run files (of every shard: `--shard I/N`),
    /// as the unsharded command makes them.
    Merge(MergeArgs),
    /// Decode a candump log (from `--candump`, candump -l, a capture): every frame as the
    /// message it carries, the segments of segmented messages included, then a line
    /// `N frames, M messages, K undecoded`.
    Decode(DecodeArgs),
    /// The arm's robot description from a simulator configuration on standard output: URDF
    /// (metres, radians; the gripper centre and the LEDs p and q as fixed frames), or
    /// MuJoCo's MJCF with `--mjcf` (with the two cameras). The differential wrist's joints A
    /// and B appear as the gripper's own axes, wrist_pitch = (A + B) / 2 and
    /// wrist_roll = (A - B) / 2.
    Model(ModelArgs),
}

/// Options of every command that runs a study of many runs.
#[derive(Debug, Args, Clone)]
pub struct StudyOpts {
    /// Runs at once (default: the number of cores). Each run is single-threaded; the
    /// results are the same for any number.
    #[arg(long, value_parser = clap::value_parser!(u64).range(1..=4096))]
    pub jobs: Option<u64>,
    /// Skip the runs whose file is already in the run folder with the same run
    /// specification (a file cut short, or of another specification, is run again).
    #[arg(long)]
    pub resume: bool,
    /// Run only shard I of N (0 <= I < N: the runs whose index is I modulo N) and write
    /// their files; `trn merge` makes the table of every shard's files.
    #[arg(long, value_parser = shard)]
    pub shard: Option<trn_studies::study::Shard>,
    /// The run folder: one JSON file per finished run (default: OUT/runs).
    #[arg(long)]
    pub runs: Option<PathBuf>,
    /// No progress (neither the bar nor a line per run).
    #[arg(long)]
    pub quiet: bool,
}

fn shard(s: &str) -> Result<trn_studies::study::Shard, String> {
    s.parse()
}

/// What a study file's command line may change.
#[derive(Debug, Args, Clone)]
pub struct StudyOverrides {
    /// Only these rows (comma-separated keys of the study's rows).
    #[arg(long, value_delimiter = ',')]
    pub configs: Vec<String>,
    /// Seeds to run: the study's first seed and N from it (default: the study's).
    #[arg(long, value_parser = clap::value_parser!(u64).range(1..=1_000_000))]
    pub seeds: Option<u64>,
    /// The first seed instead of the study's: rows tuned on its seeds reported on others,
    /// e.g. `--first-seed 100 --seeds 10` (the count: `--seeds`, else the study's).
    #[arg(long)]
    pub first_seed: Option<u64>,
    /// Training trials per network (default: the study's; rows that set their own, such
    /// as the baselines' 0, keep theirs).
    #[arg(long, value_parser = clap::value_parser!(u64).range(1..=1_000_000))]
    pub trials: Option<u64>,
    /// Held-out targets per network in the evaluation (default: the study's).
    #[arg(long, value_parser = clap::value_parser!(u64).range(0..=trn_bench::spec::MAX_COUNT as u64))]
    pub eval_targets: Option<u64>,
    /// Grasps in the evaluation (default: the study's).
    #[arg(long, value_parser = clap::value_parser!(u64).range(0..=trn_bench::spec::MAX_COUNT as u64))]
    pub grasps: Option<u64>,
    /// How the camera processor reads the lights: `geometric` (the default: each light's
    /// projection plus noise, outliers and dropouts by rule; fast) or `pixels` (every
    /// capture rendered frame by frame and read by the camera processor on pixels; the
    /// plant key `vision`). Recorded with the plant in the report.
    #[arg(long, value_enum)]
    pub vision: Option<VisionArg>,
}

/// The camera processor of `--vision`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum VisionArg {
    /// Projection plus noise of a chosen size (`pixel_noise_px`).
    Geometric,
    /// Rendered frames read by the camera processor on pixels (`[pixels]`).
    Pixels,
}

impl From<VisionArg> for trn_plant::Vision {
    fn from(v: VisionArg) -> trn_plant::Vision {
        match v {
            VisionArg::Geometric => trn_plant::Vision::Geometric,
            VisionArg::Pixels => trn_plant::Vision::Pixels,
        }
    }
}

/// `trn study`.
#[derive(Debug, Args, Clone)]
pub struct StudyArgs {
    /// The study file (TOML).
    pub file: PathBuf,
    /// What the command line changes in it.
    #[command(flatten)]
    pub over: StudyOverrides,
    /// The base plant of the study (a built-in name or a TOML file; rows that name their
    /// own keep theirs).
    #[arg(long)]
    pub config: Option<String>,
    /// Where the study's JSON (NAME.json), the plants made of keys and the run folder go
    /// (default: out/NAME).
    #[arg(long)]
    pub out: Option<PathBuf>,
    /// Write the study's JSON here instead (.json). Not with `--shard`: a shard writes its
    /// run files only, and `trn merge --report` writes the JSON of every shard's.
    #[arg(long, conflicts_with = "shard")]
    pub report: Option<PathBuf>,
    /// Parallelism, resume, shard, run folder.
    #[command(flatten)]
    pub opts: StudyOpts,
}

/// `trn merge`.
#[derive(Debug, Args, Clone)]
pub struct MergeArgs {
    /// Run files, or run folders (their *.json files), of one study: every shard's.
    #[arg(required = true)]
    pub files: Vec<PathBuf>,
    /// Write the study's JSON here (.json): what the unsharded command writes.
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// A life-long study's plot (.png or .svg).
    #[arg(long)]
    pub plot: Option<PathBuf>,
}

/// `trn decode`.
#[derive(Debug, Args, Clone)]
pub struct DecodeArgs {
    /// The candump log.
    pub log: PathBuf,
    /// Print only the counts.
    #[arg(long)]
    pub summary: bool,
    /// How to print the frames: `text` (each line of the log, then what it carries), `json`
    /// (JSON Lines: an object a frame, the message's fields included) or `csv` (a row a
    /// frame, the message's fields as JSON in the last column); with `json` and `csv` the
    /// counts go to standard error.
    #[arg(long, value_enum, default_value_t)]
    pub format: crate::decode::Format,
}

/// `trn model`.
#[derive(Debug, Args, Clone)]
pub struct ModelArgs {
    /// Simulator configuration: a TOML file, or a built-in one by name (`realistic`, the
    /// default, `ideal`, `aging`, `realistic-aging`).
    #[arg(long)]
    pub config: Option<String>,
    /// MuJoCo's MJCF instead of URDF.
    #[arg(long)]
    pub mjcf: bool,
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
    #[arg(long, default_value_t = 300, value_parser = clap::value_parser!(u64).range(0..=1_000_000))]
    pub initial: u64,
    /// A snapshot evaluation every this many trials.
    #[arg(long, default_value_t = 250, value_parser = clap::value_parser!(u64).range(1..=1_000_000))]
    pub snapshot_every: u64,
    /// Held-out targets per network in each snapshot.
    #[arg(long, default_value_t = 50, value_parser = clap::value_parser!(u64).range(0..=100_000))]
    pub snapshot_targets: u64,
    /// Held-out grasps in each snapshot.
    #[arg(long, default_value_t = 40, value_parser = clap::value_parser!(u64).range(0..=100_000))]
    pub snapshot_grasps: u64,
    /// Simulator configuration: `aging` (the default: the ideal plant with temperature
    /// drift and bounded wear), `realistic-aging` (the realistic plant with the same drift
    /// and wear), another built-in one by name (`ideal`, `realistic`), or a TOML file.
    #[arg(long, default_value = "aging")]
    pub config: String,
    /// Only these controllers (comma-separated: frozen, project, lifelong, broyden).
    #[arg(long, value_delimiter = ',', default_values_t = vec!["frozen".to_string(), "project".into(), "lifelong".into(), "broyden".into()])]
    pub only: Vec<String>,
    /// Where lifelong.json (and, with the plot feature, lifelong.png) go.
    #[arg(long, default_value = "out/lifelong")]
    pub out: PathBuf,
    /// Parallelism (one run per controller), resume, shard, run folder.
    #[command(flatten)]
    pub opts: StudyOpts,
}

/// `trn sweep`.
#[derive(Debug, Args, Clone)]
pub struct SweepArgs {
    /// The sweep's study file (default: the built-in studies/sweep.toml: 16 variants,
    /// seeds 100-102, 300 trials).
    #[arg(long)]
    pub study: Option<PathBuf>,
    /// Rows, seeds, trials, the evaluation's size.
    #[command(flatten)]
    pub over: StudyOverrides,
    /// The base configuration the variants change: a TOML file, `ideal` (the default) or
    /// `realistic` (the last rows are the realistic plant whatever the base).
    #[arg(long)]
    pub config: Option<String>,
    /// Where the variants' configurations, sweep.json and the run folder go.
    #[arg(long, default_value = "out/sweep")]
    pub out: PathBuf,
    /// Parallelism, resume, shard, run folder.
    #[command(flatten)]
    pub opts: StudyOpts,
}

/// `trn conformance`.
#[derive(Debug, Args, Clone)]
pub struct ConformanceArgs {
    /// Shared options (the bus, the preset and seed sent in the `SessionConfig`).
    #[command(flatten)]
    pub common: Common,
}

/// The bus's silence timeout in seconds ([`trn_bench::spec::check_bus_timeout`]).
fn seconds(s: &str) -> Result<f64, String> {
    let x: f64 = s.parse().map_err(|e| format!("{e}"))?;
    trn_bench::spec::check_bus_timeout(x)
        .map(|()| x)
        .map_err(|e| format!("{s} is not {e}"))
}

/// Options shared by `train`, `eval`, `grasp` and `conformance`.
#[derive(Debug, Args, Clone)]
pub struct Common {
    /// Seed of the run (plant, targets, initial tables). Seeds 1-99 are for tuning; the
    /// README reports seeds from 100 up.
    #[arg(long, default_value_t = 100)]
    pub seed: u64,
    /// Simulator configuration: a TOML file, or a built-in one by name (`realistic`, the
    /// default: coupling, process noise, skewed loops, creep, camera outliers and
    /// dropouts, occlusion by hand and cylinder, lens distortion; `ideal`: none of it;
    /// `aging`: the ideal plant with temperature drift and bounded wear; `realistic-aging`:
    /// the realistic plant with the same drift and wear).
    #[arg(long)]
    pub config: Option<String>,
    /// How the camera processor reads the lights: `geometric` (the default: each light's
    /// projection plus noise, outliers and dropouts by rule; fast) or `pixels` (every
    /// capture rendered frame by frame and read by the camera processor on pixels; the
    /// plant key `vision`). Recorded with the plant in the report.
    #[arg(long, value_enum)]
    pub vision: Option<VisionArg>,
    /// Bus: `inproc` (the controller node in this process on a simulated clock, the
    /// default), `socketcan:IFACE` (a separate `controller-node` process on IFACE: vcan0 or
    /// a real adapter), `slcan:qemu` (the firmware in QEMU, CAN frames as SLCAN over its
    /// UART; build it first with `bash scripts/cross/pil.sh --build-only`; it takes seed,
    /// preset, ablation and CAN mode from the session's `SessionConfig`) or
    /// `slcan:/dev/DEVICE` (a USB-CAN adapter that speaks serial SLCAN, e.g. /dev/ttyACM0,
    /// with a controller elsewhere on the bus: `--external-controller`).
    #[arg(long, default_value = "inproc")]
    pub bus: String,
    /// The controller runs elsewhere on the bus (a board on `socketcan:IFACE` or behind a
    /// USB-CAN adapter at `slcan:/dev/DEVICE`): start none. It keeps its own tables:
    /// `trn eval`/`trn grasp` run them, `--checkpoint-out` reads them out,
    /// `--checkpoint-in` writes a checkpoint in.
    #[arg(long)]
    pub external_controller: bool,
    /// Use CAN FD framing (one frame per message) instead of CAN 2.0 segmentation.
    #[arg(long)]
    pub fd: bool,
    /// The CAN bit rate a serial SLCAN adapter is started with (bit/s: 10000, 20000, 50000,
    /// 100000, 125000, 250000, 500000, 800000 or 1000000).
    #[arg(long, default_value_t = 500_000)]
    pub bitrate: u32,
    /// Controller preset.
    #[arg(long, value_enum, default_value_t = Preset::Project)]
    pub preset: Preset,
    /// Ablation.
    #[arg(long, value_enum, default_value_t = Ablation::None)]
    pub ablation: Ablation,
    /// The control law: `trn` (the chapter's method), `broyden` (uncalibrated visual
    /// servoing with a Broyden Jacobian, no training) or `model` (the simulator's nominal
    /// inverse kinematics: a calibrated model without hysteresis compensation; in process
    /// only) or `oracle` (the physical limit: it solves on an exact copy of the simulated
    /// plant; in process only).
    #[arg(long = "controller", value_enum, default_value_t = ControllerChoice::Trn)]
    pub law: ControllerChoice,
    /// Held-out targets per network in the evaluation.
    #[arg(long, default_value_t = 100, value_parser = clap::value_parser!(u64).range(0..=trn_bench::spec::MAX_COUNT as u64))]
    pub eval_targets: u64,
    /// Grasps in the evaluation.
    #[arg(long, default_value_t = 50, value_parser = clap::value_parser!(u64).range(0..=trn_bench::spec::MAX_COUNT as u64))]
    pub grasps: u64,
    /// Fine moves after the coarse move in the held-out evaluation with the fixed move
    /// budget (never stopping early; at most 31).
    #[arg(long, default_value_t = 6, value_parser = clap::value_parser!(u8).range(0..=31))]
    pub fine_moves: u8,
    /// A frozen snapshot evaluation (held-out targets, fixed budget, no learning) every this
    /// many training trials (0: none).
    #[arg(long, default_value_t = 25, value_parser = clap::value_parser!(u64).range(0..=trn_bench::spec::MAX_COUNT as u64))]
    pub snapshot_every: u64,
    /// Held-out targets per network in each snapshot (the first of the held-out set; at
    /// most --eval-targets) [default: 50, or every held-out target when there are fewer]
    #[arg(long, value_parser = clap::value_parser!(u64).range(0..=trn_bench::spec::MAX_COUNT as u64))]
    pub snapshot_targets: Option<u64>,
    /// Write the JSON report here (.json).
    #[arg(long)]
    pub report: Option<PathBuf>,
    /// Write learning curves here (.png or .svg).
    #[arg(long)]
    pub plot: Option<PathBuf>,
    /// Record the bus traffic as a candump log here (.log).
    #[arg(long)]
    pub candump: Option<PathBuf>,
    /// Write one row per trial here (.csv): phase, kind, errors after the coarse and the
    /// last move, fine moves, pose and grasp errors, failure.
    #[arg(long)]
    pub csv: Option<PathBuf>,
    /// Show the run in the rerun viewer while it goes on (the arm, its lights, the target,
    /// each move's error, the learning curve); needs the Python package's live view:
    /// `pip install './python[live]'` (`$TRN_PYTHON`, else python3).
    #[arg(long)]
    pub rerun: bool,
    /// Save the same as a rerun recording here (.rrd; open it with `rerun FILE`).
    #[arg(long)]
    pub rerun_save: Option<PathBuf>,
    /// No progress bar.
    #[arg(long)]
    pub quiet: bool,
    /// Seconds without a frame from the controller before the run fails (0.5 <= s <= 3600).
    #[arg(long, default_value_t = 10.0, value_parser = seconds)]
    pub bus_timeout_s: f64,
    /// Use a checkpoint learned under another preset, ablation or configuration.
    #[arg(long)]
    pub allow_config_change: bool,
    /// Allow erasing or replacing the tables the controller has learned: `trn train` seeds
    /// new ones, `--checkpoint-in` writes the checkpoint's in, the conformance suite
    /// re-seeds them. trn says what it erases (the learning steps, the configuration)
    /// before it does. Without it, a run that would lose learned tables stops before
    /// anything changes.
    #[arg(long)]
    pub reset_tables: bool,
    /// Keep the controller's tables in this file, as a board keeps them in its flash (for
    /// the in-process controller, or the controller-node this run starts on
    /// socketcan:IFACE): restored at the start, saved as the controller saves them. Runs
    /// with the same file go on with the same tables.
    #[arg(long)]
    pub tables: Option<PathBuf>,
    /// Faults, each independent per frame, seeded by the run's seed:
    /// `drop=P,dup=P,reorder=P,corrupt=P,truncate=P` (any subset, each once, P in [0, 1]).
    /// On the in-process bus per frame and receiver; on any other bus on each frame this
    /// process sends and receives (a lossy line on demand).
    #[arg(long)]
    pub faults: Option<trn_protocol::bus::FaultConfig>,
}

/// `trn train`.
#[derive(Debug, Args, Clone)]
pub struct TrainArgs {
    /// Shared options.
    #[command(flatten)]
    pub common: Common,
    /// Training trials per network (at least 1: `trn eval` evaluates without training;
    /// default 300, or with --continue what the continued run had left).
    #[arg(long, value_parser = clap::value_parser!(u64).range(1..=1_000_000))]
    pub trials: Option<u64>,
    /// Continue from this checkpoint (life-long learning): its tables are written into the
    /// controller (over the bus; over learned tables only with --reset-tables).
    #[arg(long, conflicts_with = "keep_tables")]
    pub checkpoint_in: Option<PathBuf>,
    /// Train on the tables the controller holds (a board's, or those of --tables FILE)
    /// instead of new ones; the schedule goes on from their learning steps. They must have
    /// been learned under this run's configuration.
    #[arg(long, conflicts_with = "reset_tables")]
    pub keep_tables: bool,
    /// Save the trained networks here (written atomically), and the simulator's state at
    /// the end of training beside it (`CHECKPOINT.sim`, for `--continue`).
    #[arg(long)]
    pub checkpoint_out: Option<PathBuf>,
    /// Save the checkpoint every this many training trials per network as well (needs
    /// --checkpoint-out; 0: at the end only).
    #[arg(long, default_value_t = 0, value_parser = clap::value_parser!(u64).range(0..=1_000_000))]
    pub checkpoint_every: u64,
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
    /// The trained networks, written into the controller before the run. Without it the
    /// run uses the tables the controller holds (--external-controller, --tables FILE).
    #[arg(long)]
    pub checkpoint_in: Option<PathBuf>,
    /// Read the controller's tables out at the end and write them here (with
    /// --external-controller: a board's tables; --eval-targets 0 --grasps 0 only reads).
    #[arg(long)]
    pub checkpoint_out: Option<PathBuf>,
}

/// `trn compare`.
#[derive(Debug, Args, Clone)]
pub struct CompareArgs {
    /// The comparison's study file (default: the built-in studies/compare.toml: 8
    /// configurations, seeds 100-109, 300 trials, 100 held-out targets, 50 grasps).
    #[arg(long)]
    pub study: Option<PathBuf>,
    /// Rows (--configs project,paper,no-neighbourhood,no-priming,no-fine,no-trial-secant,
    /// broyden,model), seeds, trials, the evaluation's size.
    #[command(flatten)]
    pub over: StudyOverrides,
    /// Only the project preset (the test suite's band check): `--configs project`.
    #[arg(long, conflicts_with = "configs")]
    pub project_only: bool,
    /// Simulator configuration: a TOML file, or a built-in one by name (`realistic`, the
    /// default; `ideal`; `aging`; `realistic-aging`).
    #[arg(long)]
    pub config: Option<String>,
    /// Write every configuration's figures over the seeds as JSON here (.json). Not with
    /// `--shard`: a shard writes its run files only, and `trn merge --report` writes the
    /// JSON of every shard's.
    #[arg(long, conflicts_with = "shard")]
    pub report: Option<PathBuf>,
    /// Where plants made of keys and the run folder go.
    #[arg(long, default_value = "out/compare")]
    pub out: PathBuf,
    /// Parallelism, resume, shard, run folder.
    #[command(flatten)]
    pub opts: StudyOpts,
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::CommandFactory;

    /// `trn train --help` names every bus form the transports accept, and every control
    /// law by name.
    #[test]
    fn train_help_lists_every_bus_form_and_law() {
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
        for law in ControllerChoice::ALL {
            assert!(help.contains(law.name()), "{} missing", law.name());
        }
    }

    /// Every help text that takes `--config` names every built-in configuration.
    #[test]
    fn config_help_lists_every_named_plant() {
        let mut cli = Cli::command();
        for sub in ["train", "lifelong", "compare", "model"] {
            let help = cli
                .find_subcommand_mut(sub)
                .unwrap()
                .render_long_help()
                .to_string();
            for name in trn_plant::SimConfig::NAMES {
                assert!(
                    help.contains(&format!("`{name}`")),
                    "{name} missing from trn {sub} --help"
                );
            }
        }
    }

    /// A study's `--report` with `--shard` is refused (a shard writes no JSON: it would be
    /// ignored), naming both options; either alone is taken.
    #[test]
    fn a_shard_refuses_a_report() {
        for sub in ["compare", "study"] {
            let with = |extra: &[&str]| {
                let mut args = vec!["trn", sub];
                if sub == "study" {
                    args.push("s.toml");
                }
                args.extend(extra);
                Cli::try_parse_from(args)
            };
            let err = with(&["--shard", "0/2", "--report", "x.json"]).unwrap_err();
            assert_eq!(
                err.kind(),
                clap::error::ErrorKind::ArgumentConflict,
                "{sub}"
            );
            let text = err.to_string();
            assert!(
                text.contains("--report") && text.contains("--shard"),
                "{sub}: {text}"
            );
            assert!(with(&["--shard", "0/2"]).is_ok(), "{sub}");
            assert!(with(&["--report", "x.json"]).is_ok(), "{sub}");
        }
    }

    /// The clap names of the wire-coded enums are their names in reports.
    #[test]
    fn value_names_are_the_enums_names() {
        use clap::ValueEnum;
        for p in Preset::ALL {
            assert_eq!(p.to_possible_value().unwrap().get_name(), p.name());
        }
        for a in Ablation::ALL {
            assert_eq!(a.to_possible_value().unwrap().get_name(), a.name());
        }
        for l in ControllerChoice::ALL {
            assert_eq!(l.to_possible_value().unwrap().get_name(), l.name());
        }
    }
}
