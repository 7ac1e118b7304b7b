//! One turn of a controller node's loop on any `embedded-can` port: the seam every build
//! shares. The host's thread and `controller-node` process, the QEMU firmware and the board
//! images all call [`ControllerNode::service`]; only the port (in-process bus, SocketCAN,
//! SLCAN over a UART, a HAL's CAN driver) and the clock differ.
//!
//! The port's frames are converted to and from the protocol's [`CanFrame`] here
//! ([`to_protocol`], [`from_protocol`]), so a HAL's driver plugs in with its own frame and
//! error types.

use core::any::Any;

use embedded_can::nb::Can;
use embedded_can::{Frame, Id, StandardId};
use trn_controller::Control;
use trn_protocol::{CanFrame, Encoder, Reassembler, CLASSIC_MAX};

use crate::node::ControllerNode;

/// A port's received frame as the protocol's frame; `None` for what the protocol does not
/// use (remote frames, extended ids) or cannot hold (more than 64 bytes).
///
/// The protocol's own [`CanFrame`] passes unchanged. Any other frame type is seen through
/// [`embedded_can::Frame`], which has no FD flag: a frame of more than 8 bytes is taken as
/// CAN FD, one of at most 8 as classical. Nothing is lost by that: the only FD frames of at
/// most 8 bytes the protocol sends are single-frame kinds, whose payload is read the same
/// either way (protocol/SPEC.md 4.1; a long kind's FD frame is at least 12 bytes, 4.2).
pub fn to_protocol<F: Frame + 'static>(frame: &F) -> Option<CanFrame> {
    if let Some(own) = (frame as &dyn Any).downcast_ref::<CanFrame>() {
        return Some(*own);
    }
    if frame.is_remote_frame() {
        return None;
    }
    let Id::Standard(id) = frame.id() else {
        return None;
    };
    let data = frame.data();
    CanFrame::new_checked(id.as_raw(), data, data.len() > CLASSIC_MAX).ok()
}

/// The protocol's frame as the port's frame type; `None` when that type cannot hold it
/// (an FD frame of more than 8 bytes on a classical-only frame type).
///
/// The protocol's own [`CanFrame`] passes unchanged (its FD flag kept). Any other type is
/// built with [`embedded_can::Frame::new`]: whether a frame of at most 8 bytes goes out as
/// classical CAN or CAN FD is that type's choice (a classical HAL sends classical frames,
/// which every node of an FD bus receives; a frame type whose `new` always builds FD frames
/// belongs on an FD bus only).
pub fn from_protocol<F: Frame + 'static>(frame: &CanFrame) -> Option<F> {
    let mut out: Option<F> = None;
    if let Some(own) = (&mut out as &mut dyn Any).downcast_mut::<Option<CanFrame>>() {
        *own = Some(*frame);
        return out;
    }
    F::new(StandardId::new(frame.raw_id())?, frame.payload())
}

/// What a transmission came to: a port error stops the turn, a frame the port's frame
/// type cannot hold is dropped and counted.
struct Transmit<E> {
    error: Option<E>,
    unrepresentable: u32,
}

impl<E> Transmit<E> {
    fn new() -> Self {
        Transmit {
            error: None,
            unrepresentable: 0,
        }
    }

    /// Sends `frame` on `port`, waiting while its transmit buffers are full. A frame the
    /// port hands back (a lower-priority frame it replaced with this one) is sent again.
    fn send<P>(&mut self, port: &mut P, frame: &CanFrame)
    where
        P: Can<Error = E>,
        P::Frame: 'static,
    {
        if self.error.is_some() {
            return;
        }
        let Some(mut next) = from_protocol::<P::Frame>(frame) else {
            self.unrepresentable += 1;
            return;
        };
        loop {
            match nb::block!(port.transmit(&next)) {
                Ok(None) => return,
                Ok(Some(replaced)) => next = replaced,
                Err(e) => {
                    self.error = Some(e);
                    return;
                }
            }
        }
    }
}

impl ControllerNode {
    /// Handles every frame the port has received, then the node's timers (heartbeat,
    /// timeouts), transmitting what they produce.
    ///
    /// The port is any `embedded-can` port: its frames are converted to the protocol's
    /// ([`to_protocol`], [`from_protocol`]). Malformed, lost or corrupt frames, frames the
    /// protocol does not use (remote, extended id) and frames the port's frame type cannot
    /// hold are dropped and counted ([`crate::NodeStats::frame_errors`]). A transport error
    /// of the port is returned as the port's own error; the frames received before it have
    /// been handled.
    pub fn service<P, const SLOTS: usize, C: Control + ?Sized>(
        &mut self,
        ctrl: &mut C,
        rx: &mut Reassembler<SLOTS>,
        enc: &mut Encoder,
        port: &mut P,
        now_ms: u32,
    ) -> Result<(), P::Error>
    where
        P: Can,
        P::Frame: Frame + 'static,
        P::Error: embedded_can::Error,
    {
        let mut tx = Transmit::new();
        let result = self.service_frames(ctrl, rx, enc, port, now_ms, &mut tx);
        for _ in 0..tx.unrepresentable {
            self.count_frame_error();
        }
        result
    }

    fn service_frames<P, const SLOTS: usize, C: Control + ?Sized>(
        &mut self,
        ctrl: &mut C,
        rx: &mut Reassembler<SLOTS>,
        enc: &mut Encoder,
        port: &mut P,
        now_ms: u32,
        tx: &mut Transmit<P::Error>,
    ) -> Result<(), P::Error>
    where
        P: Can,
        P::Frame: Frame + 'static,
    {
        loop {
            let received = match port.receive() {
                Ok(f) => f,
                Err(nb::Error::WouldBlock) => break,
                Err(nb::Error::Other(e)) => return Err(e),
            };
            let Some(frame) = to_protocol(&received) else {
                self.count_frame_error();
                continue;
            };
            let handled = self.on_frame(ctrl, rx, enc, &frame, now_ms, &mut |f| tx.send(port, f));
            if handled.is_err() {
                self.count_frame_error();
            }
            if let Some(e) = tx.error.take() {
                return Err(e);
            }
            if self.idle_requested() {
                return Ok(());
            }
        }
        // an encoding failure here is a bug of the node's own messages: counted, not fatal
        if self
            .poll_frames(ctrl, enc, now_ms, &mut |f| tx.send(port, f))
            .is_err()
        {
            self.count_frame_error();
        }
        tx.error.take().map_or(Ok(()), Err)
    }
}
