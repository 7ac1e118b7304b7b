//! The Broyden servo's constants ([`crate::broyden`]): part of every configuration and its
//! fingerprint, whether or not the servo is built. Numbers only.

/// The Broyden servo's constants (one set for both stages).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct BroydenConfig {
    /// Pressure of every joint for the first move of a trial (normalised, in `[-1, 1]`).
    pub home: f32,
    /// Joint change of each exploratory move (normalised pressure).
    pub explore_step: f32,
    /// Damping of the least-squares step, relative to `trace(J^T J) / M`.
    pub damping: f32,
    /// Largest joint change of one move (normalised pressure).
    pub max_step: f32,
    /// Gain of Broyden's update, in `(0, 1]`.
    pub alpha: f32,
    /// Smallest `||dq||` (normalised pressure) from which the Jacobian is updated.
    pub min_update_step: f32,
    /// Cap on fine moves per trial (the exploratory moves included).
    pub max_fine_moves: u8,
}

impl BroydenConfig {
    /// The defaults: home at zero pressure difference, exploration 0.15, damping 1 %, steps
    /// of at most 0.4, the full secant update, no update below 0.01, at most 20 fine moves.
    pub const DEFAULT: BroydenConfig = BroydenConfig {
        home: 0.0,
        explore_step: 0.15,
        damping: 0.01,
        max_step: 0.4,
        alpha: 1.0,
        min_update_step: 0.01,
        max_fine_moves: 20,
    };
}

/// All zero: the Broyden constants of [`crate::Config::zeroed`].
pub const ZERO_BROYDEN: BroydenConfig = BroydenConfig {
    home: 0.0,
    explore_step: 0.0,
    damping: 0.0,
    max_step: 0.0,
    alpha: 0.0,
    min_update_step: 0.0,
    max_fine_moves: 0,
};
