//! `trn-camera`: the camera processor as a CAN node of its own, fed by frames instead of the
//! simulator's geometry. A rig with real cameras puts it on the bus in the simulator's place:
//! it answers each `CaptureRequest` with an `Observation` of the same sequence number, as
//! protocol/SPEC.md section 3 states.
//!
//! Its layers, from the frames up:
//!
//! - [`source`]: where a capture's frames come from ([`FrameSource`]): a [`Recording`] (a
//!   folder of PNG frames with a manifest, replayed in order; what a camera's own capture
//!   tool writes, or the simulator's `record` example).
//! - [`processor`]: the camera processor proper ([`Processor`]): each frame's blobs found by
//!   `trn_vision`'s detector, the lights told apart over the capture by its identifier, the
//!   two cameras checked against each other with their calibration (the simulator's stereo
//!   check), the points in the Observation's order with their statuses.
//! - [`node`]: the CAN node, sans-IO ([`CameraNode`]): requests in, observations and
//!   heartbeats out, a lost observation sent again, a stale request ignored, CAN FD when the
//!   session says so.
//! - [`run`]: the node's loop on a real port (SocketCAN, a serial SLCAN adapter) on the wall
//!   clock; the `camera-node` binary is its command line.

#![forbid(unsafe_code)]
#![warn(missing_docs)]

mod error;
pub mod node;
pub mod processor;
pub mod run;
pub mod source;

pub use error::CameraError;
pub use node::{CameraNode, NodeStats};
pub use processor::{Calibration, Processor};
pub use source::{AnyFrame, CaptureFrames, FrameSource, Recording};
