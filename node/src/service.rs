//! One turn of a controller node's loop on an `embedded-can` port: the seam every build
//! shares. The host's thread and `controller-node` process and the firmware all call
//! [`ControllerNode::service`]; only the port (in-process bus, SocketCAN, SLCAN over a UART)
//! and the clock differ.

use embedded_can::nb::Can;
use trn_controller::Control;
use trn_protocol::{CanFrame, Encoder, Reassembler};

use crate::node::ControllerNode;

/// A transport error of the port (the node's state is unchanged).
pub type PortError = trn_protocol::Error;

fn transmit<P>(port: &mut P, f: &CanFrame, err: &mut Option<PortError>)
where
    P: Can<Frame = CanFrame, Error = PortError>,
{
    if err.is_none() {
        if let Err(e) = nb::block!(port.transmit(f)) {
            *err = Some(e);
        }
    }
}

impl ControllerNode {
    /// Handles every frame the port has received, then the node's timers (heartbeat,
    /// timeouts), transmitting what they produce. Malformed, lost or corrupt frames are
    /// dropped and counted ([`crate::NodeStats::frame_errors`]); a transport error is
    /// returned.
    pub fn service<P, const SLOTS: usize, C: Control + ?Sized>(
        &mut self,
        ctrl: &mut C,
        rx: &mut Reassembler<SLOTS>,
        enc: &mut Encoder,
        port: &mut P,
        now_ms: u32,
    ) -> Result<(), PortError>
    where
        P: Can<Frame = CanFrame, Error = PortError>,
    {
        let mut err = None;
        loop {
            let frame = match port.receive() {
                Ok(f) => f,
                Err(nb::Error::WouldBlock) => break,
                Err(nb::Error::Other(e)) => return Err(e),
            };
            let handled = self.on_frame(ctrl, rx, enc, &frame, now_ms, &mut |f| {
                transmit(port, f, &mut err)
            });
            if handled.is_err() {
                self.count_frame_error();
            }
            if let Some(e) = err.take() {
                return Err(e);
            }
            if self.idle_requested() {
                return Ok(());
            }
        }
        // an encoding failure here is a bug of the node's own messages: counted, not fatal
        if self
            .poll_frames(ctrl, enc, now_ms, &mut |f| transmit(port, f, &mut err))
            .is_err()
        {
            self.count_frame_error();
        }
        err.map_or(Ok(()), Err)
    }
}
