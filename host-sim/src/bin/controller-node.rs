//! `controller-node`: the TRN controller as its own process on a SocketCAN interface
//! (vcan0 or real hardware). `trn --bus socketcan:IFACE` starts it; it can also run alone.
//! It exits after the runner's `ModeChange{Idle}`, saving its checkpoint if asked.

use clap::Parser;
use std::path::PathBuf;
use std::process::ExitCode;
use trn_sim::experiment::cli::{Ablation, Controller, Preset};

/// The TRN controller node on SocketCAN.
#[derive(Debug, Parser)]
#[command(name = "controller-node", version, about)]
struct Args {
    /// SocketCAN interface.
    #[arg(long, default_value = "vcan0")]
    iface: String,
    /// Seed of the initial tables.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Controller preset.
    #[arg(long, value_enum, default_value_t = Preset::Project)]
    preset: Preset,
    /// Ablation.
    #[arg(long, value_enum, default_value_t = Ablation::None)]
    ablation: Ablation,
    /// Control law.
    #[arg(long, value_enum, default_value_t = Controller::Trn)]
    controller: Controller,
    /// Simulator configuration (for the camera image size the initial weights span).
    #[arg(long)]
    config: Option<PathBuf>,
    /// CAN FD framing.
    #[arg(long)]
    fd: bool,
    /// Start from this checkpoint.
    #[arg(long)]
    checkpoint_in: Option<PathBuf>,
    /// Save the networks here at the end (atomically).
    #[arg(long)]
    checkpoint_out: Option<PathBuf>,
    /// Use a checkpoint learned under another configuration.
    #[arg(long)]
    allow_config_change: bool,
}

#[cfg(target_os = "linux")]
fn run(a: &Args) -> Result<(), String> {
    use trn_sim::experiment::checkpoint_file;
    use trn_sim::experiment::run::{controller_config, load_sim_config};
    use trn_sim::transport::controller_loop;
    let sim = load_sim_config(a.config.as_deref()).map_err(|e| e.to_string())?;
    let provenance = trn_controller::checkpoint::Provenance::of(a.preset.into(), a.ablation.into());
    let cfg = trn_controller::Config {
        law: a.controller.into(),
        ..controller_config(a.preset, a.ablation, &sim)
    };
    let mut ctrl = Box::new(trn_controller::Controller::new(cfg));
    ctrl.init_random(a.seed);
    if let Some(p) = &a.checkpoint_in {
        checkpoint_file::load(&mut ctrl, p, provenance, a.allow_config_change)
            .map_err(|e| e.to_string())?;
    }
    let port = trn_protocol::bus::SocketCanPort::open(&a.iface)
        .map_err(|e| format!("{}: {e}", a.iface))?;
    let mode = if a.fd {
        trn_protocol::BusMode::Fd
    } else {
        trn_protocol::BusMode::Classic
    };
    let stop = std::sync::atomic::AtomicBool::new(false);
    let (ctrl, stats) = controller_loop::run(port, ctrl, mode, &stop).map_err(|e| e.to_string())?;
    eprintln!(
        "controller-node: {} trials, {} aborted, {} frame errors",
        stats.node.trials, stats.node.aborted, stats.node.frame_errors
    );
    if let Some(p) = &a.checkpoint_out {
        checkpoint_file::save(&ctrl, provenance, p).map_err(|e| e.to_string())?;
    }
    Ok(())
}

#[cfg(not(target_os = "linux"))]
fn run(_: &Args) -> Result<(), String> {
    Err("SocketCAN needs Linux".into())
}

fn main() -> ExitCode {
    let a = Args::parse();
    match run(&a) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("controller-node: error: {e}");
            ExitCode::FAILURE
        }
    }
}
