//! [`Envelope`]: a message with its addressing, and [`BusMode`].

use crate::error::Result;
use crate::id::CanId;
use crate::message::Message;
use crate::node::NodeId;

/// A message with the node of its CAN id: the destination for commands, the source for
/// reports (see [`crate::MessageKind::is_command`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Envelope {
    /// Destination (commands) or source (reports).
    pub node: NodeId,
    /// The message.
    pub msg: Message,
}

impl Envelope {
    /// Pairs a message with a node (not validated until encoding; see [`Envelope::can_id`]).
    pub const fn new(node: NodeId, msg: Message) -> Envelope {
        Envelope { node, msg }
    }

    /// The CAN id, `Err(NodeNotAllowed)` if the kind may not use this node.
    pub fn can_id(&self) -> Result<CanId> {
        CanId::new(self.msg.kind(), self.node)
    }
}

/// Which frames the bus carries.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub enum BusMode {
    /// CAN 2.0: classical frames only; messages longer than 8 bytes are segmented.
    #[default]
    Classic,
    /// CAN FD: every message is sent whole in one FD frame.
    Fd,
}
