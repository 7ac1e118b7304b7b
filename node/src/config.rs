//! The controller node's timing, one value for every build.

/// Timing of the node.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct NodeConfig {
    /// Heartbeat period (ms): 100.
    pub heartbeat_period_ms: u32,
    /// How long to wait for an observation before repeating the capture request (ms).
    pub observation_timeout_ms: u32,
    /// Capture requests repeated before the trial is aborted.
    pub capture_retries: u8,
}

impl NodeConfig {
    /// The node's timing on every build (host and firmware): heartbeats every 100 ms, a
    /// capture request repeated twice after 2 s without an observation.
    pub const DEFAULT: NodeConfig = NodeConfig {
        heartbeat_period_ms: 100,
        observation_timeout_ms: 2000,
        capture_retries: 2,
    };
}

impl Default for NodeConfig {
    fn default() -> Self {
        Self::DEFAULT
    }
}
