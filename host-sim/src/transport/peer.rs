//! The controller at the other end of the bus, as a run starts and stops it: a thread of
//! this process, or a child process (`controller-node`, QEMU running the firmware).

use std::path::{Path, PathBuf};
use std::process::{Child, Command};
use std::time::{Duration, Instant};

use trn_controller::Controller;

use super::controller_loop::{ControllerThread, LoopStats};
use crate::error::{Error, Result};

/// The controller's side of a run.
pub enum Peer {
    /// The controller node in a thread (in-process bus): its tables come back at the end.
    Thread(ControllerThread),
    /// The model-based reference in a thread (in-process bus): nothing comes back.
    Reference(ControllerThread<crate::reference::NominalIk>),
    /// A child process.
    Process(Child),
    /// A controller this run did not start (a board on the bus): nothing to stop.
    External,
}

/// The `controller-node` executable: `$TRN_CONTROLLER_NODE`, else beside this executable
/// (or one directory up, for test executables in `target/*/deps`).
pub fn controller_node_exe() -> std::result::Result<PathBuf, String> {
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
pub fn spawn_controller_node(a: &NodeArgs, bus: &str) -> Result<Child> {
    let bus_err = |msg: String| Error::BusOpen {
        bus: bus.to_string(),
        msg,
    };
    let exe = controller_node_exe().map_err(bus_err)?;
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
        .map_err(|e| bus_err(format!("cannot start controller-node: {e}")))?;
    // give the node time to open its socket before the first target
    std::thread::sleep(Duration::from_millis(300));
    Ok(child)
}

impl Peer {
    /// Ends the controller's side after the session: joins the thread (returning the
    /// controller with its tables) or waits for the process, killing it when the session
    /// failed or it does not exit within 10 s.
    pub fn finish(
        self,
        session_ok: bool,
        bus: &str,
    ) -> Result<Option<(Box<Controller>, LoopStats)>> {
        let bus_err = |msg: String| Error::BusOpen {
            bus: bus.to_string(),
            msg,
        };
        match self {
            Peer::Thread(t) => {
                if !session_ok {
                    return Ok(None);
                }
                let (ctrl, stats) = t.join().map_err(|e| bus_err(e.to_string()))?;
                Ok(Some((ctrl, stats)))
            }
            Peer::Reference(t) => {
                if session_ok {
                    t.join().map_err(|e| bus_err(e.to_string()))?;
                }
                Ok(None)
            }
            Peer::External => Ok(None),
            Peer::Process(mut child) => {
                let deadline = Instant::now() + Duration::from_secs(10);
                loop {
                    match child.try_wait() {
                        Ok(Some(status)) if status.success() || !session_ok => return Ok(None),
                        Ok(Some(status)) => {
                            return Err(bus_err(format!("controller-node exited with {status}")))
                        }
                        Ok(None) if Instant::now() < deadline && session_ok => {
                            std::thread::sleep(Duration::from_millis(20))
                        }
                        _ => {
                            let _ = child.kill();
                            let _ = child.wait();
                            return Ok(None);
                        }
                    }
                }
            }
        }
    }
}
