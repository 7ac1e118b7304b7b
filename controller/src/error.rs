//! The crate's one error type.

use core::fmt;

/// Everything that can go wrong in the controller. Every variant leaves the
/// network tables untouched: bad input is rejected before any update.
#[derive(Debug, Clone, Copy, PartialEq)]
#[non_exhaustive]
pub enum Error {
    /// An input coordinate (target or observation) is NaN or infinite.
    NonFiniteInput {
        /// Index of the offending coordinate.
        index: u8,
    },
    /// An input coordinate lies outside the configured camera range.
    InputOutOfRange {
        /// Index of the offending coordinate.
        index: u8,
        /// The value that was rejected (pixels).
        value: f32,
    },
    /// A supervised target pressure is NaN, infinite or outside the pressure limits.
    InvalidPressure {
        /// Index of the offending joint.
        index: u8,
    },
    /// The Jacobian rule (8.15)/(8.21) divides by `||dv||^2`, and `dv` was (almost) zero.
    /// The update is skipped; the state machine counts it and carries on.
    ZeroLengthDv,
    /// A fixed budget of fine moves beyond what a trial can trace (31).
    FineMoveBudget,
    /// The configuration asks for a control law this controller does not run
    /// (the model-based reference and the oracle are host-side, [`crate::Law::HOST_CODES`]).
    UnsupportedLaw,
    /// A preset, ablation or law code that the wire does not define (SPEC.md 3.2).
    UnknownCode,
    /// An observation arrived while none was awaited.
    UnexpectedObservation,
    /// The observation is of the wrong kind (lights when the centre was awaited, or the reverse).
    WrongObservationKind,
    /// A new task was started while a trial is still running (call `abort` first).
    Busy,
    /// In mature operation, the target is farther from every neuron than the configured limit.
    TargetOutsideLearnedRegion {
        /// Distance (pixels) from the target to the closest neuron.
        distance: f32,
    },
    /// The output buffer is too small (checkpoint serialisation).
    BufferTooSmall {
        /// Bytes needed.
        needed: usize,
    },
    /// A checkpoint is shorter or longer than its header says.
    CheckpointLength {
        /// Expected length in bytes.
        expected: usize,
        /// Actual length in bytes.
        found: usize,
    },
    /// A checkpoint does not start with the magic bytes `TRNC`.
    CheckpointMagic,
    /// A checkpoint has a format version this build does not read.
    CheckpointVersion {
        /// The version found.
        found: u16,
    },
    /// A checkpoint was written for networks of other sizes.
    CheckpointShape,
    /// A checkpoint's CRC-32 does not match its contents.
    CheckpointCrc {
        /// CRC stored in the checkpoint.
        stored: u32,
        /// CRC computed over the contents.
        computed: u32,
    },
    /// A checkpoint decoded but holds non-finite values.
    CheckpointContents,
    /// A checkpoint written or restored in pieces changed between the pieces: the tables
    /// changed while their image was being written, or a source read differently on the
    /// second pass of a restore.
    CheckpointChanged,
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Error::NonFiniteInput { index } => write!(f, "input coordinate {index} is not finite"),
            Error::InputOutOfRange { index, value } => {
                write!(
                    f,
                    "input coordinate {index} = {value} px is outside the camera range"
                )
            }
            Error::InvalidPressure { index } => {
                write!(
                    f,
                    "target pressure of joint {index} is not finite or out of limits"
                )
            }
            Error::ZeroLengthDv => write!(f, "zero-length dv: Jacobian update skipped"),
            Error::FineMoveBudget => write!(f, "a fixed budget of fine moves is at most 31"),
            Error::UnsupportedLaw => write!(f, "this controller does not run that control law"),
            Error::UnknownCode => write!(f, "no preset, ablation or law has that code"),
            Error::UnexpectedObservation => {
                write!(f, "observation received while none was awaited")
            }
            Error::WrongObservationKind => write!(f, "observation of the wrong kind for this move"),
            Error::Busy => write!(f, "a trial is still running"),
            Error::TargetOutsideLearnedRegion { distance } => write!(
                f,
                "target is {distance} px from the closest neuron, outside the learned region"
            ),
            Error::BufferTooSmall { needed } => {
                write!(f, "buffer too small: {needed} bytes needed")
            }
            Error::CheckpointLength { expected, found } => {
                write!(f, "checkpoint length {found} bytes, expected {expected}")
            }
            Error::CheckpointMagic => write!(f, "not a TRN checkpoint (bad magic)"),
            Error::CheckpointVersion { found } => {
                write!(f, "checkpoint format version {found} is not supported")
            }
            Error::CheckpointShape => write!(f, "checkpoint is for networks of another size"),
            Error::CheckpointCrc { stored, computed } => write!(
                f,
                "checkpoint CRC mismatch: stored {stored:#010x}, computed {computed:#010x}"
            ),
            Error::CheckpointContents => write!(f, "checkpoint holds non-finite values"),
            Error::CheckpointChanged => {
                write!(
                    f,
                    "checkpoint changed while it was written or read in pieces"
                )
            }
        }
    }
}

impl core::error::Error for Error {}

/// The crate's result type.
pub type Result<T> = core::result::Result<T, Error>;
