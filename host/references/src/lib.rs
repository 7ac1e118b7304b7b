//! `trn-references`: the learning-free controllers the TRN is compared with, behind the
//! controller's own [`trn_controller::Control`] seam so that anything that drives a
//! controller (the lab's CAN node, the Python binding) scores them like the TRN:
//!
//! - [`model_based`]: a controller that solves for a target on a model of the arm
//!   ([`model_based::ArmModel`]) instead of learning;
//! - [`nominal`]: the calibrated model (`model`): the arm's links, cameras and pressure
//!   curves, loops of zero width;
//! - [`oracle`]: the physical limit (`oracle`): an exact copy of the plant as it is now.
//!
//! Neither is a controller for the MCU: each carries the simulator.

pub mod model_based;
pub mod nominal;
pub mod oracle;

pub use model_based::{ArmModel, ModelBased};
pub use nominal::NominalIk;
pub use oracle::{LiveModel, Oracle, PlantSource, SharedPlant};

/// The wire codes of the session's law byte (SPEC.md 3.2) these controllers answer to:
/// [`trn_controller::Law::HOST_CODES`].
pub mod law_code {
    use trn_controller::Law;

    /// The calibrated model's code.
    pub const MODEL: u8 = Law::HOST_CODES[0].0;
    /// The oracle's code.
    pub const ORACLE: u8 = Law::HOST_CODES[1].0;
}
