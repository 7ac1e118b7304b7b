//! The TRN controller as a CAN node, shared by the host (thread or `controller-node`
//! process) and the firmware.
//!
//! [`ControllerNode`] turns protocol messages into [`trn_controller`] calls and the
//! controller's commands into messages. It never reads a clock (the caller passes
//! `now_ms`) and does no I/O: messages come in through [`ControllerNode::on_message`],
//! timers advance in [`ControllerNode::poll`], and everything to send is pushed into an
//! [`Outbox`] that the caller frames onto its bus.
//!
//! One trial on the bus:
//! 1. runner: optional `SupervisedPressure`, then `Stage1Target` or `Stage2Target` (a grasp:
//!    `GraspRequest`, `Stage1Target{grasp}`, `Stage2Target{grasp}`);
//! 2. controller: one `PressureCommand` per joint moved, then `CaptureRequest{seq}`;
//! 3. camera processor: `Observation{seq}`; back to 2 until the trial is done;
//! 4. controller: `TrialReport` per stage run (and `GripperCommand{close}` after a grasp).
#![cfg_attr(not(any(test, feature = "std")), no_std)]
#![deny(unsafe_code)]
#![warn(missing_docs)]

mod node;

pub use node::{
    codes, controller_error_code, send, ControllerNode, FrameError, NodeConfig, NodeStats, Outbox,
    OUTBOX,
};

/// Normalised pressure difference in [-1, 1] to the servo drives' 12-bit command.
pub fn pressure_to_raw(p: f32) -> u16 {
    let p = if p.is_finite() {
        p.clamp(-1.0, 1.0)
    } else {
        0.0
    };
    let raw = (p + 1.0) * 0.5 * 4095.0 + 0.5;
    (raw as u16).min(4095)
}

/// The 12-bit servo value to a normalised pressure difference.
pub fn raw_to_pressure(raw: u16) -> f32 {
    raw.min(4095) as f32 / 4095.0 * 2.0 - 1.0
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn raw_conversion() {
        assert_eq!(pressure_to_raw(-1.0), 0);
        assert_eq!(pressure_to_raw(1.0), 4095);
        assert_eq!(pressure_to_raw(0.0), 2048);
        assert_eq!(pressure_to_raw(f32::NAN), 2048);
        assert_eq!(pressure_to_raw(7.0), 4095);
        for raw in [0u16, 1, 2047, 2048, 4094, 4095] {
            assert_eq!(pressure_to_raw(raw_to_pressure(raw)), raw);
        }
    }
}
