//! The classical alternative: uncalibrated visual servoing with a Broyden Jacobian, no
//! training at all. One stage of it, with the same interface as the TRN's [`crate::stage::Stage`]
//! (a target in, pressures out, each observation back in), so that the two-stage grasp, the
//! CAN node, every bus and the firmware run it unchanged.
//!
//! Published variant followed: Jagersand, Fuentes and Nelson, "Experimental evaluation of
//! uncalibrated visual servoing for precision manipulation" (ICRA 1997), and Hosoda and
//! Asada, "Versatile visual servoing without knowledge of true Jacobian" (IROS 1994): the
//! image Jacobian `J` (D x M, pixels per unit pressure) is estimated from exploratory moves
//! and then corrected after every move by Broyden's rank-one secant update
//! `J += alpha (dy - J dq) dq^T / (dq^T dq)`; each move solves `J dq = y* - y` in the
//! damped-least-squares sense, `dq = (J^T J + lambda I)^-1 J^T (y* - y)`.
//!
//! What this implementation adds, each for a reason the plant gives:
//! - **The first move goes to a fixed home pressure** ([`BroydenConfig::home`]): the arm's
//!   state at the start of a trial is not the controller's (the runner moves it), and
//!   without a model nothing better than a known pose is available. It plays the part of the
//!   TRN's coarse move, and is scored as such.
//! - **The initial Jacobian is measured once, at home, by finite differences** (one
//!   exploratory move of [`BroydenConfig::explore_step`] per joint) during the first trial
//!   after a reset; those moves count as that trial's fine moves. Every trial starts from
//!   that Jacobian (every trial starts at home), and the trial's Broyden corrections are
//!   dropped at its end: nothing is carried from trial to trial, so the method stays
//!   training-free and `learn` changes nothing.
//! - **Damping relative to the Jacobian's scale**: `lambda = damping * trace(J^T J) / M`.
//! - **A step limit**: the largest joint change of a move is at most
//!   [`BroydenConfig::max_step`]; the whole step is scaled, keeping its direction.
//! - **Joints at their limits are excluded**: a joint at `+-pressure_limit` whose step would
//!   push it further is taken out of the solve (its column dropped) for that move.
//! - **No update from tiny steps**: below [`BroydenConfig::min_update_step`] the secant is
//!   mostly camera noise and the update is skipped (counted in `skipped_updates`).
//! - Tolerance and cap as for the TRN: the stage's `mature_tolerance` stops it by its own
//!   rule, at most [`BroydenConfig::max_fine_moves`] fine moves (exploration included); a
//!   fixed budget (`FineMoves::Exactly`) as for the TRN.
//!
//! The servo's state ([`BroydenStage`], 1,280 bytes for both stages on a Cortex-M) is built
//! with the cargo feature `broyden` (a default); without it the constants stay (they are
//! part of [`crate::Config`] and its fingerprint) and the controller refuses
//! [`crate::Law::Broyden`] with [`crate::Error::UnsupportedLaw`] (the compact firmware for
//! 128 KiB parts leaves it out).

mod pair;
#[cfg(feature = "broyden")]
mod servo;

pub(crate) use pair::BroydenPair;
#[cfg(feature = "broyden")]
pub use servo::BroydenStage;

/// The Broyden servo's constants (one set for both stages).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize)]
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
pub const ZERO_CONFIG: BroydenConfig = BroydenConfig {
    home: 0.0,
    explore_step: 0.0,
    damping: 0.0,
    max_step: 0.0,
    alpha: 0.0,
    min_update_step: 0.0,
    max_fine_moves: 0,
};
