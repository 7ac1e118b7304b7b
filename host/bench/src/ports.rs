//! Which ports of a session hold the controller itself (the in-process bus services it
//! inline), so that its tables can be checkpointed while the run goes on; on every other
//! port the controller is elsewhere.

use std::io::Write;

use trn_controller::{Control, Controller};
use trn_protocol::bus::{FaultyPort, RecordingPort};
use trn_transport::inproc::SimulatedBus;

/// A session's port, and the project's controller if this port holds it.
pub trait ControllerPort {
    /// The controller with its tables, when it runs inline on this port.
    fn controller(&self) -> Option<&Controller> {
        None
    }
}

/// The in-process bus holds its controller: the project's, a board (the controller and its
/// store), or a host-side controller without tables ([`Control::controller`]).
impl<C: Control + ?Sized> ControllerPort for SimulatedBus<C> {
    fn controller(&self) -> Option<&Controller> {
        SimulatedBus::controller(self).controller()
    }
}

impl<P: ControllerPort, W: Write, C: FnMut() -> u64> ControllerPort for RecordingPort<P, W, C> {
    fn controller(&self) -> Option<&Controller> {
        self.port().controller()
    }
}

/// The host's fault layer in front of a port: the controller is where the port's is.
impl<P: ControllerPort> ControllerPort for FaultyPort<P> {
    fn controller(&self) -> Option<&Controller> {
        self.port().controller()
    }
}

#[cfg(target_os = "linux")]
impl ControllerPort for trn_protocol::bus::SocketCanPort {}
impl ControllerPort for trn_transport::slcan_qemu::SlcanPort {}
impl ControllerPort for trn_transport::slcan_serial::SerialSlcan {}
