//! The seam between the controller and a stage's control law ([`StageLaw`]): what the
//! two-stage grasp asks of a law for one network, whatever the law is (the TRN's
//! [`crate::stage::Stage`], the Broyden servo's [`crate::broyden::BroydenStage`]). The
//! controller picks the law for a stage in one place ([`crate::Controller`]); adding a law
//! is an implementation of this trait and a wire code.

use crate::error::{Error, Result};
use crate::rank::RankScratch;
use crate::trial::{FineMoves, StageStep};

/// One stage's control law: a target in, pressures out, each observation back in, until
/// the trial's outcome.
pub trait StageLaw<const D: usize, const M: usize> {
    /// Checks a target or observation as the law accepts it.
    fn check_input(&self, u: &[f32; D]) -> Result<()>;
    /// Starts a trial towards `target`: the first pressures. `supervised` is the pressure
    /// that produced the target when known (priming) and `learn` asks to update the
    /// tables: a law that does not learn ignores both (it may report a supervised trial as
    /// such). `scratch` is working memory the controller shares between its stages.
    fn begin(
        &mut self,
        target: &[f32; D],
        supervised: Option<&[f32; M]>,
        learn: bool,
        fine: FineMoves,
        scratch: &mut RankScratch,
    ) -> Result<[f32; M]>;
    /// The observation after the last move: the next pressures, or the trial's outcome.
    /// `scratch` as in [`StageLaw::begin`].
    fn observe(&mut self, u: &[f32; D], scratch: &mut RankScratch) -> Result<StageStep<M>>;
    /// Abandons the running trial.
    fn abort(&mut self);
    /// Experiment (`StageConfig::loop_offset`): the pressures the drives hold before the
    /// stage's next trial (the controller's last command on each of the stage's channels).
    fn note_held(&mut self, _held: &[f32; M]) {}
}

/// A law this build leaves out: every trial is refused ([`Error::UnsupportedLaw`]).
#[derive(Debug, Clone, Copy, Default)]
pub struct Absent;

impl<const D: usize, const M: usize> StageLaw<D, M> for Absent {
    fn check_input(&self, _u: &[f32; D]) -> Result<()> {
        Err(Error::UnsupportedLaw)
    }
    fn begin(
        &mut self,
        _target: &[f32; D],
        _supervised: Option<&[f32; M]>,
        _learn: bool,
        _fine: FineMoves,
        _scratch: &mut RankScratch,
    ) -> Result<[f32; M]> {
        Err(Error::UnsupportedLaw)
    }
    fn observe(&mut self, _u: &[f32; D], _scratch: &mut RankScratch) -> Result<StageStep<M>> {
        Err(Error::UnsupportedLaw)
    }
    fn abort(&mut self) {}
}
