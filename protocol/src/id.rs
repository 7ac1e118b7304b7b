//! 11-bit CAN identifiers: `kind << 4 | node`.
//!
//! The upper 7 bits are the [`MessageKind`] code, which is also the arbitration
//! priority (lower code wins), the lower 4 bits the [`NodeId`] code. For *commands*
//! the node is the destination, for *reports* the source (see [`MessageKind::is_command`]).

use crate::error::{Error, Result};
use crate::node::NodeId;

/// Highest 11-bit standard id.
pub const MAX_STANDARD_ID: u16 = 0x7FF;

macro_rules! kinds {
    ($($(#[$m:meta])* $name:ident = $code:expr, $cmd:expr;)*) => {
        /// The message kind: the upper 7 bits of the CAN id (lower = higher priority).
        #[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
        #[repr(u8)]
        pub enum MessageKind {
            $($(#[$m])* $name = $code,)*
        }

        impl MessageKind {
            /// Every kind, in priority order.
            pub const ALL: &'static [MessageKind] = &[$(MessageKind::$name,)*];

            /// The kind with this 7-bit code.
            pub const fn from_code(code: u8) -> Result<MessageKind> {
                match code {
                    $($code => Ok(MessageKind::$name),)*
                    _ => Err(Error::UnknownKind(code)),
                }
            }

            /// True for commands (node field = destination), false for reports
            /// (node field = source).
            pub const fn is_command(self) -> bool {
                match self {
                    $(MessageKind::$name => $cmd,)*
                }
            }
        }
    };
}

kinds! {
    /// Emergency stop raised by any node (report).
    Emergency = 0x01, false;
    /// A node entered its safe state (report).
    SafeStateEntered = 0x02, false;
    /// Pressure command to one servo drive (command).
    PressureCommand = 0x08, true;
    /// Pressure and state feedback of one servo drive (report).
    ServoStatus = 0x09, false;
    /// Open/close the gripper (command).
    GripperCommand = 0x0A, true;
    /// Gripper state (report).
    GripperStatus = 0x0B, false;
    /// Ask the camera processor for an observation (command).
    CaptureRequest = 0x10, true;
    /// Camera observation (report).
    Observation = 0x11, false;
    /// Change the operating mode (command; node = controller or broadcast).
    ModeChange = 0x18, true;
    /// The session's run parameters (command; node = controller, or broadcast for the echo).
    SessionConfig = 0x19, true;
    /// Supervised pressure announcement for a priming trial (command to the controller).
    SupervisedPressure = 0x20, true;
    /// Stage-1 target (8-D lights) for a new trial (command to the controller).
    Stage1Target = 0x21, true;
    /// Stage-2 target (4-D centre) for a trial (command to the controller).
    Stage2Target = 0x22, true;
    /// Start a grasp trial (command to the controller).
    GraspRequest = 0x23, true;
    /// Result of a trial (report by the controller).
    TrialReport = 0x28, false;
    /// Error report (report).
    ErrorReport = 0x30, false;
    /// Heartbeat (report), `0x700 | node` as in CANopen.
    Heartbeat = 0x70, false;
}

impl MessageKind {
    /// The 7-bit code.
    pub const fn code(self) -> u8 {
        self as u8
    }

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
            | K::TrialReport => matches!(node, NodeId::Controller),
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
        // servo kinds 2 x 5 + camera 2 + gripper 2 + controller-only 5 + mode and session
        // config 2 x 2 + any-node 4 x 9
        assert_eq!(valid, 10 + 2 + 2 + 5 + 2 * 2 + 4 * 9);
        assert_eq!(CanId::from_raw(0x800), Err(Error::InvalidId(0x800)));
    }

    #[test]
    fn heartbeat_ids_are_canopen_like_and_lowest_priority() {
        let id = CanId::new(MessageKind::Heartbeat, NodeId::Controller).unwrap();
        assert_eq!(id.raw(), 0x701);
        let max = MessageKind::ALL.iter().map(|k| k.code()).max().unwrap();
        assert_eq!(max, MessageKind::Heartbeat.code());
    }

    #[test]
    fn kinds_reject_wrong_nodes() {
        assert!(CanId::new(MessageKind::PressureCommand, NodeId::Gripper).is_err());
        assert!(CanId::new(MessageKind::Heartbeat, NodeId::Broadcast).is_err());
        assert!(CanId::new(MessageKind::ModeChange, NodeId::Broadcast).is_ok());
    }
}
