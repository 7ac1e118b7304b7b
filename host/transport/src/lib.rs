//! `trn-transport`: the host side's buses and where the controller runs on each.
//!
//! | `--bus` | the controller | the transport | the clock |
//! |---|---|---|---|
//! | `inproc` | this process, serviced inline ([`inproc::SimulatedBus`]) | `trn_protocol::bus::InProcBus` | simulated |
//! | `socketcan:IFACE` | a `controller-node` process ([`controller_loop`], [`peer`]) | `trn_protocol::bus::SocketCanPort` on IFACE (vcan or a real adapter) | wall |
//! | `slcan:qemu` | the firmware in QEMU (processor in the loop) | [`slcan_qemu::SlcanPort`] over the emulated UART | wall |
//! | `slcan:/dev/ttyACM0` | a board on the CAN bus (`--external-controller`) | [`slcan_serial::SerialSlcan`]: a USB-CAN adapter speaking SLCAN | wall |
//!
//! [`BusProfile`] says what each one can do (timing, a tables file, host-only laws);
//! [`Clock`] is the time the runner, the rig and the node read.

pub mod board;
pub mod clock;
pub mod controller_loop;
mod error;
pub mod inproc;
pub mod node_bus;
pub mod peer;
pub mod slcan_qemu;
pub mod slcan_serial;
mod spec;

pub use clock::{Clock, SimClock, WallClock};
pub use error::TransportError;
pub use spec::{BusProfile, BusSpec, ControllerSite};
