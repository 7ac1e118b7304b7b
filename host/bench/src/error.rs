//! The lab's errors: what a run, a study or the conformance suite can end with, each with a
//! message a user can act on. The plant's and the transports' errors come through as they
//! are ([`PlantError`], [`TransportError`]).

use std::path::PathBuf;

use trn_plant::PlantError;
use trn_transport::TransportError;

/// Everything that can end a run of the lab.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum LabError {
    /// The run's specification is inconsistent or a value meaningless; nothing ran.
    #[error("{0}")]
    Usage(String),
    /// The plant (its configuration).
    #[error(transparent)]
    Plant(PlantError),
    /// The bus or the controller's process.
    #[error(transparent)]
    Transport(#[from] TransportError),
    /// The controller on the bus refused or did not acknowledge a request the run needs
    /// (a session configuration, a mode).
    #[error("the controller {0}")]
    Controller(String),
    /// No valid target could be drawn.
    #[error("no valid target after {0} draws: the cameras do not see the workspace")]
    NoTarget(usize),
    /// The controller sent nothing for too long.
    #[error("bus silent: no frame from the controller for {0:.1} s (is the controller node running on this bus?)")]
    BusSilent(f64),
    /// Reading or writing a file.
    #[error("{path}: {source}")]
    Io {
        /// The file (the user's path).
        path: PathBuf,
        /// What happened.
        source: std::io::Error,
    },
    /// A checkpoint file.
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
    /// Runs of a study failed (the others finished and were written: `--resume` runs only
    /// what is missing).
    #[error("{failed} of {runs} runs failed: {errors}")]
    RunsFailed {
        /// Runs that failed.
        failed: usize,
        /// Runs of the study (or shard) run.
        runs: usize,
        /// Each failed run and its error.
        errors: String,
    },
    /// The controller on the bus failed checks of the conformance suite.
    #[error("{failed} of {checks} conformance checks failed")]
    NotConformant {
        /// Failed checks.
        failed: usize,
        /// Checks run.
        checks: usize,
    },
    /// Interrupted before anything ran (while this was being prepared): nothing was written.
    #[error("interrupted while {0}: nothing ran")]
    Interrupted(&'static str),
}

/// The plant's errors as they are, but for [`PlantError::NoTarget`] (the targets are the
/// plant's): the lab's own [`LabError::NoTarget`], as before the targets moved there.
impl From<PlantError> for LabError {
    fn from(e: PlantError) -> Self {
        match e {
            PlantError::NoTarget(draws) => LabError::NoTarget(draws),
            e => LabError::Plant(e),
        }
    }
}

impl From<trn_transport::board::BoardError> for LabError {
    fn from(e: trn_transport::board::BoardError) -> Self {
        match e {
            trn_transport::board::BoardError::Usage(m) => LabError::Usage(m),
            trn_transport::board::BoardError::Io { path, source } => LabError::Io { path, source },
        }
    }
}

impl From<trn_protocol::Error> for LabError {
    fn from(e: trn_protocol::Error) -> Self {
        LabError::Transport(TransportError::Bus(e))
    }
}

impl PartialEq for LabError {
    fn eq(&self, other: &Self) -> bool {
        self.to_string() == other.to_string()
    }
}

/// The lab's result type.
pub type Result<T> = std::result::Result<T, LabError>;

/// An `Io` error for `path`.
pub fn io(path: &std::path::Path) -> impl FnOnce(std::io::Error) -> LabError + '_ {
    move |source| LabError::Io {
        path: path.to_path_buf(),
        source,
    }
}
