//! Where the controller runs and how frames reach it: the bus forms of `--bus`, the
//! controller's host loop, and the processes a run starts (`controller-node`, QEMU).
//!
//! | `--bus` | the controller | the transport |
//! |---|---|---|
//! | `inproc` | a thread of this process ([`controller_loop`]) | [`trn_protocol::bus::InProcBus`] |
//! | `socketcan:IFACE` | a `controller-node` process | `SocketCanPort` on IFACE (vcan or a real adapter) |
//! | `slcan:qemu` | the firmware in QEMU (processor in the loop) | [`slcan_qemu::SlcanPort`] over the emulated UART |
//! | `slcan:/dev/ttyACM0` | a board on the CAN bus (`--external-controller`) | [`slcan_serial::SerialSlcan`]: a USB-CAN adapter speaking SLCAN |

pub mod controller_loop;
pub mod peer;
pub mod slcan_qemu;
pub mod slcan_serial;

use crate::error::{Error, Result};

/// A parsed `--bus` argument.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum BusSpec {
    /// The in-process bus, the controller in a thread.
    InProc,
    /// SocketCAN on an interface, the controller a `controller-node` process.
    SocketCan(String),
    /// SLCAN over the UART of the firmware in QEMU.
    SlcanQemu,
    /// SLCAN over a serial device (a USB-CAN adapter).
    SlcanSerial(String),
}

impl BusSpec {
    /// Parses `inproc`, `socketcan:IFACE` or `slcan:qemu`.
    pub fn parse(s: &str) -> Result<BusSpec> {
        match s {
            "inproc" => Ok(BusSpec::InProc),
            "slcan:qemu" => Ok(BusSpec::SlcanQemu),
            _ if s.starts_with("slcan:/") => {
                Ok(BusSpec::SlcanSerial(s["slcan:".len()..].to_string()))
            }
            _ => match s.strip_prefix("socketcan:") {
                Some(iface) if !iface.is_empty() => Ok(BusSpec::SocketCan(iface.to_string())),
                _ => Err(Error::BusOpen {
                    bus: s.to_string(),
                    msg:
                        "expected `inproc`, `socketcan:IFACE`, `slcan:qemu` or `slcan:/dev/DEVICE`"
                            .into(),
                }),
            },
        }
    }

    /// The interface name used in candump logs.
    pub fn log_name(&self) -> &str {
        match self {
            BusSpec::SocketCan(iface) => iface,
            _ => "inproc0",
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bus_forms() {
        assert_eq!(BusSpec::parse("inproc").unwrap(), BusSpec::InProc);
        assert_eq!(
            BusSpec::parse("socketcan:vcan0").unwrap(),
            BusSpec::SocketCan("vcan0".into())
        );
        assert_eq!(BusSpec::parse("slcan:qemu").unwrap(), BusSpec::SlcanQemu);
        assert_eq!(
            BusSpec::parse("slcan:/dev/ttyACM0").unwrap(),
            BusSpec::SlcanSerial("/dev/ttyACM0".into())
        );
        for bad in ["", "socketcan:", "carrier-pigeon"] {
            let e = BusSpec::parse(bad).unwrap_err().to_string();
            assert!(e.contains("expected"), "{e}");
        }
    }
}
