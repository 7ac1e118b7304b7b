//! What a network table stores per value: `f32` (the default build), or `i16` fixed point
//! with a power-of-two step per table (the `compact` feature, for 128 KiB parts; issue 18).
//!
//! The rules compute in f32 either way: each entry is read as f32 ([`Entry::get`]), the
//! update computed as before, and the result written back ([`Entry::put`]). For `f32` both
//! are the identity, so the default build's arithmetic and results are unchanged. For
//! `i16` a write rounds to the nearest step (ties to even) and saturates at the
//! table's range ([`TableScales`], chosen from the magnitudes trained networks reach, with
//! headroom); an update smaller than half a step is lost, which is the compact build's
//! accuracy cost (measured in the README's speed section).

/// One table's fixed-point step (a power of two, so that `i * step` is exact).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Scale {
    /// Value of one unit.
    pub step: f32,
    /// `1 / step`.
    pub inv: f32,
}

impl Scale {
    /// The scale with step `2^-bits`.
    pub const fn pow2(bits: i32) -> Scale {
        // 2^-bits and 2^bits as f32 bit patterns (exponent field only)
        Scale {
            step: f32::from_bits(((127 - bits) as u32) << 23),
            inv: f32::from_bits(((127 + bits) as u32) << 23),
        }
    }

    /// The largest magnitude an `i16` entry holds at this scale.
    pub fn i16_max(&self) -> f32 {
        i16::MAX as f32 * self.step
    }
}

/// The steps of the three tables of a compact network (both stages).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TableScales {
    /// Weights (pixels).
    pub w: Scale,
    /// Pressures (normalised, `±1` commanded).
    pub p: Scale,
    /// Jacobians (pressure per pixel).
    pub a: Scale,
}

/// The compact build's steps, from the magnitudes of trained networks (tuning seeds 1 and 3,
/// realistic plant, 300 trials; largest magnitude over both stages, 99th percentile):
/// weights up to 1,024 px (1,006): `2^-5` px, range `±1,024` px; pressures up to 2.05 (1.0):
/// `2^-13`, range `±4`; Jacobian entries up to 0.032 (0.019): `2^-18`, range `±0.125` (4x
/// headroom), resolution 3.8e-6, under 0.1 % of a typical entry (0.005).
pub const TABLE_SCALES: TableScales = TableScales {
    w: Scale::pow2(5),
    p: Scale::pow2(13),
    a: Scale::pow2(18),
};

/// A table value as stored.
pub trait Entry: Copy + PartialEq + core::fmt::Debug + Send + Sync + 'static {
    /// Zero.
    const ZERO: Self;
    /// The value, in f32.
    fn get(self, scale: Scale) -> f32;
    /// The entry that stores `x` (rounded and saturated for fixed point).
    fn put(x: f32, scale: Scale) -> Self;
    /// The largest magnitude an entry holds at `scale`.
    fn max_abs(scale: Scale) -> f32;
}

impl Entry for f32 {
    const ZERO: Self = 0.0;
    #[inline(always)]
    fn get(self, _: Scale) -> f32 {
        self
    }
    #[inline(always)]
    fn put(x: f32, _: Scale) -> Self {
        x
    }
    fn max_abs(_: Scale) -> f32 {
        f32::MAX
    }
}

impl Entry for i16 {
    const ZERO: Self = 0;
    #[inline(always)]
    fn get(self, scale: Scale) -> f32 {
        self as f32 * scale.step
    }
    #[inline(always)]
    fn put(x: f32, scale: Scale) -> Self {
        // to the nearest integer, ties to even, by adding and subtracting 1.5 * 2^23 (exact
        // for |q| < 2^22; beyond, the result is still far outside the i16 range, with its
        // sign, and saturates); then saturated to the i16 range (on the Cortex-M4F: `vadd`,
        // `vsub`, `vcvt`, `ssat`, no branches). NaN gives 0 (`as` on NaN; inputs and
        // tables are checked finite before they reach an update).
        const ROUND: f32 = 12_582_912.0;
        let q = x * scale.inv;
        let r = (q + ROUND) - ROUND;
        (r as i32).clamp(i16::MIN as i32, i16::MAX as i32) as i16
    }
    fn max_abs(scale: Scale) -> f32 {
        scale.i16_max()
    }
}

/// The entry type of this build's tables: `f32`, or `i16` with the `compact` feature.
#[cfg(not(feature = "compact"))]
pub type Table = f32;
/// The entry type of this build's tables: `f32`, or `i16` with the `compact` feature.
#[cfg(feature = "compact")]
pub type Table = i16;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scales_are_powers_of_two() {
        assert_eq!(Scale::pow2(5).step, 1.0 / 32.0);
        assert_eq!(Scale::pow2(5).inv, 32.0);
        assert_eq!(Scale::pow2(18).step, 1.0 / 262_144.0);
        assert_eq!(Scale::pow2(-2).step, 4.0);
    }

    #[test]
    fn f32_entries_are_the_values() {
        let s = TABLE_SCALES.a;
        for x in [0.0f32, -0.0, 1.0e-30, 0.123_456_79, -5.0e6] {
            assert_eq!(f32::put(x, s).get(s).to_bits(), x.to_bits());
        }
    }

    #[test]
    fn i16_entries_round_to_the_nearest_step_and_saturate() {
        let s = TABLE_SCALES.w; // 1/32 px
        assert_eq!(i16::put(10.0, s), 320);
        assert_eq!(i16::put(10.0 + 0.4 / 32.0, s), 320);
        assert_eq!(i16::put(10.0 + 0.6 / 32.0, s), 321);
        assert_eq!(i16::put(0.5 / 32.0, s), 0); // ties to even
        assert_eq!(i16::put(1.5 / 32.0, s), 2);
        assert_eq!(i16::put(-0.5 / 32.0, s), 0);
        assert_eq!(i16::put(-1.5 / 32.0, s), -2);
        assert_eq!(i16::put(1.0e30, s), i16::MAX);
        assert_eq!(i16::put(-1.0e30, s), i16::MIN);
        assert_eq!(i16::put(f32::INFINITY, s), i16::MAX);
        assert_eq!(i16::put(-10.0 - 0.6 / 32.0, s), -321);
        assert_eq!(i16::put(5000.0, s), i16::MAX);
        assert_eq!(i16::put(-5000.0, s), i16::MIN);
        assert_eq!(i16::put(f32::NAN, s), 0);
        for x in [-1000.0f32, -3.3, 0.0, 0.01, 511.99, 1023.9] {
            assert!((i16::put(x, s).get(s) - x).abs() <= 0.5 * s.step, "{x}");
        }
        assert_eq!(i16::max_abs(s), 32767.0 / 32.0);
    }
}
