//! `controller-node`: the TRN controller as its own process on a SocketCAN interface
//! (vcan0 or real hardware). `trn --bus socketcan:IFACE` starts it; it can also run alone.
//! It exits after the runner's `ModeChange{Idle}`, saving its checkpoint if asked.

use clap::Parser;
use std::path::PathBuf;
use std::process::ExitCode;
use trn_controller::presets::{Ablation, Preset};
use trn_controller::Law;

/// `controller-node`: the controller as a CAN node in its own process, on a SocketCAN
/// interface (vcan0 or a real adapter). It answers the protocol of protocol/SPEC.md until
/// the runner ends the session (`ModeChange{Idle}`), then saves its tables if asked.
#[derive(Debug, Parser)]
#[command(name = "controller-node", version)]
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
    /// Control law (`trn` or `broyden`).
    #[arg(long, value_enum, default_value_t = Law::Trn)]
    controller: Law,
    /// Simulator configuration (for the camera image size the initial weights span).
    #[arg(long)]
    config: Option<String>,
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
    use trn_lab::{checkpoint_file, output, Command, Profile, RunSpec};
    use trn_transport::controller_loop;
    let mut spec = RunSpec::new(Command::Train, a.seed)
        .with_plant(a.config.as_deref())
        .map_err(|e| e.to_string())?;
    spec.profile = Profile {
        preset: a.preset,
        ablation: a.ablation,
        law: a.controller,
    };
    // the output is checked before the session: a board's tables are not lost to an
    // unwritable path at the end
    if let Some(p) = &a.checkpoint_out {
        output::check_path(p, output::Kind::Checkpoint).map_err(|e| e.to_string())?;
    }
    let provenance = trn_controller::checkpoint::Provenance::of(a.preset, a.ablation);
    let mut ctrl = Box::new(trn_controller::Controller::new(spec.profile_config()));
    ctrl.init_random(a.seed);
    if let Some(p) = &a.checkpoint_in {
        checkpoint_file::load(&mut ctrl, p, provenance, a.allow_config_change)
            .map_err(|e| e.to_string())?;
    }
    let port = trn_protocol::bus::SocketCanPort::open(&a.iface)
        .map_err(|e| format!("SocketCAN interface {}: {e}", a.iface))?;
    let mode = if a.fd {
        trn_protocol::BusMode::Fd
    } else {
        trn_protocol::BusMode::Classic
    };
    let stop = std::sync::atomic::AtomicBool::new(false);
    let (ctrl, stats) = controller_loop::run(port, ctrl, mode, &stop).map_err(|e| e.to_string())?;
    eprintln!(
        "controller-node: {} trials, {} aborted, {} frame errors",
        stats.trials, stats.aborted, stats.frame_errors
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
