//! `trn_softarm._native`: the Rust half of the Python package `trn_softarm`.
//!
//! - [`arm::Arm`]: the simulated SoftArm as an environment's core (a seeded plant, a
//!   deployment-style target, moves read by the camera processor's vision), with the
//!   pictures of both cameras ([`render`]); [`arm_vec::ArmVec`]: many stepped in one call,
//!   each arm's next episode built ahead.
//! - [`control::Ctrl`]: the TRN or the Broyden servo on plain lists of floats: a task in,
//!   pressures out, observations in; the calibrated model and the oracle (`trn-references`)
//!   behind the same calls.
//! - [`model`]: the arm as URDF or MJCF, and the plant's forward kinematics to check it by.
//! - [`decode`]: frames and candump logs as the protocol's messages, by the receivers' own
//!   decoder.
//!
//! The Python layer (`python/python/trn_softarm/`) turns these into numpy arrays, a
//! Gymnasium environment and the live view; nothing here imports numpy or Gymnasium.

use pyo3::prelude::*;

mod ahead;
mod arm;
mod arm_vec;
mod control;
mod decode;
mod fields;
mod model;
mod render;

/// The module `trn_softarm._native`.
#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_class::<arm::Arm>()?;
    m.add_class::<arm_vec::ArmVec>()?;
    m.add_function(wrap_pyfunction!(arm::arm_from_state, m)?)?;
    m.add_class::<control::Ctrl>()?;
    m.add_function(wrap_pyfunction!(decode::decode_frames, m)?)?;
    m.add_function(wrap_pyfunction!(decode::decode_candump, m)?)?;
    m.add_class::<decode::StreamDecoder>()?;
    m.add_function(wrap_pyfunction!(arm::config_json, m)?)?;
    m.add_function(wrap_pyfunction!(arm::camera_pinholes, m)?)?;
    m.add_function(wrap_pyfunction!(model::arm_model, m)?)?;
    m.add_function(wrap_pyfunction!(model::arm_frames, m)?)?;
    Ok(())
}
