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
            "{} not found: build it with `cargo build --release -p trn-transport --bin controller-node` or set TRN_CONTROLLER_NODE",
            beside.display()
        )),
    }
}

/// What a `controller-node` process is started with: it is configured by the session's
/// `SessionConfig` over the bus, and its tables come over the bus or from its store.
#[derive(Debug, Clone, Default)]
pub struct NodeArgs<'a> {
    /// SocketCAN interface.
    pub iface: &'a str,
    /// Its tables file (`--tables`): the store its tables survive in; none, a store in memory.
    pub tables: Option<&'a Path>,
}

/// Starts `controller-node` on a SocketCAN interface.
pub fn spawn_controller_node(a: &NodeArgs, bus: &str) -> Result<Child, TransportError> {
    let exe = controller_node_exe().map_err(|m| TransportError::open(bus, m))?;
    let mut cmd = Command::new(exe);
    cmd.arg("--iface").arg(a.iface);
    if let Some(p) = a.tables {
        cmd.arg("--tables").arg(p);
    }
    let child = cmd
        .spawn()
        .map_err(|e| TransportError::open(bus, format!("cannot start controller-node: {e}")))?;
    // give the node time to open its socket before the first request
    std::thread::sleep(Duration::from_millis(300));
    Ok(child)
}

/// Ends a controller process after the session. A controller runs on across sessions, as a
/// board does (`controller-node` until a signal, the firmware in QEMU until QEMU ends): one
/// that already exited failed if the session needed it; one still running is asked to stop
/// (SIGTERM: `controller-node` keeps its tables and exits, QEMU ends) and killed if it has
/// not within 5 s.
pub fn finish_process(mut child: Child, session_ok: bool, bus: &str) -> Result<(), TransportError> {
    match child.try_wait() {
        Ok(Some(status)) if status.success() || !session_ok => return Ok(()),
        Ok(Some(status)) => {
            return Err(TransportError::Controller {
                bus: bus.to_string(),
                msg: format!("exited with {status} during the session"),
            })
        }
        _ => {}
    }
    terminate(&child);
    let deadline = Instant::now() + Duration::from_secs(5);
    loop {
        match child.try_wait() {
            Ok(Some(_)) => return Ok(()),
            Ok(None) if Instant::now() < deadline => std::thread::sleep(Duration::from_millis(20)),
            _ => {
                let _ = child.kill();
                let _ = child.wait();
                return Ok(());
            }
        }
    }
}

/// Asks a child to stop (SIGTERM).
#[cfg(unix)]
fn terminate(child: &Child) {
    #[allow(unsafe_code)]
    // SAFETY: kill(2) on the id of a child this process started and has not reaped.
    unsafe {
        libc::kill(child.id() as libc::pid_t, libc::SIGTERM);
    }
}

#[cfg(not(unix))]
fn terminate(_: &Child) {}
