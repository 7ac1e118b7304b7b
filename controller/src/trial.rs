//! What every stage law shares, whatever it learns or not (the TRN's [`crate::stage`], the
//! Broyden servo's [`crate::broyden`]): a trial's outcome and trace, the next step of a
//! trial, the fine-move rule, and the check of a target or observation. Imports only the
//! configuration and the errors.

use crate::config::StageConfig;
use crate::error::{Error, Result};

/// Longest error trace kept per trial: the coarse move and up to 31 fine moves.
pub const TRACE_LEN: usize = 32;

/// What the caller must do next.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum StageStep<const M: usize> {
    /// Apply these pressures, let the arm settle, and pass the next observation.
    Move([f32; M]),
    /// The trial is over.
    Done(StageOutcome),
}

/// The result of one trial of one network.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StageOutcome {
    /// The learning step `t` of this trial (unchanged by trials that do not learn).
    pub t: u32,
    /// Whether the tables were updated.
    pub learned: bool,
    /// Whether the target pressure was known (supervised priming).
    pub supervised: bool,
    /// Error after the coarse move (pixels).
    pub coarse_error: f32,
    /// Error after the last move (pixels).
    pub final_error: f32,
    /// Fine moves made.
    pub fine_moves: u8,
    /// True when the loop ended at the cap on fine moves rather than within tolerance.
    pub cap_hit: bool,
    /// The tolerance the loop aimed at (pixels).
    pub tolerance: f32,
    /// Jacobian updates skipped because `dv` was (almost) zero ([`Error::ZeroLengthDv`]):
    /// the tables' while learning, the trial's secant correction
    /// ([`crate::StageConfig::trial_secant`]) in mature operation.
    pub skipped_updates: u8,
    /// Error after the coarse move and after each fine move (first `1 + fine_moves` entries,
    /// at most [`TRACE_LEN`]).
    pub trace: [f32; TRACE_LEN],
}

/// An all-zero outcome (the state before any trial).
pub const ZERO_OUTCOME: StageOutcome = StageOutcome {
    t: 0,
    learned: false,
    supervised: false,
    coarse_error: 0.0,
    final_error: 0.0,
    fine_moves: 0,
    cap_hit: false,
    tolerance: 0.0,
    skipped_updates: 0,
    trace: [0.0; TRACE_LEN],
};

/// How many fine moves a trial makes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
#[repr(u8)]
pub enum FineMoves {
    /// The controller's rule: fine moves until the error is within the tolerance (8.7), at
    /// most [`StageConfig::max_fine_moves`].
    #[default]
    Policy,
    /// Exactly this many fine moves, never stopping early (at most [`TRACE_LEN`] - 1): the
    /// evaluation's fixed move budget, so every trial's error is known after every move.
    Exactly(u8),
}

impl FineMoves {
    /// The fixed budget, if one is asked for: `None` for the controller's rule;
    /// [`Error::FineMoveBudget`] beyond what a trial can trace ([`TRACE_LEN`] - 1).
    pub fn budget(self) -> Result<Option<u8>> {
        match self {
            FineMoves::Policy => Ok(None),
            FineMoves::Exactly(n) if (n as usize) < TRACE_LEN => Ok(Some(n)),
            FineMoves::Exactly(_) => Err(Error::FineMoveBudget),
        }
    }
}

/// A target or observation as a stage accepts it: finite, within the configured range.
pub fn check_input<const D: usize>(cfg: &StageConfig, u: &[f32; D]) -> Result<()> {
    for (i, &x) in u.iter().enumerate() {
        if !x.is_finite() {
            return Err(Error::NonFiniteInput { index: i as u8 });
        }
        if x < cfg.input_min || x > cfg.input_max {
            return Err(Error::InputOutOfRange {
                index: i as u8,
                value: x,
            });
        }
    }
    Ok(())
}

/// Euclidean distance of two image vectors (pixels).
pub(crate) fn distance<const D: usize>(a: &[f32; D], b: &[f32; D]) -> f32 {
    libm::sqrtf(a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum())
}

/// `a - b`, element by element.
pub(crate) fn sub<const M: usize>(a: &[f32; M], b: &[f32; M]) -> [f32; M] {
    core::array::from_fn(|i| a[i] - b[i])
}
