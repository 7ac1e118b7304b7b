//! The transports' errors: a bus that cannot be opened (or a controller on it that cannot
//! be started), a transport failure on an open bus, and a controller process that failed.

/// What can go wrong opening or using a bus.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum TransportError {
    /// The bus could not be opened, or the controller on it not started; `bus` is the
    /// `--bus` argument.
    #[error("bus {bus}: {msg}")]
    Open {
        /// The `--bus` argument.
        bus: String,
        /// What is wrong.
        msg: String,
    },
    /// The open bus failed (its kind: `embedded_can::Error::kind()`).
    #[error("bus error: {0}")]
    Bus(#[from] trn_protocol::Error),
    /// The controller's process ended badly.
    #[error("bus {bus}: {msg}")]
    Controller {
        /// The `--bus` argument.
        bus: String,
        /// What happened.
        msg: String,
    },
}

impl TransportError {
    /// An `Open` error on `bus`.
    pub fn open(bus: &str, msg: impl Into<String>) -> TransportError {
        TransportError::Open {
            bus: bus.to_string(),
            msg: msg.into(),
        }
    }
}
