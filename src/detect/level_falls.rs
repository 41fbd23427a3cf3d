//! Where the luma along a ray first falls through a set of brightness levels.
//!
//! The line profile (`line_profile`), the symmetric middle (`mirror_middle`) and the cascade's
//! edge check (`cascade`) all read a streak's light by the same walk: out from a bright point along a ray, in fine steps,
//! noting where the light first falls through each of several levels. Equal light is equal
//! luma whatever the tone curve, black level and clip, so such crossings compare light without
//! a model of the camera; the line profile pairs them across the body and past an end, the
//! symmetric middle on either side of the middle, the cascade measures how far apart two of
//! them lie across the body. One walk, so that all read the frame the same way; the middle also weighs each crossing by the luma's slope there (a crossing moves
//! by the luma's error over that slope).

use super::bilinear::Walk;
use crate::frame::Frame;

/// Sampling step along the ray: a tenth of a pixel, so that the bilinear luma between two
/// samples is close to a straight line and the interpolated crossing to the true one.
const STEP_PX: f32 = 0.1;

/// Where a walk fell through a level, and how steeply.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Fall {
    /// Distance from the walk's start, in pixels.
    pub at_px: f32,
    /// The luma's fall per pixel over the step that crossed the level.
    pub slope_per_px: f32,
}

/// Which levels a walk may fall through.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Armed {
    /// Only those the start is at or above: a fall from the peak the walk starts on (the
    /// symmetric middle's lines, whose two sides must cross the same flank).
    AtStart,
    /// Any the walk has been at or above, from the start on: a level the start is below may
    /// still be reached and fallen through further out (an end's ray, which may start on the
    /// streak's flank).
    OnceReached,
}

/// Walks from `start` along unit vector `d`, out to `reach_px`, and records where the luma
/// first falls through each of `levels`, having been at or above it (since the start, or since
/// the walk first reached it: `armed`). A level never fallen through is `None`; so is every
/// level when the start lies outside the frame. The walk stops at the frame's edge, at
/// `reach_px`, or once no level is left to cross.
pub fn first_falls<const N: usize>(
    frame: &Frame<'_>,
    start: (f32, f32),
    d: (f32, f32),
    levels: &[f32; N],
    reach_px: f32,
    armed: Armed,
) -> [Option<Fall>; N] {
    let mut found: [Option<Fall>; N] = [None; N];
    let mut walk = Walk::new(frame);
    let Some(mut prev) = walk.luma_at(start.0, start.1) else {
        return found;
    };
    // Levels the walk has been at or above, and levels still to be crossed.
    let mut above = levels.map(|level| prev >= level);
    let mut open = match armed {
        Armed::AtStart => above,
        Armed::OnceReached => [true; N],
    };
    let Some(mut quiet) = quiet_band(levels, &open, &above) else {
        return found;
    };
    let samples = (reach_px / STEP_PX) as usize;
    for i in 1..=samples {
        let u = i as f32 * STEP_PX;
        let Some(v) = walk.luma_at(start.0 + u * d.0, start.1 + u * d.1) else {
            break;
        };
        if v < quiet.0 || v >= quiet.1 {
            for (((slot, o), a), &level) in found
                .iter_mut()
                .zip(open.iter_mut())
                .zip(above.iter_mut())
                .zip(levels)
            {
                if !*o {
                    continue;
                }
                if *a && v < level {
                    let frac = (prev - level) / (prev - v);
                    *slot = Some(Fall {
                        at_px: (i as f32 - 1.0 + frac) * STEP_PX,
                        slope_per_px: (prev - v) / STEP_PX,
                    });
                    *o = false;
                } else {
                    *a = *a || v >= level;
                }
            }
            match quiet_band(levels, &open, &above) {
                Some(band) => quiet = band,
                None => break,
            }
        }
        prev = v;
    }
    found
}

/// The luma band `[low, high)` in which a sample changes nothing: at or above every open level
/// the walk has been at (so none falls), below every open level it has not reached (so none
/// is reached). Most samples of a walk lie in it, and only those outside it visit the levels.
/// `None` when no level is open: the walk is done.
fn quiet_band<const N: usize>(
    levels: &[f32; N],
    open: &[bool; N],
    above: &[bool; N],
) -> Option<(f32, f32)> {
    let mut band = None;
    for ((&level, &o), &a) in levels.iter().zip(open).zip(above) {
        if o {
            let (low, high) = band.get_or_insert((f32::NEG_INFINITY, f32::INFINITY));
            if a {
                *low = low.max(level);
            } else {
                *high = high.min(level);
            }
        }
    }
    band
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::{FrameSize, PixelFormat};

    /// A GREY frame whose luma falls along x, by `luma(x)`, the same on every row.
    fn ramp(luma: impl Fn(usize) -> u8) -> (Vec<u8>, FrameSize) {
        let size = FrameSize::new(32, 4).unwrap();
        let mut bytes = vec![0u8; 32 * 4];
        for (i, b) in bytes.iter_mut().enumerate() {
            *b = luma(i % 32);
        }
        (bytes, size)
    }

    #[test]
    fn a_fall_is_placed_between_samples_with_its_slope() {
        // 200 up to x = 10, then 10 luma a pixel down to 0.
        let (bytes, size) = ramp(|x| 200usize.saturating_sub(10 * x.saturating_sub(10)) as u8);
        let frame = Frame::new_checked_as(&bytes, size, 32, PixelFormat::Grey).unwrap();
        let falls = first_falls(
            &frame,
            (2.0, 1.0),
            (1.0, 0.0),
            &[195.0, 150.0],
            20.0,
            Armed::AtStart,
        );
        let [Some(a), Some(b)] = falls else {
            panic!("both levels crossed: {falls:?}");
        };
        assert!((a.at_px - 8.5).abs() < 1e-3, "{a:?}");
        assert!((b.at_px - 13.0).abs() < 1e-3, "{b:?}");
        assert!((a.slope_per_px - 10.0).abs() < 1e-2, "{a:?}");
    }

    #[test]
    fn a_level_the_start_is_below_counts_only_once_reached() {
        // A dip at the start, a peak at x = 8, then a fall.
        let (bytes, size) = ramp(|x| match x {
            0..=4 => 100,
            5..=8 => 200,
            _ => 50,
        });
        let frame = Frame::new_checked_as(&bytes, size, 32, PixelFormat::Grey).unwrap();
        let levels = [150.0, 75.0];
        let at_start = first_falls(
            &frame,
            (2.0, 1.0),
            (1.0, 0.0),
            &levels,
            20.0,
            Armed::AtStart,
        );
        assert!(at_start[0].is_none(), "{at_start:?}");
        assert!(at_start[1].is_some(), "{at_start:?}");
        let reached = first_falls(
            &frame,
            (2.0, 1.0),
            (1.0, 0.0),
            &levels,
            20.0,
            Armed::OnceReached,
        );
        let Some(fall) = reached[0] else {
            panic!("the level reached is crossed: {reached:?}");
        };
        // Through 150 between x = 8 (200) and x = 9 (50): at 8 + 50 / 150.
        assert!((fall.at_px - (6.0 + 1.0 / 3.0)).abs() < 1e-3, "{fall:?}");
        // The lower level is crossed where the walk first falls through it, after the peak.
        assert_eq!(reached[1], at_start[1]);
    }

    #[test]
    fn a_start_outside_the_frame_crosses_nothing() {
        let (bytes, size) = ramp(|_| 200);
        let frame = Frame::new_checked_as(&bytes, size, 32, PixelFormat::Grey).unwrap();
        let falls = first_falls(
            &frame,
            (-5.0, 1.0),
            (1.0, 0.0),
            &[100.0],
            20.0,
            Armed::OnceReached,
        );
        assert_eq!(falls, [None]);
    }
}
