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

pub use crate::config::{BroydenConfig, ZERO_BROYDEN as ZERO_CONFIG};
