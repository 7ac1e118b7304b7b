//! Protocol versions on the wire (SPEC.md, "Versions"): what version 4 added to version 3,
//! so that a node of either version can tell what the other understands.
//!
//! Version 4 is additive: every frame of version 3 means the same in version 4. It adds
//! kinds ([`MessageKind::since`]), error codes 0x010B..=0x010D, `CONFIG_REJECTED` detail 4 and
//! the point status `Estimated`; a version-3 receiver rejects each of them as an unknown
//! kind or a decode error and answers nothing. A controller announces version 4 by
//! answering `StoreCommand{Status}` with `TablesStatus{Status}`; one that stays alive
//! (heartbeats) and never answers it speaks version 3.

use crate::kind::MessageKind;
use crate::message::{Message, PointStatus};

/// A version of this protocol that a node may speak.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum ProtocolVersion {
    /// Version 3: version 2 and `SessionConfig`.
    V3 = 3,
    /// Version 4: version 3, the guard of learned tables, the tables over the bus and the
    /// point status `Estimated`.
    V4 = 4,
}

impl ProtocolVersion {
    /// The version this crate implements.
    pub const CURRENT: ProtocolVersion = ProtocolVersion::V4;

    /// Its number (3, 4).
    pub const fn number(self) -> u8 {
        self as u8
    }

    /// True when a node of this version understands `msg`: its kind, and for an
    /// `Observation` every point's status, for an `ErrorReport` its code, exist in it.
    pub fn understands(self, msg: &Message) -> bool {
        if msg.kind().since() > self {
            return false;
        }
        match msg {
            Message::Observation(o) => {
                self >= ProtocolVersion::V4
                    || o.points.iter().all(|p| p.status != PointStatus::Estimated)
            }
            Message::ErrorReport(e) => {
                self >= ProtocolVersion::V4 || !V4_ERROR_CODES.contains(&e.code)
            }
            _ => true,
        }
    }
}

impl core::fmt::Display for ProtocolVersion {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "v{}", self.number())
    }
}

/// The controller's error codes added in version 4: `GUARD_REFUSED`, `SESSION_REQUIRED`,
/// `TABLES_FAILED`.
pub const V4_ERROR_CODES: core::ops::RangeInclusive<u16> = 0x010B..=0x010D;

impl MessageKind {
    /// The first version with this kind: version 4 for the guard's (0x1A..=0x1C) and the
    /// tables' (0x38..=0x3B, 0x78..=0x7B) kinds, version 3 for every other.
    pub const fn since(self) -> ProtocolVersion {
        use MessageKind as K;
        match self {
            K::ConfirmedSessionConfig
            | K::GuardRequest
            | K::GuardNonce
            | K::StoreCommand
            | K::TablesStatus
            | K::TableWriteBegin
            | K::TableWriteEnd
            | K::TableReadRequest
            | K::TableReadChunk
            | K::TableWriteChunk
            | K::TableWriteAck => ProtocolVersion::V4,
            _ => ProtocolVersion::V3,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_v4_kinds_are_the_guards_and_the_tables_codes() {
        let v4: Vec<u8> = MessageKind::ALL
            .iter()
            .filter(|k| k.since() == ProtocolVersion::V4)
            .map(|k| k.code())
            .collect();
        assert_eq!(
            v4,
            [0x1A, 0x1B, 0x1C, 0x38, 0x39, 0x3A, 0x3B, 0x78, 0x79, 0x7A, 0x7B]
        );
    }

    #[test]
    fn v3_does_not_understand_estimated_points_or_v4_error_codes() {
        use crate::{CaptureKind, ErrorReport, Observation, PixelPoint};
        let mut o = Observation {
            seq: 1,
            what: CaptureKind::GripperLights,
            points: [PixelPoint::UNUSED; 4],
        };
        assert!(ProtocolVersion::V3.understands(&o.into()));
        o.points[2].status = PointStatus::Estimated;
        assert!(!ProtocolVersion::V3.understands(&o.into()));
        assert!(ProtocolVersion::V4.understands(&o.into()));
        let e = |code| Message::from(ErrorReport { code, detail: 0 });
        assert!(ProtocolVersion::V3.understands(&e(0x010A)));
        assert!(!ProtocolVersion::V3.understands(&e(0x010B)));
        assert!(!ProtocolVersion::V3.understands(&e(0x010D)));
    }
}
