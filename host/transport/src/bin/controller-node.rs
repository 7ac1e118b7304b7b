//! `controller-node`: the TRN controller as its own process on a SocketCAN interface (vcan0
//! or real hardware) or a serial SLCAN adapter, as a board is on its bus. `trn --bus
//! socketcan:IFACE` starts one; it can also run alone, across sessions, until SIGINT or
//! SIGTERM.

use clap::Parser;
use std::path::PathBuf;
use std::process::ExitCode;

/// `controller-node`: the controller as a CAN node in its own process, on a SocketCAN
/// interface (vcan0 or a real adapter). It answers the protocol of protocol/SPEC.md: each
/// session's `SessionConfig` configures it (preset, ablation, law, image size, seed, CAN
/// FD); its learned tables come from its store or over the bus (`trn ... --checkpoint-in`)
/// and go out over the bus (`trn ... --checkpoint-out`). It runs until SIGINT or SIGTERM,
/// then keeps its tables in its store and exits.
#[derive(Debug, Parser)]
#[command(name = "controller-node", version)]
struct Args {
    #[command(flatten)]
    bus: trn_transport::node_bus::NodeBusArgs,
    /// Keep the learned tables in this file (created if missing), as a board keeps them in
    /// its flash: restored at start, saved when the node saves (on entering Mature, when the
    /// runner asks, at exit). Without it the store is in memory and the tables last as long
    /// as the process.
    #[arg(long)]
    tables: Option<PathBuf>,
    /// The protocol version it speaks (protocol/SPEC.md, "Versions"): 4; 3 makes it a
    /// version-3 controller, to try a runner or a tool against one: what version 4 added
    /// (the guard, the tables over the bus, estimated lights) is unknown to it.
    #[arg(long, default_value_t = 4, value_parser = clap::value_parser!(u8).range(3..=4))]
    protocol: u8,
}

#[cfg(target_os = "linux")]
fn run(a: &Args) -> Result<(), String> {
    use std::sync::atomic::AtomicBool;
    use std::sync::Arc;
    use trn_controller::presets::{self, Ablation, ImageSize, Preset};
    use trn_transport::board;
    use trn_transport::{controller_loop, WallClock};
    // the reset configuration of a board: the project preset for the default cameras,
    // tables seeded with 1; a session's `SessionConfig` replaces both
    let reset = presets::configure(Preset::Project, Ablation::None, ImageSize::DEFAULT);
    let (mut b, restored) = board::boot(reset, a.tables.as_deref()).map_err(|e| e.to_string())?;
    match &restored {
        Ok(copy) => eprintln!(
            "controller-node: restored tables of {} and {} learning steps (stored copy {})",
            copy.steps.0, copy.steps.1, copy.sequence
        ),
        Err(e) => {
            b.ctrl.init_random(1);
            if let Some(problem) = board::restore_problem(e) {
                eprintln!("controller-node: {problem}: starting with reset tables");
            }
        }
    }
    let guard = os_entropy().unwrap_or_else(|e| {
        eprintln!("controller-node: no entropy for the guard ({e}): its learned tables cannot be replaced over the bus");
        [0; 16]
    });
    let cfg = match a.protocol {
        3 => trn_node::NodeConfig::HOST_V3,
        _ => trn_node::NodeConfig::HOST,
    };
    let mut node = board::node(&mut b, restored.ok(), guard, cfg);
    let stop = Arc::new(AtomicBool::new(false));
    for signal in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
        signal_hook::flag::register(signal, stop.clone()).map_err(|e| e.to_string())?;
    }
    let clock = WallClock::start();
    let port = a.bus.open()?;
    let ran = controller_loop::run(port, &mut b, &mut node, &clock, &stop);
    // what changed since the last save is kept before the process ends
    let kept = board::save_now(&mut node, &mut b, &clock);
    let s = node.stats();
    eprintln!(
        "controller-node: {} trials, {} aborted, {} frame errors",
        s.trials, s.aborted, s.frame_errors
    );
    ran.map_err(|e| e.to_string())?;
    kept.map_err(|e| format!("the tables were not saved: {e}"))
}

/// 16 bytes of the operating system's entropy: the guard's seed, which nothing on the bus
/// can predict.
#[cfg(target_os = "linux")]
fn os_entropy() -> std::io::Result<[u8; 16]> {
    use std::io::Read;
    let mut seed = [0u8; 16];
    std::fs::File::open("/dev/urandom")?.read_exact(&mut seed)?;
    Ok(seed)
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
