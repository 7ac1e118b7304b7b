//! Seeded random draws of the simulator (every RNG is a `Xoshiro256PlusPlus`).

use rand_core::RngCore;

/// A standard normal draw (Box-Muller).
pub fn gaussian(rng: &mut impl RngCore) -> f64 {
    // Box-Muller from two uniforms in (0, 1]
    let u1 = ((rng.next_u64() >> 11) as f64 + 1.0) / (1u64 << 53) as f64;
    let u2 = (rng.next_u64() >> 11) as f64 / (1u64 << 53) as f64;
    (-2.0 * u1.ln()).sqrt() * (2.0 * std::f64::consts::PI * u2).cos()
}

/// Uniform in `[lo, hi)`.
pub fn uniform(rng: &mut impl RngCore, lo: f64, hi: f64) -> f64 {
    lo + (hi - lo) * ((rng.next_u64() >> 11) as f64 / (1u64 << 53) as f64)
}
