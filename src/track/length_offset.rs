//! How far the streak model reads one LED's path long or short, learned from the middles'
//! motion over the frames of its track.
//!
//! The fitted streak model has one family of spots (a Gaussian core in a Gaussian glow). A real
//! spot outside that family puts the fitted ends a steady distance off the true ones: a
//! defocused disk's sharp rim reads each end about half a pixel short, a core in power-law
//! wings reads each 1–2 px long. The offset is the same in every frame of the same LED at
//! about the same speed, so it biases the single frame's speed (length over exposure) by a
//! fixed number of pixels however long the exposure averages. The streak's middle carries no
//! such offset (its ends err alike on both sides), and the middles' motion gives the path's
//! length over the exposure without reading an end ([`MotionHead::path_px`], noisy in one
//! frame). Their difference, averaged over the track's recent frames, is the offset; the
//! single frame's length less the offset is what the frame says about the speed.
//!
//! Only an offset beyond its own scatter is taken off: an unbiased model's mean difference is
//! noise, and taking it off would add that noise to every frame.
//!
//! [`MotionHead::path_px`]: super::motion::MotionHead::path_px

/// The frames an observation is remembered for: each new one scales the older ones down by
/// `1 − 1 / MEMORY_FRAMES`, so that a speed that changes (and with it how far the clip
/// reaches along the streak) is followed within about this many frames.
const MEMORY_FRAMES: f32 = 16.0;
/// Observations below which nothing is taken off: the scatter of two is no measure of it.
const MIN_OBSERVATIONS: u32 = 3;
/// The mean difference is taken as an offset when it is beyond its standard error (the larger
/// of the one the observations' stated variances give and the one their scatter gives: a
/// fit's stated deviation may be too small, and so may a few observations' scatter) times
/// Student's t at 99 % two-sided for that scatter's degrees of freedom (index: degrees − 1).
/// A few frames' scatter says little about itself, and the t quantile says by how much.
const T_99: [f32; 30] = [
    63.66, 9.925, 5.841, 4.604, 4.032, 3.707, 3.499, 3.355, 3.250, 3.169, 3.106, 3.055, 3.012,
    2.977, 2.947, 2.921, 2.898, 2.878, 2.861, 2.845, 2.831, 2.819, 2.807, 2.797, 2.787, 2.779,
    2.771, 2.763, 2.756, 2.750,
];
/// The least variance an observation is weighted by (px²): a fit that claims to be exact is
/// not worth more than one of a tenth of a pixel.
const MIN_VARIANCE_PX2: f32 = 0.01;

/// The decayed, weighted sums of one track's length differences (single frame's path less
/// the motion's path over the exposure, px).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct LengthOffset {
    /// Sum of the weights.
    weights: f32,
    /// Sum of the weighted differences (px).
    weighted_px: f32,
    /// Sum of the weighted squared differences (px²).
    weighted_sq_px2: f32,
    /// Sum of the squared weights (for the effective number of observations).
    weights_sq: f32,
    /// Sum of the squared weights times the stated variances (for the stated variance of the
    /// weighted mean: each weight is the inverse of its observation's variance when new, and
    /// decays while the variance stays).
    stated_px2: f32,
    /// Observations so far (saturating).
    observations: u32,
}

impl LengthOffset {
    /// Enters one frame's single-frame path length and the motion's path over the same
    /// exposure, with the variance of their difference.
    pub fn observe(&mut self, streak_px: f32, motion_px: f32, variance_px2: f32) {
        let difference_px = streak_px - motion_px;
        if !difference_px.is_finite() || !variance_px2.is_finite() {
            return;
        }
        let keep = 1.0 - 1.0 / MEMORY_FRAMES;
        let w = 1.0 / variance_px2.max(MIN_VARIANCE_PX2);
        self.weights = keep * self.weights + w;
        self.weighted_px = keep * self.weighted_px + w * difference_px;
        self.weighted_sq_px2 = keep * self.weighted_sq_px2 + w * difference_px * difference_px;
        self.weights_sq = keep * keep * self.weights_sq + w * w;
        self.stated_px2 = keep * keep * self.stated_px2 + w;
        self.observations = self.observations.saturating_add(1);
    }

    /// The offset to take off a single frame's path length (px): the mean difference where
    /// it is beyond its scatter, else 0.
    pub fn offset_px(&self) -> f32 {
        if self.observations < MIN_OBSERVATIONS {
            return 0.0;
        }
        let effective = self.weights * self.weights / self.weights_sq;
        let mean_px = self.weighted_px / self.weights;
        let scatter_px2 = (self.weighted_sq_px2 / self.weights - mean_px * mean_px).max(0.0);
        let degrees = (effective - 1.0).max(1.0);
        let standard_error_px = (scatter_px2 / degrees)
            .max(self.stated_px2 / (self.weights * self.weights))
            .sqrt();
        let t = T_99[(degrees as usize).clamp(1, T_99.len()) - 1];
        if mean_px.abs() > t * standard_error_px {
            mean_px
        } else {
            0.0
        }
    }

    /// Forgets everything: a new track may be another LED.
    pub fn clear(&mut self) {
        *self = LengthOffset::default();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A small deterministic noise in [-1, 1].
    fn noise(i: u32) -> f32 {
        let x = (i.wrapping_mul(2_654_435_761) >> 8) as f32 / (1u32 << 24) as f32;
        2.0 * x - 1.0
    }

    #[test]
    fn a_steady_offset_is_learned_within_its_noise() {
        let mut o = LengthOffset::default();
        for i in 0..20 {
            // The streak reads 0.9 px short; the motion's path is noisy by ±0.3 px.
            o.observe(9.5 + 0.1 * noise(i), 10.4 + 0.3 * noise(i + 100), 0.05);
        }
        assert!((o.offset_px() + 0.9).abs() < 0.15, "{}", o.offset_px());
    }

    #[test]
    fn an_unbiased_model_gets_no_correction() {
        let mut o = LengthOffset::default();
        for i in 0..40 {
            o.observe(10.0 + 0.3 * noise(i), 10.0 + 0.3 * noise(i + 1000), 0.2);
            assert_eq!(o.offset_px(), 0.0, "after {} frames", i + 1);
        }
    }

    #[test]
    fn too_few_frames_say_nothing() {
        let mut o = LengthOffset::default();
        for _ in 0..3 {
            o.observe(12.0, 10.0, 0.05);
        }
        // Three give under two degrees of freedom: t times the stated error is 8 px; four
        // give three: 1.1 px.
        assert_eq!(o.offset_px(), 0.0);
        o.observe(12.0, 10.0, 0.05);
        assert!((o.offset_px() - 2.0).abs() < 1e-4, "{}", o.offset_px());
    }

    #[test]
    fn a_changed_offset_is_followed_and_a_cleared_one_forgotten() {
        let mut o = LengthOffset::default();
        for i in 0..30 {
            o.observe(11.0 + 0.1 * noise(i), 10.0, 0.05);
        }
        for i in 0..60 {
            o.observe(9.0 + 0.1 * noise(i), 10.0, 0.05);
        }
        assert!((o.offset_px() + 1.0).abs() < 0.1, "{}", o.offset_px());
        o.clear();
        assert_eq!(o.offset_px(), 0.0);
    }

    #[test]
    fn a_non_finite_observation_is_ignored() {
        let mut o = LengthOffset::default();
        for _ in 0..5 {
            o.observe(12.0, 10.0, 0.05);
        }
        let before = o;
        o.observe(f32::NAN, 10.0, 0.05);
        o.observe(12.0, 10.0, f32::INFINITY);
        assert_eq!(o, before);
    }
}
