//! The servo loop: pressure commands, drive feedback, the safe state of a drive.

use postcard::experimental::max_size::MaxSize;
use serde::{Deserialize, Serialize};

use crate::error::{Error, Result};

/// Largest 12-bit servo command / feedback value.
pub const RAW_MAX: u16 = 4095;

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

/// Pressure command to one servo drive (node = destination servo).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, MaxSize)]
pub struct PressureCommand {
    /// Sequence number (wraps).
    #[serde(with = "super::fixint")]
    pub seq: u16,
    /// 12-bit command 0..=4095: `raw = round((p + 1) / 2 * 4095)`.
    #[serde(with = "super::fixint")]
    pub raw: u16,
}

/// Servo drive feedback (node = source servo).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, MaxSize)]
pub struct ServoStatus {
    /// Sequence number of the last command applied.
    #[serde(with = "super::fixint")]
    pub seq: u16,
    /// Measured pressure difference, 12-bit 0..=4095 (same scale as the command).
    #[serde(with = "super::fixint")]
    pub raw: u16,
    /// The command now applied, 12-bit: the echo of the command of `seq` (or the held
    /// pressure in the safe state), so that the controller can verify what reached the drive.
    #[serde(with = "super::fixint")]
    pub applied: u16,
    /// The command was clipped to the drive's range.
    pub saturated: bool,
    /// Safe-state status.
    pub safe_state: SafeState,
}

/// The sender entered its safe state.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, MaxSize)]
pub struct SafeStateEntered {
    /// Why.
    pub reason: SafeStateReason,
    /// What the node did.
    pub action: SafeStateAction,
    /// Servo drives: the raw pressure now held (2048 when vented); others: 0.
    #[serde(with = "super::fixint")]
    pub held_raw: u16,
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
