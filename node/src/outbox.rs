//! The node's bounded outbox and its framing onto the bus.

use trn_protocol::{CanFrame, Encoder, Envelope, ErrorReport, Message, NodeId};

use crate::codes;

/// Capacity of an [`Outbox`]: the largest burst one event can produce (5 pressure
/// commands, a capture request, two trial reports, a gripper command, an error, a heartbeat).
pub const OUTBOX: usize = 16;

/// Messages to send, each with its CAN node field (destination for commands, this node as
/// source for reports).
pub type Outbox = heapless::Vec<Envelope, OUTBOX>;

/// Frame-level errors (the frame is dropped; nothing else changes).
pub type FrameError = trn_protocol::Error;

/// Appends a message. On overflow (a bug: [`OUTBOX`] is sized for the largest burst) the
/// last entry is replaced by an `OUTBOX_FULL` report, so the loss is visible on the bus.
pub(crate) fn push(out: &mut Outbox, node: NodeId, msg: Message) {
    if out.push(Envelope::new(node, msg)).is_err() {
        if let Some(last) = out.last_mut() {
            let report = ErrorReport {
                code: codes::OUTBOX_FULL,
                detail: 1,
            };
            *last = Envelope::new(NodeId::Controller, report.into());
        }
    }
}

/// Encodes every message of `out` and passes its frames to `tx`.
pub fn send(
    enc: &mut Encoder,
    out: &Outbox,
    tx: &mut impl FnMut(&CanFrame),
) -> Result<(), FrameError> {
    for env in out {
        for f in &enc.encode(env)? {
            tx(f);
        }
    }
    Ok(())
}
