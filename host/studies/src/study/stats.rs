//! Figures over seeds and over targets: the mean, the spread, the worst seed and the tails.
//! The project reports tails, not only means: a table cell is the mean ± the standard
//! deviation over the seeds with the worst seed beside it, and the per-target errors of
//! every seed pooled give percentiles.

use serde::{Deserialize, Serialize};

use trn_bench::format::px;
use trn_bench::report::mean;

/// Which way a figure is worse.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Worse {
    /// Larger is worse (errors, moves, time).
    Higher,
    /// Smaller is worse (success rates).
    Lower,
}

/// One figure over the seeds.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Spread {
    /// Mean of the finite values (NaN: none).
    pub mean: f32,
    /// Sample standard deviation (NaN: fewer than two values).
    pub sd: f32,
    /// The worst seed's value (NaN: none).
    pub worst: f32,
    /// Seeds with a finite value.
    pub n: usize,
}

impl Spread {
    /// No value (a figure a report does not have).
    pub fn none() -> Spread {
        Spread::of(&[], Worse::Higher)
    }

    /// The spread of the finite values of `x`.
    pub fn of(x: &[f32], worse: Worse) -> Spread {
        let v: Vec<f32> = x.iter().copied().filter(|v| v.is_finite()).collect();
        let m = mean(&v);
        let sd = if v.len() > 1 {
            (v.iter().map(|x| (x - m) * (x - m)).sum::<f32>() / (v.len() - 1) as f32).sqrt()
        } else {
            f32::NAN
        };
        let worst = v.iter().copied().fold(f32::NAN, |w, x| match worse {
            _ if w.is_nan() => x,
            Worse::Higher => w.max(x),
            Worse::Lower => w.min(x),
        });
        Spread {
            mean: m,
            sd,
            worst,
            n: v.len(),
        }
    }

    /// `mean ± sd (worst)`, two decimals; with one seed the mean alone.
    pub fn cell(&self) -> String {
        if self.n <= 1 {
            return px(self.mean);
        }
        format!("{} ± {} ({})", px(self.mean), px(self.sd), px(self.worst))
    }
}

/// The tail of a distribution (per-target errors pooled over seeds).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Tail {
    /// Finite values.
    pub n: usize,
    /// Median.
    pub p50: f32,
    /// 90th percentile.
    pub p90: f32,
    /// 99th percentile.
    pub p99: f32,
    /// Largest.
    pub max: f32,
}

impl Tail {
    /// The percentiles of the finite values of `x` (nearest rank; NaN when there are none).
    pub fn of(x: &[f32]) -> Tail {
        let mut v: Vec<f32> = x.iter().copied().filter(|v| v.is_finite()).collect();
        v.sort_by(f32::total_cmp);
        Tail {
            n: v.len(),
            p50: percentile(&v, 50.0),
            p90: percentile(&v, 90.0),
            p99: percentile(&v, 99.0),
            max: v.last().copied().unwrap_or(f32::NAN),
        }
    }

    /// `p50 / p90 / max`.
    pub fn cell(&self) -> String {
        format!("{} / {} / {}", px(self.p50), px(self.p90), px(self.max))
    }
}

/// The `p`-th percentile of sorted values by nearest rank (the smallest value with at least
/// `p` % of the values at or below it); NaN for no values.
pub fn percentile(sorted: &[f32], p: f64) -> f32 {
    if sorted.is_empty() {
        return f32::NAN;
    }
    let rank = ((p / 100.0) * sorted.len() as f64).ceil() as usize;
    sorted[rank.clamp(1, sorted.len()) - 1]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn spread_and_worst_seed() {
        let s = Spread::of(&[1.0, 3.0, f32::NAN, 2.0], Worse::Higher);
        assert_eq!((s.mean, s.sd, s.worst, s.n), (2.0, 1.0, 3.0, 3));
        assert_eq!(Spread::of(&[0.9, 0.5, 1.0], Worse::Lower).worst, 0.5);
        assert_eq!(s.cell(), "2.00 ± 1.00 (3.00)");
        let none = Spread::of(&[f32::NAN], Worse::Higher);
        assert!(none.mean.is_nan() && none.worst.is_nan() && none.n == 0);
    }

    #[test]
    fn nearest_rank_percentiles() {
        let v: Vec<f32> = (1..=100).map(|i| i as f32).collect();
        let t = Tail::of(&v);
        assert_eq!(
            (t.p50, t.p90, t.p99, t.max, t.n),
            (50.0, 90.0, 99.0, 100.0, 100)
        );
        assert_eq!(percentile(&[7.0], 90.0), 7.0);
        assert_eq!(percentile(&[1.0, 2.0, 3.0], 50.0), 2.0);
        assert!(Tail::of(&[]).p90.is_nan());
    }
}
