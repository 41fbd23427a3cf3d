//! Summaries of per-frame numbers (errors against the truth, times): median, 95th percentile
//! and maximum, by the nearest-rank method so every reported value is one that occurred.

/// The spread of a set of non-negative numbers.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Spread {
    /// How many numbers (NaNs are left out).
    pub count: usize,
    pub median: f64,
    pub p95: f64,
    pub max: f64,
}

impl Spread {
    /// The spread of `values`, ignoring NaNs; `None` when nothing is left.
    pub fn of(values: &[f64]) -> Option<Spread> {
        let mut sorted: Vec<f64> = values.iter().copied().filter(|v| !v.is_nan()).collect();
        sorted.sort_by(f64::total_cmp);
        Some(Spread {
            count: sorted.len(),
            median: percentile(&sorted, 50.0)?,
            p95: percentile(&sorted, 95.0)?,
            max: *sorted.last()?,
        })
    }
}

/// The `p`-th percentile of `sorted` by nearest rank: the smallest value with at least `p` %
/// of the values at or below it.
pub fn percentile(sorted: &[f64], p: f64) -> Option<f64> {
    let rank = (p.clamp(0.0, 100.0) / 100.0 * sorted.len() as f64).ceil() as usize;
    sorted.get(rank.max(1) - 1).copied()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nearest_rank_percentiles() {
        let hundred: Vec<f64> = (1..=100).map(f64::from).collect();
        assert_eq!(percentile(&hundred, 50.0), Some(50.0));
        assert_eq!(percentile(&hundred, 95.0), Some(95.0));
        assert_eq!(percentile(&hundred, 0.0), Some(1.0));
        assert_eq!(percentile(&hundred, 100.0), Some(100.0));
        assert_eq!(percentile(&[], 50.0), None);
    }

    #[test]
    fn spread_sorts_and_skips_nans() {
        let s = Spread::of(&[3.0, f64::NAN, 1.0, 2.0]).unwrap();
        assert_eq!(s.count, 3);
        assert_eq!((s.median, s.p95, s.max), (2.0, 3.0, 3.0));
        assert_eq!(Spread::of(&[f64::NAN]), None);
    }
}
