//! The command line's errors: the lab's, and drawing. A usage error (options that
//! contradict each other, a meaningless count, an output that collides with an input) exits
//! with 2, like clap's own; every other error with 1.

use trn_bench::LabError;

/// What can end a command.
#[derive(Debug, thiserror::Error)]
pub enum CliError {
    /// The run, its plant or its bus.
    #[error(transparent)]
    Lab(#[from] LabError),
    /// A plot could not be drawn.
    #[error("plot: {0}")]
    Plot(String),
    /// `--plot` in a build without the `plot` feature.
    #[error("this build has no plotting (feature `plot`): drop --plot")]
    NoPlot,
}

impl From<trn_plant::PlantError> for CliError {
    fn from(e: trn_plant::PlantError) -> Self {
        CliError::Lab(e.into())
    }
}

impl CliError {
    /// The process's exit code for this error.
    pub fn exit_code(&self) -> u8 {
        match self {
            CliError::Lab(LabError::Usage(_)) | CliError::NoPlot => 2,
            _ => 1,
        }
    }
}

/// The command line's result type.
pub type Result<T> = std::result::Result<T, CliError>;
