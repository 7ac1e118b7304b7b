//! The guard of a node's learned tables: a destructive operation (re-seeding tables that
//! learned, writing tables in, erasing the stored copy) carries a nonce the node announced
//! for it moments before (SPEC.md 3.4).

use postcard::experimental::max_size::MaxSize;
use serde::{Deserialize, Serialize};

use super::SessionConfig;

/// A destructive operation, as a guard request and its nonce name it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, MaxSize)]
pub enum GuardOp {
    /// A `SessionConfig` with `keep_tables = false` on tables that learned: new tables seeded.
    Reseed,
    /// Writing tables in (`TableWriteBegin`).
    TableWrite,
    /// Erasing the stored copies (`StoreCommand{Erase}`).
    StoreErase,
}

/// Asks the controller for a nonce for one destructive operation (runner → controller).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, MaxSize)]
pub struct GuardRequest {
    /// The operation the nonce is for.
    pub op: GuardOp,
}

/// A fresh nonce for one operation (controller report): valid once, for `window_ms` of the
/// controller's clock from now, for `op` only.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, MaxSize)]
pub struct GuardNonce {
    /// The operation it is for.
    pub op: GuardOp,
    /// The nonce.
    #[serde(with = "super::fixint")]
    pub nonce: u32,
    /// How long it stays valid, ms of the controller's clock.
    #[serde(with = "super::fixint")]
    pub window_ms: u16,
}

/// A `SessionConfig` confirmed with the nonce of a [`GuardOp::Reseed`] (runner →
/// controller): the only way to re-seed tables that learned. The controller acknowledges it
/// with the echo of the plain `SessionConfig`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, MaxSize)]
pub struct ConfirmedSessionConfig {
    /// The configuration (the layout of `SessionConfig`).
    pub config: SessionConfig,
    /// The nonce of the controller's `GuardNonce{Reseed}`.
    #[serde(with = "super::fixint")]
    pub nonce: u32,
}
