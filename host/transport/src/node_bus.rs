//! The bus a node process sits on, as its command line names it: a SocketCAN interface or a
//! serial SLCAN adapter. `controller-node` and `camera-node` take the same options
//! ([`NodeBusArgs`], flattened into their own) and get one port type ([`NodePort`]) that
//! either loop runs on.

use std::time::Duration;

use trn_protocol::bus::ReceiveTimeout;
#[cfg(target_os = "linux")]
use trn_protocol::bus::SocketCanPort;
use trn_protocol::{CanFrame, Error};

use crate::slcan_serial::SerialSlcan;

/// A node process's bus options.
#[derive(Debug, Clone, clap::Args)]
pub struct NodeBusArgs {
    /// SocketCAN interface.
    #[arg(long, default_value = "vcan0", conflicts_with = "slcan")]
    pub iface: String,
    /// A serial SLCAN adapter (a USB-CAN adapter in the Lawicel format, or one end of a
    /// pseudo-terminal) instead of SocketCAN; CAN 2.0 frames only, as the adapters carry.
    #[arg(long, value_name = "DEVICE")]
    pub slcan: Option<String>,
    /// The adapter's CAN bit rate (`--slcan`).
    #[arg(long, default_value_t = 500_000, requires = "slcan")]
    pub bitrate: u32,
}

impl NodeBusArgs {
    /// The port the options name, opened (a serial adapter started at its bit rate).
    pub fn open(&self) -> Result<NodePort, String> {
        match &self.slcan {
            Some(device) => Ok(NodePort::Slcan(SerialSlcan::open(device, self.bitrate)?)),
            #[cfg(target_os = "linux")]
            None => SocketCanPort::open(&self.iface)
                .map(NodePort::SocketCan)
                .map_err(|e| format!("SocketCAN interface {}: {e}", self.iface)),
            #[cfg(not(target_os = "linux"))]
            None => Err(format!(
                "SocketCAN interface {}: SocketCAN needs Linux (--slcan DEVICE serves elsewhere)",
                self.iface
            )),
        }
    }
}

/// A SocketCAN interface or a serial SLCAN adapter, through the same traits.
pub enum NodePort {
    /// SocketCAN.
    #[cfg(target_os = "linux")]
    SocketCan(SocketCanPort),
    /// A serial SLCAN adapter.
    Slcan(SerialSlcan),
}

impl embedded_can::blocking::Can for NodePort {
    type Frame = CanFrame;
    type Error = Error;

    fn transmit(&mut self, frame: &CanFrame) -> Result<(), Error> {
        match self {
            #[cfg(target_os = "linux")]
            NodePort::SocketCan(p) => embedded_can::blocking::Can::transmit(p, frame),
            NodePort::Slcan(p) => embedded_can::blocking::Can::transmit(p, frame),
        }
    }

    fn receive(&mut self) -> Result<CanFrame, Error> {
        match self {
            #[cfg(target_os = "linux")]
            NodePort::SocketCan(p) => embedded_can::blocking::Can::receive(p),
            NodePort::Slcan(p) => embedded_can::blocking::Can::receive(p),
        }
    }
}

impl embedded_can::nb::Can for NodePort {
    type Frame = CanFrame;
    type Error = Error;

    fn transmit(&mut self, frame: &CanFrame) -> nb::Result<Option<CanFrame>, Error> {
        match self {
            #[cfg(target_os = "linux")]
            NodePort::SocketCan(p) => embedded_can::nb::Can::transmit(p, frame),
            NodePort::Slcan(p) => embedded_can::nb::Can::transmit(p, frame),
        }
    }

    fn receive(&mut self) -> nb::Result<CanFrame, Error> {
        match self {
            #[cfg(target_os = "linux")]
            NodePort::SocketCan(p) => embedded_can::nb::Can::receive(p),
            NodePort::Slcan(p) => embedded_can::nb::Can::receive(p),
        }
    }
}

impl ReceiveTimeout for NodePort {
    fn receive_timeout(&mut self, timeout: Duration) -> Result<Option<CanFrame>, Error> {
        match self {
            #[cfg(target_os = "linux")]
            NodePort::SocketCan(p) => p.receive_timeout(timeout),
            NodePort::Slcan(p) => p.receive_timeout(timeout),
        }
    }
}
