//! The messages: one payload struct per [`MessageKind`], and the [`Message`] enum.
//!
//! Wire layout: the CAN id carries the kind, the frame payload is the postcard encoding of
//! the payload struct alone (no enum tag). Every integer wider than a byte is encoded as
//! fixed-width little endian (`postcard::fixint::le`), so every layout has a fixed length
//! ([`MessageKind::wire_len`]) and single-frame layouts are described by `trn.dbc`.

use postcard::experimental::max_size::MaxSize;
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};
use crate::id::MessageKind;

/// Largest 12-bit servo command / feedback value.
pub const RAW_MAX: u16 = 4095;

/// Budget for any message's postcard encoding: 62 bytes, so that any message fits one
/// CAN FD frame (64 bytes) even with a 2-byte header.
pub const MESSAGE_BUDGET: usize = 62;

/// Longest payload of a segmented ("long") kind: payload + CRC-32 must fit one FD frame.
pub const LONG_PAYLOAD_MAX: usize = crate::frame::FD_MAX - 4;

/// Safe-state behaviour of a servo drive as reported in [`ServoStatus`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, MaxSize)]
pub enum SafeState {
    /// Following pressure commands.
    Normal,
    /// Heartbeat lost: holding the last commanded pressure.
    HoldLast,
    /// Heartbeat lost: vented (both chambers to ambient, zero difference).
    Vented,
}

/// What the camera processor is asked to capture.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, MaxSize)]
pub enum CaptureKind {
    /// The two gripper lights p, q in both cameras (8-D stage-1 input).
    GripperLights,
    /// The gripper centre light in both cameras (4-D stage-2 input).
    GripperCentre,
}

/// Validity of one observed light.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, MaxSize)]
pub enum PointStatus {
    /// Detected; `x`, `y` are valid pixel coordinates.
    Valid,
    /// The light projects outside the image.
    OutOfView,
    /// The light is hidden behind the arm or an object.
    Occluded,
    /// Not detected for another reason (or an unused slot).
    NotDetected,
}

/// Operating state announced in heartbeats.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, MaxSize)]
pub enum NodeState {
    /// Starting up, not yet operational.
    Booting,
    /// Operating normally.
    Operational,
    /// In its safe state.
    SafeState,
    /// Faulted.
    Fault,
}

/// Operating mode of the experiment.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, MaxSize)]
pub enum Mode {
    /// No trials running.
    Idle,
    /// Supervised priming trials.
    Priming,
    /// Unsupervised training trials.
    Training,
    /// Mature network: no learning.
    Mature,
}

/// Why an emergency was raised.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, MaxSize)]
pub enum EmergencyReason {
    /// Operator pressed stop.
    Operator,
    /// A node lost the controller heartbeat.
    HeartbeatLost,
    /// Pressure or actuator fault.
    PressureFault,
    /// The controller itself faulted.
    ControllerFault,
    /// Bus errors (bus-off, persistent protocol errors).
    BusFault,
}

/// Why a node entered its safe state.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, MaxSize)]
pub enum SafeStateReason {
    /// The controller heartbeat was not seen within the timeout.
    HeartbeatLost,
    /// An emergency was received.
    Emergency,
    /// Commanded (e.g. by the runner at the end of an experiment).
    Commanded,
}

/// What a servo drive does when it loses the controller heartbeat.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, MaxSize)]
pub enum SafeStateAction {
    /// Hold the last commanded pressure.
    HoldLast,
    /// Vent: go to zero pressure difference.
    Vent,
}

/// One light in one camera. Pixels, origin top-left.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, MaxSize)]
pub struct PixelPoint {
    /// Column, pixels.
    pub x: f32,
    /// Row, pixels.
    pub y: f32,
    /// Validity of this point.
    pub status: PointStatus,
}

impl PixelPoint {
    /// An unused slot: `(0, 0, NotDetected)`.
    pub const UNUSED: PixelPoint = PixelPoint {
        x: 0.0,
        y: 0.0,
        status: PointStatus::NotDetected,
    };

    /// A valid point.
    pub const fn valid(x: f32, y: f32) -> PixelPoint {
        PixelPoint {
            x,
            y,
            status: PointStatus::Valid,
        }
    }
}

/// Pressure command to one servo drive (node = destination servo).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, MaxSize)]
pub struct PressureCommand {
    /// Sequence number (wraps).
    #[serde(with = "postcard::fixint::le")]
    pub seq: u16,
    /// 12-bit command 0..=4095: `raw = round((p + 1) / 2 * 4095)`.
    #[serde(with = "postcard::fixint::le")]
    pub raw: u16,
}

/// Servo drive feedback (node = source servo).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, MaxSize)]
pub struct ServoStatus {
    /// Sequence number of the last command applied.
    #[serde(with = "postcard::fixint::le")]
    pub seq: u16,
    /// Measured pressure difference, 12-bit 0..=4095 (same scale as the command).
    #[serde(with = "postcard::fixint::le")]
    pub raw: u16,
    /// The command was clipped to the drive's range.
    pub saturated: bool,
    /// Safe-state status.
    pub safe_state: SafeState,
}

/// Ask the camera processor for an observation (node = camera processor).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, MaxSize)]
pub struct CaptureRequest {
    /// Sequence number echoed in the [`Observation`].
    #[serde(with = "postcard::fixint::le")]
    pub seq: u16,
    /// What to capture.
    pub what: CaptureKind,
}

/// A camera observation (node = camera processor).
///
/// `GripperLights`: `points = [p_cam0, p_cam1, q_cam0, q_cam1]` (the stage-1 `v` order).
/// `GripperCentre`: `points = [g_cam0, g_cam1, UNUSED, UNUSED]`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, MaxSize)]
pub struct Observation {
    /// Sequence number of the request.
    #[serde(with = "postcard::fixint::le")]
    pub seq: u16,
    /// What was captured.
    pub what: CaptureKind,
    /// The points, see the type docs for the order.
    pub points: [PixelPoint; 4],
}

/// `raw = round((p + 1) / 2 * 4095)` for a normalised pressure difference `p`, clamped to
/// [-1, 1]; `Err(OutOfRange("p"))` for NaN.
///
/// ```
/// use trn_protocol::{pressure_to_raw, raw_to_pressure};
/// assert_eq!(pressure_to_raw(-1.0)?, 0);
/// assert_eq!(pressure_to_raw(0.0)?, 2048);
/// assert_eq!(pressure_to_raw(1.0)?, 4095);
/// assert!((raw_to_pressure(2048) - 0.0).abs() < 1e-3);
/// # Ok::<(), trn_protocol::Error>(())
/// ```
pub fn pressure_to_raw(p: f32) -> Result<u16> {
    if p.is_nan() {
        return Err(Error::OutOfRange("p"));
    }
    let x = (p.clamp(-1.0, 1.0) + 1.0) / 2.0 * RAW_MAX as f32;
    // x >= 0, so adding 0.5 and truncating rounds half up (no libm in no_std).
    Ok(((x + 0.5) as u16).min(RAW_MAX))
}

/// The normalised pressure difference of a raw value: `raw / 4095 * 2 - 1`.
pub fn raw_to_pressure(raw: u16) -> f32 {
    raw.min(RAW_MAX) as f32 / RAW_MAX as f32 * 2.0 - 1.0
}

impl Observation {
    /// A `GripperLights` observation from `[p_cam0, p_cam1, q_cam0, q_cam1]`.
    pub const fn lights(seq: u16, points: [PixelPoint; 4]) -> Observation {
        Observation {
            seq,
            what: CaptureKind::GripperLights,
            points,
        }
    }

    /// The points used by this kind of observation (4 for lights, 2 for the centre).
    pub fn used_points(&self) -> &[PixelPoint] {
        match self.what {
            CaptureKind::GripperLights => &self.points,
            CaptureKind::GripperCentre => &self.points[..2],
        }
    }

    /// True if every used point is `Valid`.
    pub fn all_valid(&self) -> bool {
        self.used_points()
            .iter()
            .all(|p| p.status == PointStatus::Valid)
    }

    /// The stage-1 vector `v = [p0x, p0y, p1x, p1y, q0x, q0y, q1x, q1y]` of a
    /// `GripperLights` observation (`None` for the centre).
    pub fn v(&self) -> Option<[f32; 8]> {
        if self.what != CaptureKind::GripperLights {
            return None;
        }
        let p = &self.points;
        Some([
            p[0].x, p[0].y, p[1].x, p[1].y, p[2].x, p[2].y, p[3].x, p[3].y,
        ])
    }

    /// The stage-2 vector `c = [g0x, g0y, g1x, g1y]` of a `GripperCentre` observation
    /// (`None` for the lights).
    pub fn c(&self) -> Option<[f32; 4]> {
        if self.what != CaptureKind::GripperCentre {
            return None;
        }
        let p = &self.points;
        Some([p[0].x, p[0].y, p[1].x, p[1].y])
    }

    /// A `GripperCentre` observation (fills the unused slots).
    pub const fn centre(seq: u16, cam0: PixelPoint, cam1: PixelPoint) -> Observation {
        Observation {
            seq,
            what: CaptureKind::GripperCentre,
            points: [cam0, cam1, PixelPoint::UNUSED, PixelPoint::UNUSED],
        }
    }
}

/// Stage-1 target for a trial (runner -> controller). With `grasp`, `v` are the target
/// lights p, q for the grasp approach.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, MaxSize)]
pub struct Stage1Target {
    /// Trial number.
    #[serde(with = "postcard::fixint::le")]
    pub trial: u32,
    /// Learning enabled for this trial.
    pub learn: bool,
    /// Part of a grasp trial (after a [`GraspRequest`]).
    pub grasp: bool,
    /// 8-D target `[p0x, p0y, p1x, p1y, q0x, q0y, q1x, q1y]`, pixels.
    pub v: [f32; 8],
}

/// Stage-2 target for a trial (runner -> controller). With `grasp`, `c` is the
/// cylinder centre in both cameras.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, MaxSize)]
pub struct Stage2Target {
    /// Trial number.
    #[serde(with = "postcard::fixint::le")]
    pub trial: u32,
    /// Learning enabled for this trial.
    pub learn: bool,
    /// Part of a grasp trial.
    pub grasp: bool,
    /// 4-D target `[g0x, g0y, g1x, g1y]`, pixels.
    pub c: [f32; 4],
}

/// Supervised pressures for a priming trial (runner -> controller); precedes the
/// [`Stage1Target`] of the same trial.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, MaxSize)]
pub struct SupervisedPressure {
    /// Trial number.
    #[serde(with = "postcard::fixint::le")]
    pub trial: u32,
    /// Normalised pressure difference per joint, each in [-1, 1].
    pub p: [f32; 5],
}

/// Start a grasp trial (runner -> controller); followed by a `Stage1Target` and a
/// `Stage2Target` of the same trial, both with `grasp = true`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, MaxSize)]
pub struct GraspRequest {
    /// Trial number.
    #[serde(with = "postcard::fixint::le")]
    pub trial: u32,
}

/// Result of a trial (controller -> runner; node = controller, the source).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize, MaxSize)]
pub struct TrialReport {
    /// Trial number.
    #[serde(with = "postcard::fixint::le")]
    pub trial: u32,
    /// Last stage reached: 0 = supervised priming, 1 = stage 1, 2 = stage 2.
    pub stage: u8,
    /// Error after the coarse move, pixels (≥ 0).
    pub coarse_error_px: f32,
    /// Error at the end of the trial, pixels (≥ 0).
    pub final_error_px: f32,
    /// Number of fine moves made.
    pub fine_moves: u8,
    /// The fine-move cap was hit.
    pub cap_hit: bool,
}

/// Open or close the gripper.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, MaxSize)]
pub struct GripperCommand {
    /// `true` closes, `false` opens.
    pub close: bool,
}

/// Gripper state.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, MaxSize)]
pub struct GripperStatus {
    /// The gripper is closed.
    pub closed: bool,
}

/// Heartbeat, sent by every node every 100 ms.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, MaxSize)]
pub struct Heartbeat {
    /// Wrapping counter, +1 per heartbeat.
    pub counter: u8,
    /// The sender's state.
    pub state: NodeState,
}

/// Change the operating mode.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, MaxSize)]
pub struct ModeChange {
    /// The new mode.
    pub mode: Mode,
}

/// An error report (codes are node specific, see SPEC.md).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, MaxSize)]
pub struct ErrorReport {
    /// Error code.
    #[serde(with = "postcard::fixint::le")]
    pub code: u16,
    /// Code-specific detail.
    #[serde(with = "postcard::fixint::le")]
    pub detail: u32,
}

/// Emergency stop: every servo drive vents, the controller stops the trial.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, MaxSize)]
pub struct Emergency {
    /// Why.
    pub reason: EmergencyReason,
}

/// The sender entered its safe state.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, MaxSize)]
pub struct SafeStateEntered {
    /// Why.
    pub reason: SafeStateReason,
    /// What the node did.
    pub action: SafeStateAction,
    /// Servo drives: the raw pressure now held (2048 when vented); others: 0.
    #[serde(with = "postcard::fixint::le")]
    pub held_raw: u16,
}

/// The controller saved a checkpoint.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, MaxSize)]
pub struct CheckpointSaved {
    /// Size in bytes.
    #[serde(with = "postcard::fixint::le")]
    pub bytes: u32,
    /// CRC-32 (ISO-HDLC) of the checkpoint.
    #[serde(with = "postcard::fixint::le")]
    pub crc: u32,
}

fn finite(x: f32, field: &'static str) -> Result<()> {
    if x.is_finite() {
        Ok(())
    } else {
        Err(Error::OutOfRange(field))
    }
}

fn raw12(raw: u16) -> Result<()> {
    if raw <= RAW_MAX {
        Ok(())
    } else {
        Err(Error::OutOfRange("raw"))
    }
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
    ServoStatus = 6;
    GripperCommand = 1;
    GripperStatus = 1;
    CaptureRequest = 3;
    Observation = 39;
    ModeChange = 1;
    SupervisedPressure = 24;
    Stage1Target = 38;
    Stage2Target = 22;
    GraspRequest = 4;
    TrialReport = 15;
    ErrorReport = 6;
    CheckpointSaved = 8;
    Heartbeat = 2;
}

// The tagged enum encoding also fits the budget.
const _: () = assert!(<Message as MaxSize>::POSTCARD_MAX_SIZE <= MESSAGE_BUDGET);

impl Message {
    /// Checks every documented range: 12-bit raws, finite floats, pressures in [-1, 1],
    /// unused observation slots, stages ≤ 2, non-negative errors.
    pub fn validate(&self) -> Result<()> {
        match self {
            Message::PressureCommand(m) => raw12(m.raw),
            Message::ServoStatus(m) => raw12(m.raw),
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
            Message::Stage1Target(m) => m.v.iter().try_for_each(|&x| finite(x, "v")),
            Message::Stage2Target(m) => m.c.iter().try_for_each(|&x| finite(x, "c")),
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
            Message::Emergency(_)
            | Message::GripperCommand(_)
            | Message::GripperStatus(_)
            | Message::CaptureRequest(_)
            | Message::ModeChange(_)
            | Message::GraspRequest(_)
            | Message::ErrorReport(_)
            | Message::CheckpointSaved(_)
            | Message::Heartbeat(_) => Ok(()),
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
}
