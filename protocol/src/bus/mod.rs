//! Transports behind the `embedded-can` traits (feature `std`).
//!
//! * [`InProcBus`]: an in-process virtual CAN bus with fault injection (the default);
//! * [`RecordingPort`]: wraps any port and records its traffic as a candump log;
//! * [`FaultyPort`]: wraps any port and injects faults into its traffic both ways;
//! * `SocketCanPort` (feature `socketcan`, Linux): vcan or real hardware.

use std::time::Duration;

use crate::error::Result;
use crate::frame::CanFrame;

mod faults;
mod faulty;
mod inproc;
mod recording;
#[cfg(all(feature = "socketcan", target_os = "linux"))]
mod socketcan;

#[cfg(all(feature = "socketcan", target_os = "linux"))]
pub use self::socketcan::SocketCanPort;
pub use faults::{BusStats, CorruptScope, FaultConfig};
pub use faulty::FaultyPort;
pub use inproc::{InProcBus, InProcPort};
pub use recording::RecordingPort;

/// Blocking receive with a timeout (std transports).
pub trait ReceiveTimeout {
    /// Waits up to `timeout` for a frame; `Ok(None)` on timeout.
    fn receive_timeout(&mut self, timeout: Duration) -> Result<Option<CanFrame>>;
}
