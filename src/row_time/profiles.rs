//! Each frame's row profile: the logarithm of every row's mean luma over its darker pixels,
//! kept for a run of frames in memory allocated once.
//!
//! A flickering light multiplies the floor's light by a factor that each row samples at its
//! own moment, so the bands are a factor on every pixel of a row: the row's mean carries it,
//! averaged over the row's width (its noise divided by √width), and the logarithm turns the
//! factor into a term that adds. Everything that stands still in the picture (the floor's
//! texture, a vignette, a window) is the same term in every frame and cancels between two
//! frames.
//!
//! The mean is taken over the darkest [`KEPT_FRACTION`] of the row's pixels. The LED and its
//! glow only add light, and where they cross a row its whole mean moves by far more than the
//! bands (a clipped streak of 20 px in a row of 640 at 50 moves it by 6 %, bands of 1 %): on
//! the independently rendered scenes of `tests/row_time.rs` the plain mean refused three of 14
//! and read one 6 % off, where the darker pixels' are all within 1.4 %. The band is one
//! factor along a row, which keeps the pixels' order, so the same pixels are the darker ones in
//! every frame wherever nothing moves: no cut by level (a wall near the clip, kept in its dark
//! phases and cut in its bright ones) draws bands of its own.

use crate::detect::luma_histogram::LumaHistogram;
use crate::frame::Frame;

/// A row whose mean luma is below this holds no light to read a factor from (a black row, or
/// studio range's foot): it is left out.
const MIN_ROW_MEAN_LUMA: f32 = 1.0;

/// The share of each row's pixels, the darkest, that its mean is taken over: a streak and its
/// glow may cover the rest.
pub const KEPT_FRACTION: f32 = 0.75;

/// Row profiles of up to `capacity` frames of one height, with their times.
pub struct RowProfiles {
    height_px: usize,
    capacity: usize,
    /// `ln` of each row's mean luma, frame after frame; NaN for a row left out.
    ln_means: Vec<f32>,
    times_us: Vec<u64>,
}

impl RowProfiles {
    /// Room for `capacity` frames of `height_px` rows.
    pub fn new(height_px: usize, capacity: usize) -> Self {
        RowProfiles {
            height_px,
            capacity,
            ln_means: Vec::with_capacity(height_px * capacity),
            times_us: Vec::with_capacity(capacity),
        }
    }

    /// Adds `frame`'s profile, taken at `t_us`. Returns `false`, keeping nothing, when the
    /// profiles are full or the frame is not of their height.
    pub fn push(&mut self, frame: &Frame<'_>, t_us: u64) -> bool {
        if self.is_full() || frame.size().height() != self.height_px {
            return false;
        }
        let (step, width) = (frame.luma_step(), frame.size().width());
        let kept = ((width as f32 * KEPT_FRACTION) as usize).max(1);
        for row in frame.luma_rows() {
            let mut levels = LumaHistogram::new();
            for &l in row.iter().step_by(step) {
                levels.add(f32::from(l));
            }
            let mean = levels.mean_of_lowest(kept).unwrap_or(0.0);
            self.ln_means.push(if mean >= MIN_ROW_MEAN_LUMA {
                mean.ln()
            } else {
                f32::NAN
            });
        }
        self.times_us.push(t_us);
        true
    }

    /// Whether no more frames fit.
    pub fn is_full(&self) -> bool {
        self.times_us.len() >= self.capacity
    }

    /// Frames held.
    pub fn frames(&self) -> usize {
        self.times_us.len()
    }

    /// Rows of each profile.
    pub fn height_px(&self) -> usize {
        self.height_px
    }

    /// Frame `n`'s profile (NaN where a row is left out), for `n` below [`RowProfiles::frames`].
    pub fn profile(&self, n: usize) -> &[f32] {
        &self.ln_means[n * self.height_px..(n + 1) * self.height_px]
    }

    /// Frame `n`'s time, µs, for `n` below [`RowProfiles::frames`].
    pub fn time_us(&self, n: usize) -> u64 {
        self.times_us[n]
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::{FrameSize, PixelFormat};

    #[test]
    fn a_row_s_profile_is_the_log_of_its_darker_pixels_mean_and_a_black_row_is_left_out() {
        let size = FrameSize::new(4, 3).unwrap();
        // YUYV: luma on the even bytes, chroma (which must not count) on the odd ones. Of
        // four pixels the darkest three count.
        let bytes = [
            40, 200, 10, 200, 30, 200, 20, 200, //
            0, 99, 0, 99, 0, 99, 9, 99, //
            255, 0, 6, 0, 6, 0, 3, 0,
        ];
        let frame = Frame::new_checked_as(&bytes, size, 8, PixelFormat::Yuyv).unwrap();
        let mut profiles = RowProfiles::new(3, 2);
        assert!(profiles.push(&frame, 7));
        let p = profiles.profile(0);
        assert!((p[0] - 20.0f32.ln()).abs() < 1e-6, "{}", p[0]);
        assert!(p[1].is_nan());
        assert!((p[2] - 5.0f32.ln()).abs() < 1e-6, "{}", p[2]);
        assert_eq!(profiles.time_us(0), 7);
    }

    #[test]
    fn a_frame_of_another_height_or_one_past_the_capacity_is_not_kept() {
        let bytes = [50u8; 8];
        let two_rows =
            Frame::new_checked_as(&bytes, FrameSize::new(2, 2).unwrap(), 4, PixelFormat::Yuyv)
                .unwrap();
        let mut profiles = RowProfiles::new(3, 1);
        assert!(!profiles.push(&two_rows, 0));
        let mut profiles = RowProfiles::new(2, 1);
        assert!(profiles.push(&two_rows, 0));
        assert!(profiles.is_full());
        assert!(!profiles.push(&two_rows, 1));
        assert_eq!(profiles.frames(), 1);
    }
}
