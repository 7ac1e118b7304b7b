//! A controller in another process, as a run starts and stops it: `controller-node` on
//! SocketCAN, or QEMU running the firmware.

use std::path::{Path, PathBuf};
use std::process::{Child, Command};
use std::time::{Duration, Instant};

use crate::error::TransportError;

/// The `controller-node` executable: `$TRN_CONTROLLER_NODE`, else beside this executable
/// (or one directory up, for test executables in `target/*/deps`).
pub fn controller_node_exe() -> Result<PathBuf, String> {
    if let Some(p) = std::env::var_os("TRN_CONTROLLER_NODE") {
        return Ok(PathBuf::from(p));
    }
    let me = std::env::current_exe().map_err(|e| e.to_string())?;
    let beside = me.with_file_name("controller-node");
    let up = me
        .parent()
        .and_then(|d| d.parent())
        .map(|d| d.join("controller-node"));
    match (beside.exists(), up) {
        (true, _) => Ok(beside),
        (false, Some(up)) if up.exists() => Ok(up),
        _ => Err(format!(
            "{} not found: build it with `cargo build --release -p trn-sim --bins` or set TRN_CONTROLLER_NODE",
            beside.display()
        )),
    }
}

/// What a `controller-node` process is started with.
#[derive(Debug, Clone, Default)]
pub struct NodeArgs<'a> {
    /// SocketCAN interface.
    pub iface: &'a str,
    /// Seed of the initial tables.
    pub seed: u64,
    /// Preset name.
    pub preset: &'a str,
    /// Ablation name.
    pub ablation: &'a str,
    /// Control law name (`trn`, `broyden`).
    pub controller: &'a str,
    /// Simulator configuration (for the image size).
    pub config: Option<&'a Path>,
    /// CAN FD framing.
    pub fd: bool,
    /// Start from this checkpoint.
    pub checkpoint_in: Option<&'a Path>,
    /// Save the tables here at the end.
    pub checkpoint_out: Option<&'a Path>,
}

/// Starts `controller-node` on a SocketCAN interface.
pub fn spawn_controller_node(a: &NodeArgs, bus: &str) -> Result<Child, TransportError> {
    let exe = controller_node_exe().map_err(|m| TransportError::open(bus, m))?;
    let mut cmd = Command::new(exe);
    cmd.arg("--iface")
        .arg(a.iface)
        .arg("--seed")
        .arg(a.seed.to_string());
    cmd.arg("--preset")
        .arg(a.preset)
        .arg("--ablation")
        .arg(a.ablation)
        .arg("--controller")
        .arg(a.controller);
    if let Some(c) = a.config {
        cmd.arg("--config").arg(c);
    }
    if a.fd {
        cmd.arg("--fd");
    }
    if let Some(p) = a.checkpoint_in {
        cmd.arg("--checkpoint-in").arg(p);
    }
    if let Some(p) = a.checkpoint_out {
        cmd.arg("--checkpoint-out").arg(p);
    }
    let child = cmd
        .spawn()
        .map_err(|e| TransportError::open(bus, format!("cannot start controller-node: {e}")))?;
    // give the node time to open its socket before the first target
    std::thread::sleep(Duration::from_millis(300));
    Ok(child)
}

/// Ends a controller process after the session: waits for it to exit (it does after the
/// runner's `Idle`), killing it when the session failed or it does not exit within 10 s.
pub fn finish_process(mut child: Child, session_ok: bool, bus: &str) -> Result<(), TransportError> {
    let deadline = Instant::now() + Duration::from_secs(10);
    loop {
        match child.try_wait() {
            Ok(Some(status)) if status.success() || !session_ok => return Ok(()),
            Ok(Some(status)) => {
                return Err(TransportError::Controller {
                    bus: bus.to_string(),
                    msg: format!("controller-node exited with {status}"),
                })
            }
            Ok(None) if Instant::now() < deadline && session_ok => {
                std::thread::sleep(Duration::from_millis(20))
            }
            _ => {
                let _ = child.kill();
                let _ = child.wait();
                return Ok(());
            }
        }
    }
}
