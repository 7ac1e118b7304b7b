//! `trn`: train, evaluate and grasp with the TRN controller on the simulated SoftArm,
//! compare it with its ablations and baselines, or check a controller on a CAN bus.
//! `cargo run --release --bin trn -- train` is the project's main job.

use clap::Parser;
use std::process::ExitCode;
use trn_lab::{compare, lifelong, run, summary, sweep, Command, RunSpec};
use trn_sim::cli::{Cli, Cmd, Common};
use trn_sim::live::{Both, LiveStream};
use trn_sim::progress::{Interrupts, Progress};
use trn_sim::{CliError, Result};

/// Runs one specification with the progress bar and the interrupts (and the live view,
/// `--rerun`/`--rerun-save`); draws its plot.
fn run_one(
    spec: RunSpec,
    common: &Common,
    interrupts: &Interrupts,
    print_training: bool,
) -> Result<()> {
    let mut progress = Progress::new(spec.command == Command::Conformance, interrupts.clone());
    let report = if common.rerun || common.rerun_save.is_some() {
        let mut live = LiveStream::start(&spec.plant, common.rerun, common.rerun_save.as_deref())?;
        let report = run::run(&spec, &mut Both(&mut progress, &mut live));
        live.close()?;
        report?
    } else {
        run::run(&spec, &mut progress)?
    };
    if let Some(p) = &spec.outputs.plot {
        plot(&report, p)?;
    }
    match spec.command {
        Command::Conformance => summary::conformance(&report)?,
        _ if report.interrupted => summary::interrupted(&report),
        _ => summary::print(&report, print_training)?,
    }
    Ok(())
}

#[cfg(feature = "plot")]
fn plot(report: &trn_lab::Report, path: &std::path::Path) -> Result<()> {
    trn_sim::plot::learning_curves(report, path)
}

#[cfg(not(feature = "plot"))]
fn plot(_: &trn_lab::Report, _: &std::path::Path) -> Result<()> {
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
        Cmd::Decode(a) => {
            trn_sim::decode::decode(&a.log, a.summary, &mut std::io::stdout().lock()).map(drop)
        }
        Cmd::Compare(a) => compare::run(&a.spec()).map_err(CliError::from),
        Cmd::Sweep(a) => sweep::run(&a.spec()).map_err(CliError::from),
        Cmd::Lifelong(a) => lifelong_run(&a.spec()),
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

fn lifelong_run(spec: &lifelong::LifelongSpec) -> Result<()> {
    let curves = lifelong::run(spec)?;
    #[cfg(feature = "plot")]
    trn_sim::plot::lifelong(&curves, &spec.out.join("lifelong.png"))?;
    #[cfg(not(feature = "plot"))]
    let _ = curves;
    Ok(())
}
