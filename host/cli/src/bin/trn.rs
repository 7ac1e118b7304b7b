//! `trn`: train, evaluate and grasp with the TRN controller on the simulated SoftArm,
//! compare it with its ablations and baselines, or check a controller on a CAN bus.
//! `cargo run --release --bin trn -- train` is the project's main job.

use clap::Parser;
use std::process::ExitCode;
use trn_bench::{run, Command, Observer, RunSpec};
use trn_conformance::Conformance;
use trn_sim::cli::{Cli, Cmd, Common};
use trn_sim::live::{Both, LiveStream};
use trn_sim::progress::{Interrupts, Progress};
use trn_sim::studies;
use trn_sim::summary;
use trn_sim::{CliError, Result};
use trn_studies::lifelong;

/// Runs one specification with the progress bar and the interrupts (and the live view,
/// `--rerun`/`--rerun-save`); prints its summary as soon as the run is over, before its
/// files are written (a write that then fails loses no figure), then draws its plot.
fn run_one(
    spec: RunSpec,
    common: &Common,
    interrupts: &Interrupts,
    print_training: bool,
) -> Result<()> {
    let mut progress = Progress::new(spec.command == Command::Conformance, interrupts.clone());
    let mut summary = Summary {
        command: spec.command,
        print_training,
        printed: None,
    };
    let ran = if common.rerun || common.rerun_save.is_some() {
        let mut live = LiveStream::start(&spec.plant, common.rerun, common.rerun_save.as_deref())?;
        let watching = &mut Both(&mut progress, &mut live);
        let ran = run::run_with(&spec, &mut Both(watching, &mut summary), &Conformance);
        live.close()?;
        ran
    } else {
        run::run_with(&spec, &mut Both(&mut progress, &mut summary), &Conformance)
    };
    let report = ran?;
    if let Some(p) = &spec.outputs.plot {
        plot(&report, p)?;
    }
    // a run always ends in `ran` (the summary) unless it failed, which `ran?` returned
    summary.printed.unwrap_or(Ok(())).map_err(CliError::from)
}

/// Prints the run's summary the moment the run is over ([`Observer::ran`]), beside the
/// progress bar and the live view.
struct Summary {
    command: Command,
    print_training: bool,
    /// The summary's outcome, once printed (a failed conformance check, too many failed
    /// trials).
    printed: Option<trn_bench::Result<()>>,
}

impl Observer for Summary {
    fn ran(&mut self, report: &trn_bench::Report) {
        self.printed = Some(match self.command {
            Command::Conformance => summary::conformance(report),
            _ if report.interrupted => {
                summary::interrupted(report);
                Ok(())
            }
            _ => summary::print(report, self.print_training),
        });
    }
}

/// Draws the learning curves into a temporary file beside `path` that becomes `path` only
/// when whole (the output rule of every file).
#[cfg(feature = "plot")]
fn plot(report: &trn_bench::Report, path: &std::path::Path) -> Result<()> {
    let pending = trn_bench::output::PendingFile::create(path)?;
    trn_sim::plot::learning_curves(report, pending.temporary_path())
        .map_err(|e| CliError::Plot(format!("{}: {e}", path.display())))?;
    pending.commit()?;
    Ok(())
}

#[cfg(not(feature = "plot"))]
fn plot(_: &trn_bench::Report, _: &std::path::Path) -> Result<()> {
    Err(CliError::NoPlot)
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    let interrupts = match Interrupts::install() {
        Ok(i) => i,
        Err(e) => {
            eprintln!("trn: error: cannot install the signal handlers: {e}");
            return ExitCode::FAILURE;
        }
    };
    // what a study's build asks before each configuration
    let stop = || interrupts.requested();
    let result = match &cli.command {
        Cmd::Train(a) => a
            .spec()
            .map_err(CliError::from)
            .and_then(|s| run_one(s, &a.common, &interrupts, true)),
        Cmd::Eval(a) => a
            .spec(Command::Eval)
            .map_err(CliError::from)
            .and_then(|s| run_one(s, &a.common, &interrupts, false)),
        Cmd::Grasp(a) => a
            .spec(Command::Grasp)
            .map_err(CliError::from)
            .and_then(|s| run_one(s, &a.common, &interrupts, false)),
        Cmd::Conformance(a) => a
            .common
            .spec(Command::Conformance, 0)
            .map_err(CliError::from)
            .and_then(|s| run_one(s, &a.common, &interrupts, false)),
        Cmd::Model(a) => model(a),
        Cmd::Decode(a) => trn_sim::decode::decode_as(
            &a.log,
            a.summary,
            a.format,
            &mut std::io::stdout().lock(),
            &mut std::io::stderr().lock(),
        )
        .map(drop),
        Cmd::Compare(a) => a
            .spec()
            .study_unless(&stop)
            .map_err(CliError::from)
            .and_then(|s| {
                let opts = a.opts.options(&a.out);
                studies::run(&s, &opts, a.opts.quiet, &interrupts, a.report.as_deref()).map(drop)
            }),
        Cmd::Sweep(a) => a
            .spec()
            .study_unless(&stop)
            .map_err(CliError::from)
            .and_then(|s| {
                trn_bench::fsio::create_folder(&a.out)?;
                let (opts, json) = (a.opts.options(&a.out), a.out.join("sweep.json"));
                studies::run(&s, &opts, a.opts.quiet, &interrupts, Some(&json)).map(drop)
            }),
        Cmd::Lifelong(a) => lifelong_run(&a.spec(), &a.opts, &interrupts),
        Cmd::Study(a) => a
            .study(&stop)
            .map_err(CliError::from)
            .and_then(|(s, out, json)| {
                let opts = a.opts.options(&out);
                studies::run(&s, &opts, a.opts.quiet, &interrupts, Some(&json)).map(drop)
            }),
        Cmd::Merge(a) => {
            studies::merge(&a.files, a.report.as_deref()).and_then(|f| match &a.plot {
                Some(p) => lifelong_plot(&f.files, p),
                None => Ok(()),
            })
        }
    };
    if let Some(code) = interrupts.exit_code() {
        if let Err(e) = &result {
            eprintln!("trn: error: {e}");
        }
        eprintln!("trn: interrupted");
        return ExitCode::from(code);
    }
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("trn: error: {e}");
            ExitCode::from(e.exit_code())
        }
    }
}

/// `trn model`: the arm's URDF or MJCF on standard output.
fn model(a: &trn_sim::cli::ModelArgs) -> Result<()> {
    use std::io::Write;
    let cfg = trn_plant::SimConfig::resolve(a.config.as_deref().map(std::path::Path::new))?;
    let text = if a.mjcf {
        trn_plant::model::mjcf(&cfg)
    } else {
        trn_plant::model::urdf(&cfg)
    };
    std::io::stdout()
        .lock()
        .write_all(text.as_bytes())
        .map_err(|e| CliError::from(trn_bench::io(std::path::Path::new("standard output"))(e)))
}

fn lifelong_run(
    spec: &lifelong::LifelongSpec,
    opts: &trn_sim::cli::StudyOpts,
    interrupts: &Interrupts,
) -> Result<()> {
    let study = spec.study()?;
    trn_bench::fsio::create_folder(&spec.out)?;
    let json = spec.out.join("lifelong.json");
    let done = studies::run(
        &study,
        &opts.options(&spec.out),
        opts.quiet,
        interrupts,
        Some(&json),
    )?;
    match done {
        Some(f) if cfg!(feature = "plot") => {
            lifelong_plot(&f.files, &spec.out.join("lifelong.png"))
        }
        _ => Ok(()),
    }
}

/// The life-long plot of a study's runs, written whole or not at all.
#[cfg(feature = "plot")]
fn lifelong_plot(files: &[trn_studies::study::RunFile], path: &std::path::Path) -> Result<()> {
    let pending = trn_bench::output::PendingFile::create(path)?;
    trn_sim::plot::lifelong(&lifelong::curves(files), pending.temporary_path())
        .map_err(|e| CliError::Plot(format!("{}: {e}", path.display())))?;
    pending.commit()?;
    Ok(())
}

#[cfg(not(feature = "plot"))]
fn lifelong_plot(_: &[trn_studies::study::RunFile], _: &std::path::Path) -> Result<()> {
    Err(CliError::NoPlot)
}
