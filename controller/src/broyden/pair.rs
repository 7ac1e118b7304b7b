//! The Broyden servo's two stages as the controller holds them; without the cargo feature
//! `broyden`, a stand-in of no size that refuses the law ([`Error::UnsupportedLaw`]).

use super::BroydenConfig;
#[cfg(feature = "broyden")]
use super::BroydenStage;
use crate::config::StageConfig;
#[cfg(not(feature = "broyden"))]
use crate::error::Error;
use crate::error::Result;
use crate::stage::{FineMoves, StageStep};

/// Stage 1 (8-D lights, 5 joints) and stage 2 (4-D centre, 3 joints) of the servo.
#[cfg(feature = "broyden")]
#[derive(Debug, Clone)]
pub(crate) struct BroydenPair {
    pub(crate) stage1: BroydenStage<8, 5>,
    pub(crate) stage2: BroydenStage<4, 3>,
}

/// The servo left out of the build: every call that would run it fails.
#[cfg(not(feature = "broyden"))]
#[derive(Debug, Clone)]
pub(crate) struct BroydenPair;

#[cfg(feature = "broyden")]
impl BroydenPair {
    /// Whether this build runs the servo.
    pub(crate) const BUILT: bool = true;

    pub(crate) const fn new(s1: StageConfig, s2: StageConfig, b: BroydenConfig) -> Self {
        BroydenPair {
            stage1: BroydenStage::new(s1, b),
            stage2: BroydenStage::new(s2, b),
        }
    }

    pub(crate) fn reset(&mut self) {
        self.stage1.reset();
        self.stage2.reset();
    }

    pub(crate) fn set_config(
        &mut self,
        s1: StageConfig,
        s2: StageConfig,
        b: BroydenConfig,
    ) -> Result<()> {
        self.stage1.set_config(s1, b)?;
        self.stage2.set_config(s2, b)
    }

    pub(crate) fn abort(&mut self) {
        self.stage1.abort();
        self.stage2.abort();
    }

    pub(crate) fn check_input2(&self, c: &[f32; 4]) -> Result<()> {
        self.stage2.check_input(c)
    }

    pub(crate) fn begin1(
        &mut self,
        v: &[f32; 8],
        supervised: bool,
        fine: FineMoves,
    ) -> Result<[f32; 5]> {
        self.stage1.begin_with(v, supervised, fine)
    }

    pub(crate) fn observe1(&mut self, v: &[f32; 8]) -> Result<StageStep<5>> {
        self.stage1.observe(v)
    }

    pub(crate) fn begin2(&mut self, c: &[f32; 4], fine: FineMoves) -> Result<[f32; 3]> {
        self.stage2.begin_with(c, false, fine)
    }

    pub(crate) fn observe2(&mut self, c: &[f32; 4]) -> Result<StageStep<3>> {
        self.stage2.observe(c)
    }
}

#[cfg(not(feature = "broyden"))]
impl BroydenPair {
    /// Whether this build runs the servo.
    pub(crate) const BUILT: bool = false;

    pub(crate) const fn new(_s1: StageConfig, _s2: StageConfig, _b: BroydenConfig) -> Self {
        BroydenPair
    }

    pub(crate) fn reset(&mut self) {}

    pub(crate) fn set_config(
        &mut self,
        _s1: StageConfig,
        _s2: StageConfig,
        _b: BroydenConfig,
    ) -> Result<()> {
        Ok(())
    }

    pub(crate) fn abort(&mut self) {}

    pub(crate) fn check_input2(&self, _c: &[f32; 4]) -> Result<()> {
        Err(Error::UnsupportedLaw)
    }

    pub(crate) fn begin1(
        &mut self,
        _v: &[f32; 8],
        _supervised: bool,
        _fine: FineMoves,
    ) -> Result<[f32; 5]> {
        Err(Error::UnsupportedLaw)
    }

    pub(crate) fn observe1(&mut self, _v: &[f32; 8]) -> Result<StageStep<5>> {
        Err(Error::UnsupportedLaw)
    }

    pub(crate) fn begin2(&mut self, _c: &[f32; 4], _fine: FineMoves) -> Result<[f32; 3]> {
        Err(Error::UnsupportedLaw)
    }

    pub(crate) fn observe2(&mut self, _c: &[f32; 4]) -> Result<StageStep<3>> {
        Err(Error::UnsupportedLaw)
    }
}
