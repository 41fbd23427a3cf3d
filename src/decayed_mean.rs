//! A decayed, weighted mean and spread of a quantity observed once a frame.
//!
//! Two stages learn a steady quantity from a track's frames: the streak length the fit reads
//! long or short (`track::length_offset`) and the tone exponent the fit reads
//! (`detect::tone_memory`). Both weigh each frame by the inverse of its stated variance and
//! forget the older frames geometrically, so that a quantity that changes is followed. The
//! sums are kept here once; what each makes of them (a t-test, a prior's spread) stays with it.
//!
//! Fixed size: three sums and a count.

/// The decayed sums of weighted observations.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct DecayedMean {
    /// Sum of the weights.
    weights: f32,
    /// Sum of the weighted values.
    weighted: f32,
    /// Sum of the weighted squared values.
    weighted_sq: f32,
    /// Observations so far (saturating).
    observations: u32,
}

impl DecayedMean {
    /// Scales the sums so far by `keep` (`1 − 1 / frames remembered`) and adds `value` with
    /// `weight`.
    pub fn add(&mut self, value: f32, weight: f32, keep: f32) {
        self.weights = keep * self.weights + weight;
        self.weighted = keep * self.weighted + weight * value;
        self.weighted_sq = keep * self.weighted_sq + weight * value * value;
        self.observations = self.observations.saturating_add(1);
    }

    /// The decayed sum of the weights.
    pub fn weights(&self) -> f32 {
        self.weights
    }

    /// The observations added so far.
    pub fn observations(&self) -> u32 {
        self.observations
    }

    /// The weighted mean (NaN before any weight).
    pub fn mean(&self) -> f32 {
        self.weighted / self.weights
    }

    /// The weighted mean of the squared values (NaN before any weight).
    pub fn mean_square(&self) -> f32 {
        self.weighted_sq / self.weights
    }

    /// The weighted variance of the values about their mean (never negative).
    pub fn scatter(&self) -> f32 {
        let mean = self.mean();
        (self.mean_square() - mean * mean).max(0.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn equal_weights_without_decay_give_the_plain_mean_and_variance() {
        let mut m = DecayedMean::default();
        for v in [1.0, 2.0, 3.0, 6.0] {
            m.add(v, 2.0, 1.0);
        }
        assert_eq!(m.observations(), 4);
        assert!((m.mean() - 3.0).abs() < 1e-6, "{m:?}");
        // (4 + 1 + 0 + 9) / 4
        assert!((m.scatter() - 3.5).abs() < 1e-5, "{m:?}");
    }

    #[test]
    fn the_older_observations_fade_and_the_heavier_count_more() {
        let mut m = DecayedMean::default();
        for _ in 0..100 {
            m.add(10.0, 1.0, 0.5);
        }
        for _ in 0..20 {
            m.add(2.0, 1.0, 0.5);
        }
        assert!((m.mean() - 2.0).abs() < 1e-3, "{m:?}");
        let mut m = DecayedMean::default();
        m.add(0.0, 1.0, 1.0);
        m.add(4.0, 3.0, 1.0);
        assert!((m.mean() - 3.0).abs() < 1e-6, "{m:?}");
    }
}
