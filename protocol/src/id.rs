//! 11-bit CAN identifiers: `kind << 4 | node`.
//!
//! The upper 7 bits are the [`MessageKind`] code, which is also the arbitration
//! priority (lower code wins), the lower 4 bits the [`NodeId`] code. For *commands*
//! the node is the destination, for *reports* the source (see [`MessageKind::is_command`]).
//! The kinds themselves are `kind.rs`'s; this module owns decoding a kind's code (checked)
//! and which nodes each kind allows.

use crate::error::{Error, Result};
use crate::kind::MessageKind;
use crate::node::NodeId;

/// Highest 11-bit standard id.
pub const MAX_STANDARD_ID: u16 = 0x7FF;

/// [`MessageKind::from_code`] from the table of kinds (`kind.rs`).
macro_rules! decode_kinds {
    ($($(#[$m:meta])* $name:ident = $code:expr, $cmd:expr;)*) => {
        impl MessageKind {
            /// The kind with this 7-bit code.
            pub const fn from_code(code: u8) -> Result<MessageKind> {
                match code {
                    $($code => Ok(MessageKind::$name),)*
                    _ => Err(Error::UnknownKind(code)),
                }
            }
        }
    };
}

crate::kind::with_kinds!(decode_kinds);

impl MessageKind {
    /// Whether `node` may appear in the node field of this kind.
    pub const fn allows(self, node: NodeId) -> bool {
        use MessageKind as K;
        match self {
            K::PressureCommand | K::ServoStatus => matches!(node, NodeId::Servo(_)),
            K::CaptureRequest | K::Observation => matches!(node, NodeId::CameraProcessor),
            K::GripperCommand | K::GripperStatus => matches!(node, NodeId::Gripper),
            K::SupervisedPressure
            | K::Stage1Target
            | K::Stage2Target
            | K::GraspRequest
            | K::TrialReport
            | K::ConfirmedSessionConfig
            | K::GuardRequest
            | K::GuardNonce
            | K::StoreCommand
            | K::TablesStatus
            | K::TableWriteBegin
            | K::TableWriteEnd
            | K::TableReadRequest
            | K::TableReadChunk
            | K::TableWriteChunk
            | K::TableWriteAck => matches!(node, NodeId::Controller),
            K::ModeChange | K::SessionConfig => {
                matches!(node, NodeId::Controller | NodeId::Broadcast)
            }
            K::Emergency | K::SafeStateEntered | K::ErrorReport | K::Heartbeat => {
                !matches!(node, NodeId::Broadcast)
            }
        }
    }
}

/// A decoded 11-bit identifier.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct CanId {
    /// Message kind (upper 7 bits).
    pub kind: MessageKind,
    /// Node (lower 4 bits): destination of commands, source of reports.
    pub node: NodeId,
}

impl CanId {
    /// Builds an id, checking that the kind allows the node.
    pub const fn new(kind: MessageKind, node: NodeId) -> Result<CanId> {
        if kind.allows(node) {
            Ok(CanId { kind, node })
        } else {
            Err(Error::NodeNotAllowed {
                kind,
                node: node.code(),
            })
        }
    }

    /// The raw 11-bit id.
    pub const fn raw(self) -> u16 {
        ((self.kind.code() as u16) << 4) | self.node.code() as u16
    }

    /// Decodes a raw id (must be ≤ 0x7FF, a known kind and an allowed node).
    pub fn from_raw(raw: u16) -> Result<CanId> {
        if raw > MAX_STANDARD_ID {
            return Err(Error::InvalidId(raw as u32));
        }
        let kind = MessageKind::from_code((raw >> 4) as u8)?;
        let node = NodeId::from_code((raw & 0xF) as u8)?;
        CanId::new(kind, node)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_valid_id_round_trips_and_every_other_is_rejected() {
        let mut valid = 0;
        for raw in 0..=0x800u16 {
            if let Ok(id) = CanId::from_raw(raw) {
                assert_eq!(id.raw(), raw);
                valid += 1;
            }
        }
        // servo kinds 2 x 5 + camera 2 + gripper 2 + controller-only 5 + guard 3 + tables 8
        // + mode and session config 2 x 2 + any-node 4 x 9
        assert_eq!(valid, 10 + 2 + 2 + 5 + 3 + 8 + 2 * 2 + 4 * 9);
        assert_eq!(CanId::from_raw(0x800), Err(Error::InvalidId(0x800)));
    }

    /// Heartbeats lose arbitration to every kind but the bulk transfer of tables, which
    /// yields to them: a table transfer never delays a heartbeat (and so never trips a
    /// drive's supervision).
    #[test]
    fn heartbeat_ids_are_canopen_like_and_lowest_priority_but_the_bulk_transfer() {
        let id = CanId::new(MessageKind::Heartbeat, NodeId::Controller).unwrap();
        assert_eq!(id.raw(), 0x701);
        let bulk = [
            MessageKind::TableReadRequest,
            MessageKind::TableReadChunk,
            MessageKind::TableWriteChunk,
            MessageKind::TableWriteAck,
        ];
        let max = MessageKind::ALL
            .iter()
            .filter(|k| !bulk.contains(k))
            .map(|k| k.code())
            .max()
            .unwrap();
        assert_eq!(max, MessageKind::Heartbeat.code());
        assert!(bulk
            .iter()
            .all(|k| k.code() > MessageKind::Heartbeat.code()));
    }

    #[test]
    fn kinds_reject_wrong_nodes() {
        assert!(CanId::new(MessageKind::PressureCommand, NodeId::Gripper).is_err());
        assert!(CanId::new(MessageKind::Heartbeat, NodeId::Broadcast).is_err());
        assert!(CanId::new(MessageKind::ModeChange, NodeId::Broadcast).is_ok());
    }
}
