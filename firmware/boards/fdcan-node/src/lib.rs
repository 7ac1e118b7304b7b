//! The TRN controller as a CAN node on an STM32's FDCAN peripheral, with embassy: what the
//! FDCAN board images share (`firmware/boards/stm32h743`, `stm32g474`).
//!
//! - [`bitrate`]: the CAN bit rates of the build (`TRN_CAN_BITRATE`, `TRN_CAN_DATA_BITRATE`)
//!   and their bit timings for the board's FDCAN kernel clock, checked when the image is built.
//! - [`start`]: the peripheral configured (bit timings, CAN FD with bit-rate switching,
//!   transmit FIFO in write order, standard data frames only) and started with interrupt-driven
//!   receive and transmit buffers.
//! - [`FdcanPort`]: that driver as an `embedded-can` port of the protocol's frames, the seam
//!   [`trn_node::ControllerNode::service`] takes.
//! - [`run`]: the node's loop: a turn of `service`, then sleep until a frame arrives or the
//!   node's [`trn_node::ControllerNode::poll_timeout`], with embassy-time's clock as `now_ms`;
//!   it logs each trial with the node's counters and the stack's high-water mark
//!   ([`stack_high_water_mark`]), and feeds the board's watchdog once a turn.
//! - [`guard_stack`]: an MPU region at the stack's bottom, so that an overflow faults and
//!   resets the part instead of overwriting the static data.
//! - [`health`]: FDCAN1's error counters, fault confinement state and receive overruns read
//!   each turn for the node's health policy, and the restart after a bus-off's hold-off.
//! - [`store`]: what the boards' stores of their learned tables share: the flash error with
//!   its ECC case, how often a board saves, the restore at boot and its log.
//! - [`recover`]: a panic or a hard fault logs its cause and resets the part; the HSE's start
//!   bounded ([`recover::hse_started`]).
//!
//! The controller is configured only by the `SessionConfig` it receives (protocol/SPEC.md
//! 3.2); until then it holds zeroed tables and refuses targets with an error report.
#![no_std]
#![deny(unsafe_code)]
#![warn(missing_docs)]

pub mod bitrate;
mod fdcan;
pub mod health;
mod port;
pub mod recover;
mod run;
mod stack;
pub mod store;

pub use fdcan::{start, Fdcan, KernelClock};
pub use port::{FdcanPort, PortError};
pub use run::{now_ms, rng_draws, run, NodeState};
pub use stack::{guard as guard_stack, stack_high_water_mark, GUARD as STACK_GUARD};
/// The node's timing and save settings ([`NodeState::with_config`]).
pub use trn_node::NodeConfig;
/// The reset flags a board reads at boot ([`NodeState::reset_cause`]).
pub use trn_node::ResetFlags;
