//! The camera processor's errors: every bad input is one of these, never a panic.

/// What can go wrong when rendering, detecting or identifying.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum VisionError {
    /// A frame (or a sensor) with no pixel.
    #[error("empty frame: {width} x {height} pixels")]
    EmptyFrame {
        /// Frame width (pixels).
        width: u32,
        /// Frame height (pixels).
        height: u32,
    },
    /// A frame whose size is not the one the detector was made for, or whose buffer does
    /// not hold width x height samples.
    #[error("frame of {got_width} x {got_height} ({got_len} samples) where {width} x {height} was expected")]
    WrongSize {
        /// Expected width (pixels).
        width: u32,
        /// Expected height (pixels).
        height: u32,
        /// The frame's width (pixels).
        got_width: u32,
        /// The frame's height (pixels).
        got_height: u32,
        /// The number of samples in the frame's buffer.
        got_len: usize,
    },
    /// A parameter that is not a finite number, or outside its range; the message names it.
    #[error("parameter {name} = {value} is out of range: {rule}")]
    Parameter {
        /// The parameter's name.
        name: &'static str,
        /// Its value.
        value: f64,
        /// The range it must be in.
        rule: &'static str,
    },
    /// A capture protocol that cannot tell its lights apart, or a capture sequence that does
    /// not fit the protocol; the message says why.
    #[error("capture protocol: {0}")]
    Protocol(String),
}

/// `Ok(v)` when `v` is finite and `ok(v)` holds, else [`VisionError::Parameter`].
pub(crate) fn check(
    name: &'static str,
    value: f64,
    rule: &'static str,
    ok: impl Fn(f64) -> bool,
) -> Result<f64, VisionError> {
    if value.is_finite() && ok(value) {
        Ok(value)
    } else {
        Err(VisionError::Parameter { name, value, rule })
    }
}
