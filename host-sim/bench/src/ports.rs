//! Which ports of a session hold the controller itself (the in-process bus services it
//! inline), so that its tables can be checkpointed while the run goes on; on every other
//! port the controller is elsewhere.

use std::io::Write;

use trn_controller::Controller;
use trn_protocol::bus::RecordingPort;
use trn_transport::inproc::SimulatedBus;

use crate::oracle::Oracle;
use crate::reference::NominalIk;

/// A session's port, and the project's controller if this port holds it.
pub trait ControllerPort {
    /// The controller with its tables, when it runs inline on this port.
    fn controller(&self) -> Option<&Controller> {
        None
    }
}

impl ControllerPort for SimulatedBus<Controller> {
    fn controller(&self) -> Option<&Controller> {
        Some(SimulatedBus::controller(self))
    }
}

impl ControllerPort for SimulatedBus<trn_transport::board::Board> {
    fn controller(&self) -> Option<&Controller> {
        Some(&SimulatedBus::controller(self).ctrl)
    }
}

impl ControllerPort for SimulatedBus<NominalIk> {}

impl ControllerPort for SimulatedBus<Oracle> {}

impl<P: ControllerPort, W: Write, C: FnMut() -> u64> ControllerPort for RecordingPort<P, W, C> {
    fn controller(&self) -> Option<&Controller> {
        self.port().controller()
    }
}

#[cfg(target_os = "linux")]
impl ControllerPort for trn_protocol::bus::SocketCanPort {}
impl ControllerPort for trn_transport::slcan_qemu::SlcanPort {}
impl ControllerPort for trn_transport::slcan_serial::SerialSlcan {}
