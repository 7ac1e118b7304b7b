//! The plant's CAN nodes as sans-IO state machines, in the style of the controller's node:
//! each takes received messages and the time (`now_ms`, from the caller) and pushes the
//! messages it sends into an [`Outbox`]; none owns a bus or reads a clock. They act on the
//! one [`Plant`](crate::Plant) they share, which the caller passes in.
//!
//! - [`ServoDrive`]: one joint's servo drive unit: applies pressure commands, reports
//!   [`ServoStatus`](trn_protocol::ServoStatus), supervises the controller's heartbeat and
//!   enters its safe state when it is lost.
//! - [`CameraProcessor`]: both cameras: lets the arm settle, reads the lights, answers a
//!   capture request with an observation.
//! - [`Gripper`]: opens and closes, reports its state.

mod camera_processor;
mod gripper;
mod servo_drive;

pub use camera_processor::{CameraProcessor, Capture, Served, Sight};
pub use gripper::Gripper;
pub use servo_drive::ServoDrive;

/// Messages a node sends in answer to one event, each with the node field of its CAN id.
pub type Outbox = Vec<trn_protocol::Envelope>;
