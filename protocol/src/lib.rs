//! The TRN CAN protocol: postcard messages framed onto CAN 2.0 and CAN FD.
//!
//! * [`Message`]: every message between the controller, the servo drives, the camera
//!   processor, the gripper and the experiment runner; fixed little-endian layouts.
//! * [`CanId`]: 11-bit ids `kind << 4 | node` ([`MessageKind`] = priority, [`NodeId`]).
//! * [`encode`] / [`Encoder`]: one classical frame for short messages, segmentation with a
//!   CRC-32 for long ones on CAN 2.0, one FD frame on CAN FD.
//! * [`Reassembler`]: bounded reassembly and decoding with typed errors.
//! * [`HeartbeatMonitor`]: safe state on heartbeat loss.
//! * [`candump`]: the candump log format; `decode` (feature `std`): a log's frames as
//!   messages, segmented ones included.
//! * `bus` (feature `std`): the in-process virtual bus and SocketCAN (feature `socketcan`).
//!
//! The wire format is specified in `protocol/SPEC.md`.
#![cfg_attr(not(any(test, feature = "std")), no_std)]
#![deny(unsafe_code)]
#![warn(missing_docs)]

pub mod candump;
mod envelope;
mod error;
mod frame;
pub mod heartbeat;
mod id;
mod kind;
mod message;
mod node;
mod reassembly;
mod segment;
pub mod slcan;
mod version;

#[cfg(feature = "std")]
pub mod bus;
#[cfg(feature = "std")]
pub mod decode;

pub use envelope::{BusMode, Envelope};
pub use error::{Error, Result};
pub use frame::{fd_len_for, CanFrame, CLASSIC_MAX, FD_MAX};
pub use heartbeat::{HeartbeatConfig, HeartbeatEvent, HeartbeatMonitor, HeartbeatSender};
pub use id::{CanId, MAX_STANDARD_ID};
pub use kind::MessageKind;
pub use message::*;
pub use node::{Joint, NodeId, JOINTS};
pub use reassembly::{Reassembler, DEFAULT_STALE_MS};
pub use segment::{encode, segment_count, segment_len, Encoder, Frames, CRC_LEN, MAX_SEGMENTS};
pub use version::{ProtocolVersion, V4_ERROR_CODES};

/// The README's code examples run as doc tests.
#[cfg(doctest)]
#[doc = include_str!("../README.md")]
pub struct ReadmeDoctests;
