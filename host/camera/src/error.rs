//! What can go wrong, per operation.

use std::path::PathBuf;

/// An error of the camera node.
#[derive(Debug, thiserror::Error)]
pub enum CameraError {
    /// A file of a recording could not be read.
    #[error("{path}: {source}")]
    Read {
        /// The file.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// A recording's manifest that is not one.
    #[error("{path}: {why}")]
    Manifest {
        /// The manifest.
        path: PathBuf,
        /// What is wrong with it.
        why: String,
    },
    /// A frame that is not a grayscale image of the size its camera has.
    #[error("{path}: {why}")]
    Frame {
        /// The frame's file.
        path: PathBuf,
        /// What is wrong with it.
        why: String,
    },
    /// A capture of another kind than the one asked for, or none left.
    #[error("{0}")]
    Source(String),
    /// The detector or the identifier refused a frame or a protocol.
    #[error(transparent)]
    Vision(#[from] trn_vision::VisionError),
    /// The bus.
    #[error("bus: {0:?}")]
    Bus(trn_protocol::Error),
}

impl From<trn_protocol::Error> for CameraError {
    fn from(e: trn_protocol::Error) -> Self {
        CameraError::Bus(e)
    }
}
