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
//! frame). Their difference, averaged over the track's recent frames (the frame's own among
//! them: in a track's first frames each is much of what is known), is the offset; the single
//! frame's length less the offset is what the frame says about the speed.
//!
//! Only an offset beyond its own scatter is taken off: an unbiased model's mean difference is
//! noise, and taking it off would add that noise to every frame.
//!
//! [`MotionHead::path_px`]: super::motion::MotionHead::path_px

use super::motion::CHI2_1DOF_99;
use crate::decayed_mean::DecayedMean;

/// The frames an observation is remembered for: each new one scales the older ones down by
/// `1 − 1 / MEMORY_FRAMES`, so that a speed that changes (and with it how far the clip
/// reaches along the streak) is followed within about this many frames.
const MEMORY_FRAMES: f32 = 16.0;
/// Observations below which nothing is taken off: the scatter of two is no measure of it.
const MIN_OBSERVATIONS: u32 = 3;
/// The mean difference is taken as an offset when it is beyond its standard error times
/// Student's t at 95 % two-sided for the variance's degrees of freedom (index: degrees − 1):
/// a few frames' scatter says little about itself, and the t quantile says by how much.
///
/// Why 95 % and not 99 %: the two mistakes do not cost alike. An offset taken off that was
/// only noise adds its standard error to every frame, about the frame's own deviation over
/// the root of the frames seen; an offset left on adds all of itself. At 99 % a pillbox's
/// steady 1 px short (−9 %, independent seed 1, scene 41) was taken off only from the ninth
/// frame of its fourteen. Not lower: a fit's misreadings are not all Gaussian noise. On a
/// 60-frame halo arc, runs of frames read 10 % long among frames read right, and at 90 % the
/// mean of such a run was taken as an offset, which put that scene's median from 2.6 to
/// 3.3 %.
///
/// The fit states its length's deviation, from its residual; on a spot outside the model's
/// family that residual is mostly the profile's misfit, steady from frame to frame (on a
/// Moffat arc it stated 0.3–0.6 px for lengths that scattered by 0.03 px about a steady
/// 0.33 px short), so the stated variance is pooled with the scatter, counted as
/// [`STATED_DEGREES`] observations' worth. Taken as the least the error could be, it kept
/// that offset from ever being taken off. The ramps state no deviation of their own: only
/// the motion's part is known, and the variance is at least that and at least the scatter.
const T_95: [f32; 30] = [
    12.71, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228, 2.201, 2.179, 2.160,
    2.145, 2.131, 2.120, 2.110, 2.101, 2.093, 2.086, 2.080, 2.074, 2.069, 2.064, 2.060, 2.056,
    2.052, 2.048, 2.045, 2.042,
];
/// The observations' worth of the stated variance beside their scatter's.
const STATED_DEGREES: f32 = 2.0;
/// The least variance an observation is weighted by (px²): a fit that claims to be exact is
/// not worth more than one of a tenth of a pixel.
const MIN_VARIANCE_PX2: f32 = 0.01;

/// A frame's single-frame length (less its offset), weighed with the middles' path over the
/// same exposure: each by the inverse of its variance (each deviation taken as at least a
/// tenth of a pixel, as an observation of the offset's is).
///
/// The offset needs three observations and their scatter, so in a track's first frames the
/// single frame's length keeps the fit's steady misreading of a spot outside its family,
/// while the middles' path, from the third middle on, already measures that length without
/// reading an end. On the independent scenes a halo's 13 px line read +16 % in its third
/// frame (the fit stating 1.5 px for a length 2.1 px long; the middles' path 13.15 px for a
/// true 13.12; +5.1 % weighed), and accelerating halos at 1280×720 −11 % in their third
/// (−4.4 and −4.7 % weighed). Later, the offset takes off only the fit's steady misreading,
/// and a halo's lengths still scatter by the pixel or two the fit states about it, where the
/// middles' path over five middles is often known to a tenth: weighed in every frame, the
/// independent scenes' pooled speed median went from 0.28–0.51 % to 0.10–0.19 %. The
/// weights are the variances as stated: the fit's length's, and the middles' path's from
/// the middles' own deviations.
///
/// Where the two differ beyond their deviations (χ² at 99 %), the frame's own length stands:
/// the middles' path is the motion of the frames before carried on, and an LED that brakes,
/// turns back or starts within this exposure shows it in this frame's streak alone. Unless
/// the streak's length is known to be `misread` (the LED kept its speed, and the two differ
/// by a steady misreading of the single frame's): then the middles' path stands. (Weighed
/// with it by the variances as stated, a misread length still pulled the speed several
/// percent off: its misreading is a bias its variance does not include.)
pub fn weighed_with_motion(
    streak_px: f32,
    streak_var_px2: f32,
    motion_px: f32,
    motion_var_px2: f32,
    misread: bool,
) -> f32 {
    let (streak_var_px2, motion_var_px2) = (
        streak_var_px2.max(MIN_VARIANCE_PX2),
        motion_var_px2.max(MIN_VARIANCE_PX2),
    );
    let miss_px = streak_px - motion_px;
    if miss_px * miss_px > CHI2_1DOF_99 * (streak_var_px2 + motion_var_px2) {
        return if misread { motion_px } else { streak_px };
    }
    (streak_px / streak_var_px2 + motion_px / motion_var_px2)
        / (1.0 / streak_var_px2 + 1.0 / motion_var_px2)
}

/// Which model read a frame's path, and how: each misreads a spot outside its family by its
/// own steady offset, so each learns its own.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LengthReading {
    /// The ramps' tips (a path they read as still has no length).
    Ramps,
    /// The fit, a path longer than the spot is wide.
    FitMoving,
    /// The fit, a path no longer than its spot is wide: a bloom clipped far into its glow,
    /// whose fitted spot is the glow; its length is the speed where the middles moved as far
    /// (a glow 5.8 px wide in a halo read such 22.5 px arcs 2 px long in all of 39 frames).
    FitStill,
}

impl LengthReading {
    /// The number of readings.
    pub const COUNT: usize = 3;

    /// Whether the reading states its length's deviation (the fit, from its residual), so
    /// that the variance stated with an observation is all of it, not only the motion's.
    pub fn states_its_deviation(self) -> bool {
        self != LengthReading::Ramps
    }

    /// The fit's other reading (moving for still, still for moving); `None` for the ramps. A
    /// path about as long as its spot is wide turns from one to the other between frames, and
    /// the offset learned in one stands for the other until it has its own.
    pub fn other_fit(self) -> Option<LengthReading> {
        match self {
            LengthReading::Ramps => None,
            LengthReading::FitMoving => Some(LengthReading::FitStill),
            LengthReading::FitStill => Some(LengthReading::FitMoving),
        }
    }

    /// The reading of a path fitted or not, read as moving or not.
    pub fn of(fitted: bool, moving: bool) -> LengthReading {
        match (fitted, moving) {
            (false, _) => LengthReading::Ramps,
            (true, true) => LengthReading::FitMoving,
            (true, false) => LengthReading::FitStill,
        }
    }
}

/// The decayed, weighted sums of one track's length differences (single frame's path less
/// the motion's path over the exposure, px).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct LengthOffset {
    /// The differences (px), each weighed by the inverse of its variance.
    differences: DecayedMean,
    /// Sum of the squared weights (for the effective number of observations).
    weights_sq: f32,
    /// Sum of the squared weights times the stated variances (for the stated variance of the
    /// weighted mean: each weight is the inverse of its observation's variance when new, and
    /// decays while the variance stays).
    stated_px2: f32,
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
        self.differences.add(difference_px, w, keep);
        self.weights_sq = keep * keep * self.weights_sq + w * w;
        self.stated_px2 = keep * keep * self.stated_px2 + w;
    }

    /// The offset to take off a single frame's path length (px) as `reading` reads it: the
    /// mean difference where it is beyond its scatter, else 0.
    pub fn offset_px(&self, reading: LengthReading) -> f32 {
        let d = &self.differences;
        if d.observations() < MIN_OBSERVATIONS {
            return 0.0;
        }
        let weights = d.weights();
        let effective = weights * weights / self.weights_sq;
        let mean_px = d.mean();
        let scatter_px2 = d.scatter();
        let degrees = (effective - 1.0).max(1.0);
        // One observation's variance, from the scatter and as stated.
        let scattered_px2 = scatter_px2 * effective / degrees;
        let stated_px2 = self.stated_px2 / (weights * weights) * effective;
        let (variance_px2, variance_degrees) = if reading.states_its_deviation() {
            // The stated variance counts as `STATED_DEGREES` observations' worth.
            let pooled_degrees = STATED_DEGREES + degrees;
            let pooled_px2 =
                (STATED_DEGREES * stated_px2 + degrees * scattered_px2) / pooled_degrees;
            (pooled_px2, pooled_degrees)
        } else {
            // Only the motion's part is stated: the variance is at least that.
            (scattered_px2.max(stated_px2), degrees)
        };
        let standard_error_px = (variance_px2 / effective).sqrt();
        let t = T_95[(variance_degrees as usize).clamp(1, T_95.len()) - 1];
        if mean_px.abs() > t * standard_error_px {
            mean_px
        } else {
            0.0
        }
    }

    /// Whether as many differences were observed as an offset needs (three).
    pub fn has_enough(&self) -> bool {
        self.differences.observations() >= MIN_OBSERVATIONS
    }

    /// The mean squared difference of the frames seen from `offset_px` (px²): how far this
    /// track's lengths, less that offset, have read from the motion's path, misfit and noise
    /// together; `None` before as many observations as an offset needs (three).
    pub fn mean_square_about_px2(&self, offset_px: f32) -> Option<f32> {
        let d = &self.differences;
        (d.observations() >= MIN_OBSERVATIONS).then(|| {
            let (mean_px, mean_square_px2) = (d.mean(), d.mean_square());
            (mean_square_px2 - 2.0 * offset_px * mean_px + offset_px * offset_px).max(0.0)
        })
    }

    /// Forgets everything: a new track may be another LED.
    pub fn clear(&mut self) {
        *self = LengthOffset::default();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const READINGS: [LengthReading; 3] = [
        LengthReading::Ramps,
        LengthReading::FitMoving,
        LengthReading::FitStill,
    ];

    /// A small deterministic noise in [-1, 1].
    fn noise(i: u32) -> f32 {
        let x = (i.wrapping_mul(2_654_435_761) >> 8) as f32 / (1u32 << 24) as f32;
        2.0 * x - 1.0
    }

    /// Two readings that agree within their deviations are weighed by them; where they
    /// disagree beyond (an LED braking within the exposure, whose path the middles cannot
    /// know yet), the frame's own length stands, unless it is known misread.
    #[test]
    fn a_length_is_weighed_with_the_middles_path_only_where_they_agree_or_it_is_misread() {
        let weighed = weighed_with_motion(15.0, 2.25, 13.0, 0.25, false);
        assert!((weighed - 13.2).abs() < 1e-4, "{weighed}");
        // Variances below a tenth of a pixel's count as that.
        let weighed = weighed_with_motion(13.1, 0.0, 13.0, 0.0, false);
        assert!((weighed - 13.05).abs() < 1e-4, "{weighed}");
        // 9 px apart where each is stated to a third of a pixel.
        assert_eq!(weighed_with_motion(3.0, 0.09, 12.0, 0.01, false), 3.0);
        // ... unless the length is known misread: then the middles' path stands.
        assert_eq!(weighed_with_motion(3.0, 0.09, 12.0, 0.01, true), 12.0);
        // Where the two agree, a misread length is weighed as any other.
        let weighed = weighed_with_motion(15.0, 2.25, 13.0, 0.25, true);
        assert!((weighed - 13.2).abs() < 1e-4, "{weighed}");
    }

    #[test]
    fn a_steady_offset_is_learned_within_its_noise() {
        let mut o = LengthOffset::default();
        for i in 0..20 {
            // The streak reads 0.9 px short; the motion's path is noisy by ±0.3 px.
            o.observe(9.5 + 0.1 * noise(i), 10.4 + 0.3 * noise(i + 100), 0.05);
        }
        for reading in READINGS {
            let offset_px = o.offset_px(reading);
            assert!((offset_px + 0.9).abs() < 0.15, "{reading:?}: {offset_px}");
        }
    }

    #[test]
    fn an_unbiased_model_gets_no_correction() {
        let mut o = LengthOffset::default();
        for i in 0..40 {
            o.observe(10.0 + 0.3 * noise(i), 10.0 + 0.3 * noise(i + 1000), 0.2);
            for reading in READINGS {
                assert_eq!(
                    o.offset_px(reading),
                    0.0,
                    "{reading:?} after {} frames",
                    i + 1
                );
            }
        }
    }

    #[test]
    fn too_few_frames_say_nothing() {
        let mut o = LengthOffset::default();
        // Two frames say nothing however far off they read.
        for _ in 0..2 {
            o.observe(30.0, 10.0, 0.05);
        }
        for reading in READINGS {
            assert_eq!(o.offset_px(reading), 0.0, "{reading:?}");
        }
        // Frames 2 px off that agree exactly, stated to be uncertain by 0.7 px (the motion's
        // part of the ramps' deviation): three give under two degrees of freedom, t times
        // the stated error 5.2 px; four give three: 1.5 px.
        let mut o = LengthOffset::default();
        for _ in 0..3 {
            o.observe(12.0, 10.0, 0.5);
        }
        assert_eq!(o.offset_px(LengthReading::Ramps), 0.0);
        o.observe(12.0, 10.0, 0.5);
        let offset_px = o.offset_px(LengthReading::Ramps);
        assert!((offset_px - 2.0).abs() < 1e-4, "{offset_px}");
        // The same stated by the fit to be uncertain by 2 px: three hold the pooled variance
        // at half the stated one on four degrees (t times the error 2.6 px); four on five
        // degrees: 1.8 px.
        let mut o = LengthOffset::default();
        for _ in 0..3 {
            o.observe(12.0, 10.0, 4.0);
        }
        assert_eq!(o.offset_px(LengthReading::FitMoving), 0.0);
        o.observe(12.0, 10.0, 4.0);
        let offset_px = o.offset_px(LengthReading::FitMoving);
        assert!((offset_px - 2.0).abs() < 1e-4, "{offset_px}");
    }

    /// A spot outside the model's family, as on a Moffat arc: the fit states its length
    /// uncertain by 0.4 px from a residual that is mostly the profile's misfit, while the
    /// lengths scatter by a few hundredths about a steady 0.2 px short. The offset is taken
    /// off within ten frames; with the stated variance as the floor of the error (as for the
    /// ramps) it is not.
    #[test]
    fn a_steady_offset_far_inside_its_stated_deviation_is_taken_off() {
        let mut o = LengthOffset::default();
        for i in 0..10 {
            o.observe(8.18 + 0.03 * noise(i), 8.38 + 0.01 * noise(i + 500), 0.16);
        }
        let offset_px = o.offset_px(LengthReading::FitMoving);
        assert!((offset_px + 0.2).abs() < 0.03, "{offset_px}");
        // Were the stated deviation only part of it, as the ramps', it would not be.
        assert_eq!(o.offset_px(LengthReading::Ramps), 0.0);
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
        let offset_px = o.offset_px(LengthReading::FitMoving);
        assert!((offset_px + 1.0).abs() < 0.1, "{offset_px}");
        o.clear();
        assert_eq!(o.offset_px(LengthReading::FitMoving), 0.0);
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
