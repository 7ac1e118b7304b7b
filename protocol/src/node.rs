//! Node identifiers: the 4-bit node field of every CAN id.

use crate::error::{Error, Result};

/// Number of servo drive units (joints 0..=4).
pub const JOINTS: u8 = 5;

/// A joint index 0..=4 (the paper's joints 1..5), validated on construction.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Joint(u8);

impl Joint {
    /// A joint index, `Err(InvalidNode)` unless `index < 5`.
    pub const fn new(index: u8) -> Result<Joint> {
        if index < JOINTS {
            Ok(Joint(index))
        } else {
            Err(Error::InvalidNode(index))
        }
    }

    /// The joint index 0..=4.
    pub const fn index(self) -> u8 {
        self.0
    }

    /// All five joints in order.
    pub const ALL: [Joint; 5] = [Joint(0), Joint(1), Joint(2), Joint(3), Joint(4)];
}

/// A node on the bus. Its 4-bit code is the low nibble of every CAN id.
///
/// | code | node |
/// |---|---|
/// | 0 | reserved |
/// | 1 | `Controller` |
/// | 2..=6 | `Servo(joint 0..=4)` |
/// | 7 | reserved |
/// | 8 | `CameraProcessor` |
/// | 9 | reserved (second camera processor) |
/// | 10 | `Gripper` |
/// | 11 | `Runner` (experiment runner) |
/// | 12..=14 | reserved |
/// | 15 | `Broadcast` |
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum NodeId {
    /// The TRN controller.
    Controller,
    /// The servo drive unit of one joint.
    Servo(Joint),
    /// The camera processor (both cameras).
    CameraProcessor,
    /// The gripper.
    Gripper,
    /// The experiment runner (targets, scoring).
    Runner,
    /// Every node (only where a kind allows it).
    Broadcast,
}

impl NodeId {
    /// The 4-bit node code.
    pub const fn code(self) -> u8 {
        match self {
            NodeId::Controller => 1,
            NodeId::Servo(j) => 2 + j.0,
            NodeId::CameraProcessor => 8,
            NodeId::Gripper => 10,
            NodeId::Runner => 11,
            NodeId::Broadcast => 15,
        }
    }

    /// The node with this 4-bit code; `Err(InvalidNode)` for reserved codes.
    pub const fn from_code(code: u8) -> Result<NodeId> {
        match code {
            1 => Ok(NodeId::Controller),
            2..=6 => Ok(NodeId::Servo(Joint(code - 2))),
            8 => Ok(NodeId::CameraProcessor),
            10 => Ok(NodeId::Gripper),
            11 => Ok(NodeId::Runner),
            15 => Ok(NodeId::Broadcast),
            _ => Err(Error::InvalidNode(code)),
        }
    }

    /// The servo node of joint `index`.
    pub fn servo(index: u8) -> Result<NodeId> {
        Joint::new(index).map(NodeId::Servo)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn codes_round_trip_and_reserved_codes_fail() {
        let mut valid = 0;
        for code in 0..16u8 {
            match NodeId::from_code(code) {
                Ok(n) => {
                    assert_eq!(n.code(), code);
                    valid += 1;
                }
                Err(e) => assert_eq!(e, Error::InvalidNode(code)),
            }
        }
        assert_eq!(valid, 10);
        assert_eq!(NodeId::servo(0).unwrap().code(), 2);
        assert_eq!(NodeId::servo(4).unwrap().code(), 6);
        assert!(NodeId::servo(5).is_err());
    }
}
