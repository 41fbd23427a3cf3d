//! The tone exponent one LED's fits have read, frame after frame, as a prior for the next fit.
//!
//! The fit's model maps light to luma through `v^k` (see [`super::fit`]). On a spot whose core
//! is clipped far into its glow, the unclipped pixels are nearly all glow, and `k` trades
//! against the spot's width and brightness along a valley the pixels hardly tell apart: on
//! sweep seed 12's point 109 (a bloom clipped 14×, an 8.3 px line) the fitted `k` read
//! 0.32–0.41 in frames 3–6 and then ran to its lower bound (0.2) in frames 7–9, with the core
//! as wide as the glow and the lengths 13–20 % short at stated deviations of 0.3–0.5 px. The
//! tone is the camera's and the spot the same LED's from one frame to the next, so what the
//! frames before read of `k` says what this frame's is: their weighted mean, and as its
//! spread the larger of their scatter and their own stated deviation.
//!
//! Fixed size: a few sums, kept with the LED's [`super::fit::SpotFit`].

use crate::decayed_mean::DecayedMean;

/// The frames an observation is remembered for: each new one scales the older ones down by
/// `1 − 1 / MEMORY_FRAMES` (as the learned length offset's, see
/// `crate::track::length_offset`), so that a tone that changes (an exposure that changed)
/// is followed.
const MEMORY_FRAMES: f32 = 16.0;
/// Observations below which there is no prior: the scatter of two is no measure of it.
const MIN_OBSERVATIONS: u32 = 3;

/// The decayed, weighted sums of one LED's fitted tone exponents.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct ToneMemory {
    /// The exponents, each weighed by the inverse of its variance.
    tones: DecayedMean,
    /// The decayed count of observations (for the stated variance of one).
    count: f32,
}

/// What the frames before say of this frame's tone exponent: its mean and the variance of
/// one frame's about it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TonePrior {
    /// The exponent the frames before read (their weighted mean).
    pub tone: f32,
    /// The variance of one frame's exponent about it.
    pub variance: f32,
}

impl ToneMemory {
    /// This memory with one more fit's exponent `tone` of variance `variance`, the pixels'
    /// own (without the prior the fit was given).
    pub fn with(self, tone: f32, variance: f32) -> ToneMemory {
        if !(tone.is_finite() && variance.is_finite() && variance > 0.0) {
            return self;
        }
        let keep = 1.0 - 1.0 / MEMORY_FRAMES;
        let mut tones = self.tones;
        tones.add(tone, 1.0 / variance, keep);
        ToneMemory {
            tones,
            count: keep * self.count + 1.0,
        }
    }

    /// The prior for the next frame's exponent, `None` before three observations.
    pub fn prior(&self) -> Option<TonePrior> {
        let t = &self.tones;
        if t.observations() < MIN_OBSERVATIONS || t.weights() <= 0.0 {
            return None;
        }
        // One observation's stated variance: the harmonic mean of theirs.
        let stated = self.count / t.weights();
        Some(TonePrior {
            tone: t.mean(),
            variance: t.scatter().max(stated),
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_steady_tone_is_the_prior_and_its_spread_the_larger_of_scatter_and_stated() {
        let mut m = ToneMemory::default();
        for k in [0.40, 0.44, 0.42] {
            assert_eq!(m.prior(), None, "before three observations");
            m = m.with(k, 1e-4);
        }
        let p = m.prior().expect("a prior after three");
        assert!((p.tone - 0.42).abs() < 0.005, "{p:?}");
        // Scatter about 0.016 (variance 2.7e-4) beyond the stated 1e-4.
        assert!(p.variance > 2e-4 && p.variance < 4e-4, "{p:?}");
        // Stated variances larger than the scatter set the spread.
        let mut m = ToneMemory::default();
        for k in [0.40, 0.41, 0.40, 0.41] {
            m = m.with(k, 0.01);
        }
        let p = m.prior().expect("a prior");
        assert!((p.variance - 0.01).abs() < 1e-3, "{p:?}");
    }

    #[test]
    fn an_uncertain_observation_weighs_little_and_a_broken_one_nothing() {
        let mut m = ToneMemory::default();
        for _ in 0..4 {
            m = m.with(0.45, 1e-4);
        }
        let before = m;
        assert_eq!(m.with(f32::NAN, 1e-4), before);
        assert_eq!(m.with(0.3, f32::INFINITY), before);
        assert_eq!(m.with(0.3, 0.0), before);
        let p = m.with(0.2, 1.0).prior().expect("a prior");
        assert!((p.tone - 0.45).abs() < 0.001, "{p:?}");
    }
}
