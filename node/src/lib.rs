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
