//! The plant's errors: a configuration value out of its range (the key named), a joint
//! that does not exist, no target the cameras see.

/// What can go wrong in the plant.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[non_exhaustive]
pub enum PlantError {
    /// A configuration value is wrong, or a configuration file cannot be read or parsed;
    /// the message names the key or the file.
    #[error("{0}")]
    Config(String),
    /// A joint index outside 0..5.
    #[error("joint {0} does not exist (0..5)")]
    NoSuchJoint(usize),
    /// No valid target could be drawn ([`crate::targets`]).
    #[error("no valid target after {0} draws: the cameras do not see the workspace")]
    NoTarget(usize),
}
