//! The controller node's timing and its guard and save settings, one value for every build.

use trn_protocol::ProtocolVersion;

/// Timing of the node.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct NodeConfig {
    /// Heartbeat period (ms): 100.
    pub heartbeat_period_ms: u32,
    /// How long to wait for the answer to a request (a drive's `ServoStatus`, an
    /// `Observation`, a `GripperStatus`) before repeating it (ms).
    pub reply_timeout_ms: u32,
    /// Repeats of a request before the trial is given up (aborted with a reason).
    pub retries: u8,
    /// How long a guard nonce stays valid after the node announced it (ms of its clock).
    pub nonce_window_ms: u16,
    /// Lets a `SessionConfig` with `keep_tables = false` re-seed tables that learned without
    /// a nonce (a bench board whose tables are disposable); writes and erases stay guarded.
    pub allow_unguarded_reset: bool,
    /// Learning steps between two saves to the stored copy
    /// (`trn_store::policy::steps_between_saves` of the part); `u32::MAX`: never by steps.
    pub save_every_steps: u32,
    /// How long a trial's start may wait for a save in progress to end (ms): a save writes
    /// the tables only while no trial runs, so a target that comes while one runs waits for
    /// it (the node serving heartbeats and the bus meanwhile) up to this long, and then
    /// starts, abandoning the save's writing for after the trial (its erases are kept).
    /// Below the runner's give-up of a trial start that shows no sign (13 x 300 ms on
    /// SocketCAN): 3,000.
    pub save_hold_ms: u32,
    /// Learning steps before a save by steps is due at which its erases begin (they run
    /// during the trials, the tables are written once the save is due): 1, room for a
    /// 128 KiB sector's erase of up to 2.2 s in each of two trials.
    pub save_lead_steps: u32,
    /// The protocol version the node speaks (SPEC.md, "Versions"): [`ProtocolVersion::V4`];
    /// [`ProtocolVersion::V3`] makes it a version-3 controller, for testing runners against
    /// one: the kinds, error codes and point status that version 4 added are unknown to it
    /// (ignored and counted as frame errors, never answered, never sent), and with them the
    /// guard and the tables over the bus (a `SessionConfig` re-seeds without a nonce, no
    /// trial is refused for want of a session).
    pub protocol: ProtocolVersion,
}

impl NodeConfig {
    /// The node's timing on the firmware: heartbeats every 100 ms, a request repeated up to
    /// 8 times, 200 ms apart; a guard nonce valid for 2 s; re-seeding learned tables guarded;
    /// no saves by learning steps (a board with a store sets them from its flash). (Under QEMU's instruction counting the firmware's clock runs
    /// about ten times slower than the wall clock: 2 s of wall time.)
    pub const DEFAULT: NodeConfig = NodeConfig {
        heartbeat_period_ms: 100,
        reply_timeout_ms: 200,
        retries: 8,
        nonce_window_ms: 2000,
        allow_unguarded_reset: false,
        save_every_steps: u32::MAX,
        save_hold_ms: 3000,
        save_lead_steps: 1,
        protocol: ProtocolVersion::V4,
    };

    /// The host's loop (in-process bus, SocketCAN): the simulator answers within a
    /// millisecond, so a lost frame is repeated after 10 ms, up to 50 times: half a second
    /// before a trial is given up, ample for a loaded machine's scheduling (a repeat that
    /// crosses a late answer is harmless: both sides recognise it).
    pub const HOST: NodeConfig = NodeConfig {
        reply_timeout_ms: 10,
        retries: 50,
        ..NodeConfig::DEFAULT
    };

    /// [`NodeConfig::HOST`] speaking protocol version 3.
    pub const HOST_V3: NodeConfig = NodeConfig {
        protocol: ProtocolVersion::V3,
        ..NodeConfig::HOST
    };

    /// True when the node speaks version 3 only (the guard and the tables unknown to it).
    pub const fn v3(&self) -> bool {
        matches!(self.protocol, ProtocolVersion::V3)
    }
}

impl Default for NodeConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}
