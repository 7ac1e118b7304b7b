//! The Broyden servo's two stages as the controller holds them; without the cargo feature
//! `broyden`, a stand-in of no size whose stages refuse every trial
//! ([`crate::Error::UnsupportedLaw`]).

use super::BroydenConfig;
#[cfg(feature = "broyden")]
use super::BroydenStage;
use crate::config::StageConfig;
use crate::error::Result;
#[cfg(not(feature = "broyden"))]
use crate::law::Absent;
use crate::law::StageLaw;

/// Stage 1 (8-D lights, 5 joints) and stage 2 (4-D centre, 3 joints) of the servo.
#[cfg(feature = "broyden")]
#[derive(Debug, Clone)]
pub(crate) struct BroydenPair {
    pub(crate) stage1: BroydenStage<8, 5>,
    pub(crate) stage2: BroydenStage<4, 3>,
}

/// The servo left out of the build: its stages refuse every trial.
#[cfg(not(feature = "broyden"))]
#[derive(Debug, Clone)]
pub(crate) struct BroydenPair {
    absent: Absent,
}

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

    /// Stage 1's law.
    pub(crate) fn law1(&mut self) -> &mut dyn StageLaw<8, 5> {
        &mut self.stage1
    }

    /// Stage 2's law.
    pub(crate) fn law2(&mut self) -> &mut dyn StageLaw<4, 3> {
        &mut self.stage2
    }
}

#[cfg(not(feature = "broyden"))]
impl BroydenPair {
    /// Whether this build runs the servo.
    pub(crate) const BUILT: bool = false;

    pub(crate) const fn new(_s1: StageConfig, _s2: StageConfig, _b: BroydenConfig) -> Self {
        BroydenPair { absent: Absent }
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

    /// Stage 1's law: absent.
    pub(crate) fn law1(&mut self) -> &mut dyn StageLaw<8, 5> {
        &mut self.absent
    }

    /// Stage 2's law: absent.
    pub(crate) fn law2(&mut self) -> &mut dyn StageLaw<4, 3> {
        &mut self.absent
    }
}
