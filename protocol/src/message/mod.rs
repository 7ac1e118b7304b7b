//! The messages: one payload struct per [`MessageKind`], and the [`Message`] enum.
//!
//! Wire layout: the CAN id carries the kind, the frame payload is the postcard encoding of
//! the payload struct alone (no enum tag). Every integer wider than a byte is encoded as
//! fixed-width little endian (`postcard::fixint::le`, through the `fixint` module so that a format
//! for people shows a number), so every layout has a fixed length
//! ([`MessageKind::wire_len`]) and single-frame layouts are described by `trn.dbc`.

use postcard::experimental::max_size::MaxSize;
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::kind::MessageKind;

/// Budget for any message's postcard encoding: 62 bytes, so that any message fits one
/// CAN FD frame (64 bytes) even with a 2-byte header.
pub const MESSAGE_BUDGET: usize = 62;

/// Longest payload of a segmented ("long") kind: payload + CRC-32 must fit one FD frame.
pub const LONG_PAYLOAD_MAX: usize = crate::frame::FD_MAX - 4;

mod camera;
mod fixint;
mod guard;
mod servo;
mod session;
mod tables;
mod trial;

pub use camera::*;
pub use guard::*;
pub use servo::*;
pub use session::*;
pub use tables::*;
pub use trial::*;

fn finite(x: f32, field: &'static str) -> Result<()> {
    if x.is_finite() {
        Ok(())
    } else {
        Err(Error::OutOfRange(field))
    }
}

fn fine_moves(n: u8) -> Result<()> {
    if n <= FINE_MOVES_MAX || n == FINE_MOVES_POLICY {
        Ok(())
    } else {
        Err(Error::OutOfRange("fine_moves"))
    }
}

fn raw12(raw: u16) -> Result<()> {
    if raw <= RAW_MAX {
        Ok(())
    } else {
        Err(Error::OutOfRange("raw"))
    }
}

fn session_config(m: &SessionConfig) -> Result<()> {
    if m.preset >= PRESET_CODES {
        return Err(Error::OutOfRange("preset"));
    }
    if m.ablation >= ABLATION_CODES {
        return Err(Error::OutOfRange("ablation"));
    }
    if m.law >= LAW_CODES {
        return Err(Error::OutOfRange("law"));
    }
    for (side, f) in [
        (m.image_width, "image_width"),
        (m.image_height, "image_height"),
    ] {
        if side == 0 || side > IMAGE_SIDE_MAX {
            return Err(Error::OutOfRange(f));
        }
    }
    Ok(())
}

macro_rules! messages {
    ($($name:ident = $len:expr;)*) => {
        /// Any protocol message. The CAN id carries the variant ([`MessageKind`]); the
        /// payload is the postcard encoding of the inner struct.
        #[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, MaxSize)]
        #[non_exhaustive]
        pub enum Message {
            $(
                #[doc = concat!("See [`", stringify!($name), "`].")]
                $name($name),
            )*
        }

        impl Message {
            /// The message kind.
            pub const fn kind(&self) -> MessageKind {
                match self {
                    $(Message::$name(_) => MessageKind::$name,)*
                }
            }

            /// Serialises the payload (without kind) into `buf`, returning its length.
            pub(crate) fn encode_payload(&self, buf: &mut [u8]) -> Result<usize> {
                let used = match self {
                    $(Message::$name(m) => postcard::to_slice(m, buf).map_err(|_| Error::Encode)?.len(),)*
                };
                if used != self.kind().wire_len() {
                    return Err(Error::Encode);
                }
                Ok(used)
            }

            /// Decodes and validates a payload of `kind`. The payload must be exactly
            /// [`MessageKind::wire_len`] bytes.
            pub fn decode_payload(kind: MessageKind, payload: &[u8]) -> Result<Message> {
                if payload.len() != kind.wire_len() {
                    return Err(Error::WrongLength { expected: kind.wire_len(), got: payload.len() });
                }
                let msg = match kind {
                    $(MessageKind::$name => {
                        let (m, rest) = postcard::take_from_bytes(payload).map_err(|_| Error::Decode)?;
                        if !rest.is_empty() {
                            return Err(Error::Decode);
                        }
                        Message::$name(m)
                    })*
                };
                msg.validate()?;
                Ok(msg)
            }
        }

        impl MessageKind {
            /// The fixed payload length of this kind, bytes.
            pub const fn wire_len(self) -> usize {
                match self {
                    $(MessageKind::$name => $len,)*
                }
            }
        }

        $(
            const _: () = assert!(<$name as MaxSize>::POSTCARD_MAX_SIZE <= MESSAGE_BUDGET);
            const _: () = assert!($len <= <$name as MaxSize>::POSTCARD_MAX_SIZE);
            // Long kinds carry a CRC-32 and must still fit one FD frame.
            const _: () = assert!($len <= 8 || $len <= LONG_PAYLOAD_MAX);
            impl From<$name> for Message {
                fn from(m: $name) -> Message {
                    Message::$name(m)
                }
            }
        )*
    };
}

messages! {
    Emergency = 1;
    SafeStateEntered = 4;
    PressureCommand = 4;
    ServoStatus = 8;
    GripperCommand = 1;
    GripperStatus = 1;
    CaptureRequest = 3;
    Observation = 39;
    ModeChange = 1;
    SessionConfig = 17;
    ConfirmedSessionConfig = 21;
    GuardRequest = 1;
    GuardNonce = 7;
    SupervisedPressure = 24;
    Stage1Target = 39;
    Stage2Target = 23;
    GraspRequest = 4;
    TrialReport = 15;
    ErrorReport = 6;
    StoreCommand = 5;
    TablesStatus = 21;
    TableWriteBegin = 16;
    TableWriteEnd = 4;
    Heartbeat = 2;
    TableReadRequest = 2;
    TableReadChunk = 50;
    TableWriteChunk = 50;
    TableWriteAck = 6;
}

// The tagged enum encoding also fits the budget.
const _: () = assert!(<Message as MaxSize>::POSTCARD_MAX_SIZE <= MESSAGE_BUDGET);

impl Message {
    /// Checks every documented range: 12-bit raws, finite floats, pressures in [-1, 1],
    /// unused observation slots, stages ≤ 2, non-negative errors.
    pub fn validate(&self) -> Result<()> {
        match self {
            Message::PressureCommand(m) => raw12(m.raw),
            Message::ServoStatus(m) => raw12(m.raw).and_then(|_| raw12(m.applied)),
            Message::SafeStateEntered(m) => raw12(m.held_raw),
            Message::Observation(m) => {
                for p in &m.points {
                    finite(p.x, "points.x")?;
                    finite(p.y, "points.y")?;
                }
                if m.what == CaptureKind::GripperCentre && m.points[2..] != [PixelPoint::UNUSED; 2]
                {
                    return Err(Error::OutOfRange("points[2..]"));
                }
                Ok(())
            }
            Message::Stage1Target(m) => {
                fine_moves(m.fine_moves)?;
                m.v.iter().try_for_each(|&x| finite(x, "v"))
            }
            Message::Stage2Target(m) => {
                fine_moves(m.fine_moves)?;
                m.c.iter().try_for_each(|&x| finite(x, "c"))
            }
            Message::SupervisedPressure(m) => m.p.iter().try_for_each(|&x| {
                if (-1.0..=1.0).contains(&x) {
                    Ok(())
                } else {
                    Err(Error::OutOfRange("p"))
                }
            }),
            Message::TrialReport(m) => {
                if m.stage > 2 {
                    return Err(Error::OutOfRange("stage"));
                }
                for (x, f) in [
                    (m.coarse_error_px, "coarse_error_px"),
                    (m.final_error_px, "final_error_px"),
                ] {
                    if !(x.is_finite() && x >= 0.0) {
                        return Err(Error::OutOfRange(f));
                    }
                }
                Ok(())
            }
            Message::SessionConfig(m) => session_config(m),
            Message::ConfirmedSessionConfig(m) => session_config(&m.config),
            Message::Emergency(_)
            | Message::GripperCommand(_)
            | Message::GripperStatus(_)
            | Message::CaptureRequest(_)
            | Message::ModeChange(_)
            | Message::GraspRequest(_)
            | Message::ErrorReport(_)
            | Message::Heartbeat(_)
            | Message::GuardRequest(_)
            | Message::GuardNonce(_)
            | Message::StoreCommand(_)
            | Message::TablesStatus(_)
            | Message::TableWriteBegin(_)
            | Message::TableWriteEnd(_)
            | Message::TableReadRequest(_)
            | Message::TableReadChunk(_)
            | Message::TableWriteChunk(_)
            | Message::TableWriteAck(_) => Ok(()),
        }
    }
}

impl MessageKind {
    /// Whether this kind fits one classical frame (≤ 8 bytes) and is sent unsegmented.
    pub const fn is_single_frame(self) -> bool {
        self.wire_len() <= 8
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn pressure_raw_conversion() {
        assert_eq!(pressure_to_raw(-2.0), Ok(0));
        assert_eq!(pressure_to_raw(2.0), Ok(4095));
        assert_eq!(pressure_to_raw(f32::NAN), Err(Error::OutOfRange("p")));
        for raw in 0..=RAW_MAX {
            assert_eq!(pressure_to_raw(raw_to_pressure(raw)), Ok(raw));
        }
    }

    #[test]
    fn observation_vectors_follow_the_architecture_order() {
        let pt = |x: f32| PixelPoint::valid(x, x + 0.5);
        let o = Observation::lights(1, [pt(1.0), pt(2.0), pt(3.0), pt(4.0)]);
        assert_eq!(o.v(), Some([1.0, 1.5, 2.0, 2.5, 3.0, 3.5, 4.0, 4.5]));
        assert_eq!(o.c(), None);
        assert!(o.all_valid());
        let mut c = Observation::centre(2, pt(5.0), pt(6.0));
        assert_eq!(c.c(), Some([5.0, 5.5, 6.0, 6.5]));
        assert_eq!(c.used_points().len(), 2);
        assert!(c.all_valid());
        c.points[1].status = PointStatus::Occluded;
        assert!(!c.all_valid());
        assert_eq!(c.v(), None);
    }

    /// A point's status is one byte, its index (SPEC.md 3): `Estimated` (4) is the last; a
    /// receiver refuses 5.
    #[test]
    fn point_status_bytes_are_the_spec_table() {
        let statuses = [
            PointStatus::Valid,
            PointStatus::OutOfView,
            PointStatus::Occluded,
            PointStatus::NotDetected,
            PointStatus::Estimated,
        ];
        let pt = |status| PixelPoint {
            x: 1.0,
            y: 2.0,
            status,
        };
        for (byte, status) in statuses.into_iter().enumerate() {
            assert_eq!(status as u8, byte as u8);
            let msg: Message = Observation::lights(3, [pt(status); 4]).into();
            let mut buf = [0u8; 64];
            let n = msg.encode_payload(&mut buf).unwrap();
            // seq (2), what (1), then x, y, status per point
            assert_eq!(buf[3 + 8], byte as u8);
            assert_eq!(Message::decode_payload(msg.kind(), &buf[..n]), Ok(msg));
        }
        let msg: Message = Observation::lights(3, [pt(PointStatus::Valid); 4]).into();
        let mut buf = [0u8; 64];
        let n = msg.encode_payload(&mut buf).unwrap();
        buf[3 + 8] = 5;
        assert_eq!(
            Message::decode_payload(msg.kind(), &buf[..n]),
            Err(Error::Decode)
        );
    }
}
