//! The crate's one error type: every failure of the simulator, the runner, the transports
//! and the command line, each with a message a user can act on.

use std::path::PathBuf;

/// Everything that can go wrong in `trn-sim`.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum Error {
    /// A configuration value is wrong; the message names the key.
    #[error("{0}")]
    Config(String),
    /// A joint index outside 0..5.
    #[error("joint {0} does not exist (0..5)")]
    NoSuchJoint(usize),
    /// No valid target could be drawn.
    #[error("no valid target after {0} draws: the cameras do not see the workspace")]
    NoTarget(usize),
    /// The controller sent nothing for too long.
    #[error("bus silent: no frame from the controller for {0:.1} s (is the controller node running on this bus?)")]
    BusSilent(f64),
    /// The transport failed.
    #[error("bus error: {0}")]
    Bus(#[from] trn_protocol::Error),
    /// The bus could not be opened, or the controller on it not started.
    #[error("bus {bus}: {msg}")]
    BusOpen {
        /// The `--bus` argument.
        bus: String,
        /// What is wrong.
        msg: String,
    },
    /// Reading or writing a file.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// What happened.
        source: std::io::Error,
    },
    /// A checkpoint.
    #[error("checkpoint {path}: {source}")]
    Checkpoint {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        source: trn_controller::Error,
    },
    /// More than a tenth of the evaluation's trials failed: its figures would mean little.
    #[error("{failed} of {trials} evaluation trials failed (more than 10 %): {reasons}")]
    TooManyFailures {
        /// Failed evaluation trials.
        failed: usize,
        /// Evaluation trials.
        trials: usize,
        /// The reasons, counted.
        reasons: String,
    },
    /// The controller on the bus failed checks of the conformance suite.
    #[error("{failed} of {checks} conformance checks failed")]
    NotConformant {
        /// Failed checks.
        failed: usize,
        /// Checks run.
        checks: usize,
    },
    /// Plotting.
    #[error("plot: {0}")]
    Plot(String),
    /// `--plot` in a build without the `plot` feature.
    #[error("this build has no plotting (feature `plot`): drop --plot")]
    NoPlot,
}

impl PartialEq for Error {
    fn eq(&self, other: &Self) -> bool {
        self.to_string() == other.to_string()
    }
}

/// The crate's result type.
pub type Result<T> = std::result::Result<T, Error>;

/// An `Io` error for `path`.
pub fn io(path: &std::path::Path) -> impl FnOnce(std::io::Error) -> Error + '_ {
    move |source| Error::Io {
        path: path.to_path_buf(),
        source,
    }
}
