//! How far below its plateau's level a streak's saturated pixels read: the clip's own spread,
//! measured on the streak's plateau.
//!
//! A sensor that clips writes every saturated pixel at one level, but processing after the
//! clip (compression, sharpening, denoising) spreads that level by a few luma: a real
//! recording's window "clips at 244+", not at one value. The streak fit takes a pixel at the
//! clip level as "at least this bright" and every other as a value; on a spread plateau many
//! saturated pixels then read as values a few luma below the level, inside a streak whose
//! model is far above the clip, and they pulled its fitted length 0.3–5 px off. The spread is
//! read where the streak is surely saturated if it is at all, the pixels along the central
//! half of its rough path, and the level lowered to cover it, or as far as the plateau's noise
//! above its level says its pixels reach below it, if that is deeper; a hard clip reads
//! exactly its level there, and is left exactly as it was.

use super::fit::{distance2_to_rough, row_span, Rough};
use super::threshold::blob_level::{count_near_top, PLATEAU_WINDOW_LUMA};
use crate::frame::Frame;
/// The fraction of the path's central pixels the spread must cover: the plateau's own
/// deepest percent still read as values a few luma below the level found, but the fit leaves
/// out those whose four neighbours are saturated (see [`ClipSpread::holds_hole`]). (At 0.95,
/// 46 and 52 of the sweep's first 200 points were out on seeds 11 and 12, against 44 and 48.)
const COVER: f32 = 0.99;
/// A plateau spread by noise after the clip and then clamped at the end of the luma range
/// has no pixel above its level, as a hard clip has none, but reads below it in at least
/// this fraction of the central pixels (a third at 1 luma of noise); a hard clip's central
/// pixels all read the top but for a few rim or noise pixels.
const CLAMPED_BELOW: f32 = 0.15;
/// The standard normal quantile of [`COVER`]: the depth that covers the plateau's noise, in
/// its deviations.
const DEPTH_PER_DEVIATION: f32 = 2.326;
/// Fewer pixels above the plateau's level than this say nothing of its noise.
const MIN_ABOVE_PX: u32 = 3;
/// Fewer central pixels than this say nothing of a spread.
const MIN_CENTRAL_PX: u32 = 6;
/// The central pixels lie within this fraction of the streak's thickness of its path, and at
/// least [`MIN_RADIUS_PX`]: inside the saturated band, which is narrower than the blob cut
/// below it. (A quarter of the thickness reached 3 px from a still spot's middle, past its
/// 2.4 px clipped radius, and took the rim's levels for the plateau's spread.)
const RADIUS_PER_THICKNESS: f32 = 0.15;
const MIN_RADIUS_PX: f32 = 0.5;

/// The clip as a streak's pixels show it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ClipSpread {
    /// Pixels at or above this level read "at least this bright".
    pub level_luma: f32,
    /// How far below the top luma that is (0 for a hard clip).
    pub depth_luma: f32,
}

impl ClipSpread {
    /// A clip at exactly `top_luma`.
    pub fn hard(top_luma: u8) -> ClipSpread {
        ClipSpread {
            level_luma: f32::from(top_luma),
            depth_luma: 0.0,
        }
    }

    /// Whether a pixel of `luma` is a hole in the plateau, given that its four neighbours are
    /// at or above the level: saturated too, pushed below the level by the spread itself.
    pub fn holds_hole(&self, luma: f32) -> bool {
        self.depth_luma > 0.0 && luma >= self.level_luma - self.depth_luma
    }
}

/// The clip's spread on `frame` along the central half of `rough`, whose saturated plateau
/// reads `top_luma` (its most common level near the top, see
/// [`blob_level`](super::threshold::blob_level)): the smallest depth below that level which
/// [`COVER`] of the central pixels reach, or deeper where the plateau's noise read above the
/// level says its pixels reach further (see [`upper_deviation_luma`]).
///
/// A hard clip, with no spread, where no central pixel reads above the level and no more than
/// [`CLAMPED_BELOW`] below it (a sensor's clip, exactly as before: its central pixels all read
/// the top), where they do not reach within [`PLATEAU_WINDOW_LUMA`] of it (no plateau there:
/// a streak that does not clip) or are too few.
pub fn measure(frame: &Frame<'_>, rough: &Rough, top_luma: u8) -> ClipSpread {
    let mid = rough.mid_px;
    let halfway = |end: (f32, f32)| (0.5 * (mid.0 + end.0), 0.5 * (mid.1 + end.1));
    let central_half = Rough {
        ends_px: rough.ends_px.map(halfway),
        ..*rough
    };
    let radius_px = (RADIUS_PER_THICKNESS * rough.thickness_px).max(MIN_RADIUS_PX);
    // Central pixels by depth below the level (those above it at depth 0).
    let mut by_depth = [0u32; PLATEAU_WINDOW_LUMA + 1];
    let (mut central, mut above) = (0u32, 0u32);
    near_path(frame, &central_half, radius_px, |luma| {
        central += 1;
        above += u32::from(luma > top_luma);
        count_near_top(&mut by_depth, top_luma, Some(luma));
    });
    let at_level = by_depth.first().copied().unwrap_or(0);
    let clamped = (central - at_level) as f32 >= CLAMPED_BELOW * central as f32;
    if central < MIN_CENTRAL_PX || (above == 0 && !clamped) {
        return ClipSpread::hard(top_luma);
    }
    let noise_depth_luma =
        (DEPTH_PER_DEVIATION * upper_deviation_luma(frame, rough, top_luma)).ceil();
    let needed = (COVER * central as f32).ceil() as u32;
    let mut reached = 0u32;
    for (depth, &count) in by_depth.iter().enumerate() {
        reached += count;
        if reached >= needed {
            let depth_luma = (depth as f32)
                .max(noise_depth_luma)
                .min(PLATEAU_WINDOW_LUMA as f32);
            return ClipSpread {
                level_luma: f32::from(top_luma) - depth_luma,
                depth_luma,
            };
        }
    }
    ClipSpread::hard(top_luma)
}

/// The deviation of the noise that spread the plateau, in luma, from the pixels above its
/// level `top_luma` anywhere within half the thickness of `rough`'s path: only the plateau
/// reads above its level (the rim is below it), so these are the upper half of its noise,
/// each pixel at the level counted as half above. Zero with fewer than [`MIN_ABOVE_PX`] above
/// (a plateau clamped at the end of the luma range, whose upper half is cut off).
///
/// A small spot's central pixels are a handful (6–8 for a 1 px core), too few to reach down
/// to the plateau's deepest noise: from them alone, a streak spread by 2.4 luma after the clip
/// was left hard in some frames, and its fitted lengths came 8–19 % long.
fn upper_deviation_luma(frame: &Frame<'_>, rough: &Rough, top_luma: u8) -> f32 {
    let radius_px = (0.5 * rough.thickness_px).max(MIN_RADIUS_PX);
    let (mut squares, mut above, mut at_level) = (0.0f32, 0u32, 0u32);
    near_path(frame, rough, radius_px, |luma| {
        if luma > top_luma {
            let d = f32::from(luma - top_luma);
            squares += d * d;
            above += 1;
        } else if luma == top_luma {
            at_level += 1;
        }
    });
    if above < MIN_ABOVE_PX {
        return 0.0;
    }
    (squares / (above as f32 + 0.5 * at_level as f32)).sqrt()
}

/// Visits the luma of every pixel of `frame` within `radius_px` of `rough`'s polyline
/// `a → mid → b`.
fn near_path(frame: &Frame<'_>, rough: &Rough, radius_px: f32, mut visit: impl FnMut(u8)) {
    let ([a, b], mid) = (rough.ends_px, rough.mid_px);
    let lo = |v: f32| (v - radius_px).floor().max(0.0) as usize;
    let hi = |v: f32| (v + radius_px).ceil().max(0.0) as usize;
    let (x0, x1) = (lo(a.0.min(b.0).min(mid.0)), hi(a.0.max(b.0).max(mid.0)));
    let (y0, y1) = (lo(a.1.min(b.1).min(mid.1)), hi(a.1.max(b.1).max(mid.1)));
    let r2 = radius_px * radius_px;
    for y in y0..=y1 {
        // Only the columns that can lie within reach (most of a diagonal streak's box does not).
        let Some((left, right)) = row_span(rough, y as f32, radius_px) else {
            continue;
        };
        let (left, right) = (
            left.floor().max(0.0) as usize,
            right.ceil().max(0.0) as usize,
        );
        for x in left.max(x0)..=right.min(x1) {
            if distance2_to_rough(rough, x as f32, y as f32) > r2 {
                continue;
            }
            if let Some(luma) = frame.luma(x, y) {
                visit(luma);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::{FrameSize, PixelFormat};

    const WIDTH: usize = 64;
    const HEIGHT: usize = 32;

    /// A horizontal streak from x 12 to 52 on row 16, 7 px thick: `plateau(i)` gives its
    /// i-th pixel's luma, a ramp of 40 luma a pixel gives its rim, a floor of 40 the rest.
    fn streak(plateau: impl Fn(usize) -> u8) -> Vec<u8> {
        let mut bytes = vec![40u8; WIDTH * HEIGHT];
        for (i, luma) in bytes.iter_mut().enumerate() {
            let (x, y) = (i % WIDTH, i / WIDTH);
            let across = y.abs_diff(16);
            if (12..=52).contains(&x) && across <= 3 {
                *luma = if across <= 2 { plateau(i) } else { 200 };
            }
        }
        bytes
    }

    fn rough() -> Rough {
        Rough {
            ends_px: [(12.0, 16.0), (52.0, 16.0)],
            mid_px: (32.0, 16.0),
            thickness_px: 7.0,
        }
    }

    fn measure_on(bytes: &[u8], top_luma: u8) -> ClipSpread {
        let size = FrameSize::new(WIDTH as u32, HEIGHT as u32).unwrap();
        let frame = Frame::new_checked_as(bytes, size, WIDTH, PixelFormat::Grey).unwrap();
        measure(&frame, &rough(), top_luma)
    }

    /// A small pseudo-random luma offset in `-spread..=spread` for pixel `i`.
    fn jitter(i: usize, spread: u32) -> i32 {
        let h = (i as u32).wrapping_mul(2_654_435_761).rotate_right(13);
        (h % (2 * spread + 1)) as i32 - spread as i32
    }

    /// A sensor's clip reads exactly its level: no spread, whatever the rim below it.
    #[test]
    fn a_hard_clip_has_no_spread() {
        let bytes = streak(|_| 250);
        assert_eq!(measure_on(&bytes, 250), ClipSpread::hard(250));
    }

    /// Noise after the clip, both ways around 235 (uniform over ±3 luma): the level goes down
    /// past it (the upper half's deviation, 2 luma, read as a normal's, puts its 1 % point at
    /// 5 luma), and a pixel pushed below it among saturated neighbours is a hole.
    #[test]
    fn a_spread_plateau_is_covered_from_below() {
        let bytes = streak(|i| (235 + jitter(i, 3)) as u8);
        let spread = measure_on(&bytes, 235);
        assert!(
            spread.depth_luma >= 3.0 && spread.depth_luma <= 6.0,
            "{spread:?}"
        );
        assert_eq!(spread.level_luma, 235.0 - spread.depth_luma);
        assert!(spread.holds_hole(spread.level_luma - 1.0));
        assert!(!spread.holds_hole(spread.level_luma - spread.depth_luma - 1.0));
        assert!(!ClipSpread::hard(235).holds_hole(234.0));
    }

    /// The central pixels alone, a handful, can all happen to read at or above the level;
    /// the plateau's noise above its level over the whole streak still says how far down its
    /// pixels reach.
    #[test]
    fn the_noise_above_the_level_reaches_below_the_central_pixels() {
        let bytes = streak(|i| {
            let row = i / WIDTH;
            let offset = jitter(i, 3);
            let offset = if row.abs_diff(16) <= 1 {
                offset.abs()
            } else {
                offset
            };
            (235 + offset) as u8
        });
        let spread = measure_on(&bytes, 235);
        assert!(spread.depth_luma >= 3.0, "{spread:?}");
    }

    /// Noise after the clip at the end of the range: clamped, nothing reads above the level,
    /// but a good part of the plateau reads below it.
    #[test]
    fn a_clamped_plateau_is_spread_too() {
        let bytes = streak(|i| (255 + jitter(i, 4).min(0)) as u8);
        let spread = measure_on(&bytes, 255);
        assert!(
            spread.depth_luma >= 3.0 && spread.depth_luma <= 4.0,
            "{spread:?}"
        );
        // A hard clip with a few of its central pixels below the top (read noise before the
        // clip in a barely saturated core) is left as it is.
        let bytes = streak(|i| if i % 41 == 0 { 250 } else { 255 });
        assert_eq!(measure_on(&bytes, 255), ClipSpread::hard(255));
    }

    /// A streak whose central pixels fall off far below the top does not clip: no plateau.
    #[test]
    fn a_ridge_far_below_the_top_is_no_plateau() {
        let bytes = streak(|i| (200 + jitter(i, 10)) as u8);
        assert_eq!(measure_on(&bytes, 255), ClipSpread::hard(255));
    }
}
