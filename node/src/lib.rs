//! The TRN controller as a CAN node, shared by the host (thread or `controller-node`
//! process) and the firmware.
//!
//! [`ControllerNode`] turns protocol messages into [`trn_controller`] calls and the
//! controller's commands into messages. It never reads a clock (the caller passes
//! `now_ms`) and does no I/O: messages come in through [`ControllerNode::on_message`],
//! timers advance in [`ControllerNode::poll`], and everything to send is pushed into an
//! [`Outbox`] that the caller frames onto its bus. [`ControllerNode::service`] is one turn
//! of the loop on any `embedded-can` port, the code path every build shares, and
//! [`ControllerNode::poll_timeout`] says when the loop must come back if no frame arrives.
//!
//! The node guards its learned tables against destructive operations that do not carry a
//! fresh nonce ([`ControllerNode::seed_guard`], `guard.rs`), and serves them over the bus
//! and to their store (`node/tables.rs`; a controller with a store is a
//! [`trn_controller::WithStore`]).
//!
//! One trial on the bus is specified in `protocol/SPEC.md`.
#![cfg_attr(not(any(test, feature = "std")), no_std)]
#![deny(unsafe_code)]
#![warn(missing_docs)]

pub mod codes;
mod config;
mod exchange;
mod guard;
pub mod health;
mod node;
mod outbox;
pub mod reset;
mod service;
mod stats;

pub use codes::controller_error_code;
pub use config::NodeConfig;
pub use guard::{op_code, seed_from_draws, Refusal, SeedFailure, SEED_DRAWS};
pub use health::{BusAction, BusCounters, BusHealth, BusReading, BusState};
pub use node::{ControllerNode, NodeStats};
pub use outbox::{send, FrameError, Outbox, OUTBOX};
pub use reset::{reset_cause, reset_report, ResetCause, ResetFlags};
pub use service::{from_protocol, to_protocol};
