//! Where a streak's middle lies, from the mirror symmetry of its light.
//!
//! An LED moving at a steady speed along a straight line or a circle leaves light that is
//! mirror-symmetric about the perpendicular bisector of the path's chord: the spot is swept
//! the same way on either side of the middle. The camera's tone curve, its black level and its
//! clipping map equal light to equal luma, so the luma is mirror-symmetric too, whatever the
//! spot's profile and however far the LED saturates. On any line parallel to the chord, the
//! points where the luma falls through a level on either side of the middle are mirror images:
//! their midpoint lies on the bisector, which is the middle's position along the chord.
//!
//! The same holds across the streak, whose cross-sections are mirror-symmetric about the
//! path: the mirror points of lines across it, spread along the body on either side of the
//! middle, trace the centre line, read at the middle. Each crossing moves by the luma's error
//! over the slope there, so each pair of crossings counts by the inverse of its variance (the
//! slopes squared).
//!
//! The intensity-weighted centroid the middle started from weighs every pixel of the streak's
//! rim, and on a 60 px streak a rim pixel 25 px from the middle whose luma the floor's texture
//! or the read noise moves carries that lever arm: on the sweep's 60 px streaks (seed 11) the
//! centroid was 0.13 / 0.56 px off along the streak (median / p95), the crossings here
//! 0.07 / 0.55 px. What is left is mostly blooms: where a glow reaches the levels on its own,
//! every crossing is on its shallow flank, which the floor's texture moves by tenths of a pixel.

use nalgebra::{Matrix3, Vector3};

use super::bilinear::luma_at;
use super::level_falls::{first_falls, Armed};
use super::ray_floor;
use crate::frame::Frame;

/// The levels the luma along the lines is cut at, as fractions of the way from the floor to
/// the streak's top: clear of the floor, whose texture under the two caps differs, and up to
/// near the top, where a clipped core's fall rises above a glow's shoulder (a bloom whose glow
/// reaches 0.8 of the way is read on its core only there).
const LEVELS: [f32; 7] = [0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9];

/// The lines parallel to the chord that place the middle along it, as offsets across from the
/// line the caller places them about, in pixels: three, so that the pixel grid's sampling and
/// the read noise average out.
///
/// That line runs through the middle of a straight streak. On an arc, a line through the
/// middle leaves the streak through its sides, where it meets the light at a grazing angle and
/// a tenth of a pixel across moves a crossing by pixels along (a 60 px arc on a 115 px circle,
/// bent 3.9 px: the middle 0.4–2.2 px off along it); there the caller places it halfway to the
/// chord, within half the bend of the path from the middle to both caps, whose outer edges are
/// mirror images on an arc as on a line.
const ALONG_LINES_PX: [f32; 3] = [-0.5, 0.0, 0.5];

/// The lines across the streak that place the middle across it: this many on either side of
/// the bisector, evenly out to [`across_half_span_px`], but at least this far apart.
const ACROSS_LINES_EACH_SIDE: usize = 6;
const MIN_ACROSS_STEP_PX: f32 = 0.5;
/// The farthest along the chord from the bisector the lines across reach (px).
const MAX_ACROSS_HALF_SPAN_PX: f32 = 12.0;
/// The least half span: lines within a pixel of the bisector (five of them) however short or
/// bent the streak.
const MIN_ACROSS_HALF_SPAN_PX: f32 = 1.0;
/// The most a circle may part from the parabola fitted to it over the span (px): a circle of
/// radius `r` parts from its osculating parabola by `t⁴ / 8r³` at `t` from the middle.
const ARC_PARABOLA_PX: f32 = 0.02;

/// A fall along the streak nearer the middle than this share of the chord's half-length is
/// not a cap's: the light dipped inside the body. A line off the path of a thin streak runs
/// on its shoulder, where the noise takes the upper levels below their cut (a 1 px disk's
/// 3 px streak, lines 0.5 px off its path: falls 0.5–2 px from the middle, whose pairs with
/// the caps' 30 px out moved the middle 1.3 px along). The rough middle is much nearer the
/// true one than a quarter of the chord, so the caps lie beyond half of its half-length.
const NEAREST_CAP_OF_HALF_CHORD: f32 = 0.5;

/// How far past the chord's half-length a line is walked: the widest spot's fall to the
/// levels (a glow's cap lies within the floor's reach, [`ray_floor::MAX_REACH_PX`]).
const BEYOND_CHORD_PX: f32 = ray_floor::MAX_REACH_PX;

/// The streak's middle, from `mid` near it: moved along `along` (a unit vector parallel to the
/// chord, which is `half_chord_px` long on either side of the bisector) to the bisector by the
/// level crossings on lines parallel to the chord about the line `lines_offset_px` from `mid`
/// along `across` (see `ALONG_LINES_PX`), then across (`across`, the unit normal) to the
/// centre of the cross-section there, by the crossings on short lines across it (the
/// cross-section of a streak is mirror-symmetric about its path too: exactly on a straight
/// one, and on an arc of radius `r` to within its width over `r`). `top_luma` is the frame's
/// clip level. `None` when the floor cannot be read beside the middle, the light at the middle
/// is no brighter than it, or no level is crossed on both sides of any line.
pub fn centre(
    frame: &Frame<'_>,
    mid: (f32, f32),
    along: (f32, f32),
    across: (f32, f32),
    half_chord_px: f32,
    lines_offset_px: f32,
    top_luma: u8,
) -> Option<(f32, f32)> {
    // The floor: the brighter of the floors on the two sides of the middle, so that every
    // level stands clear of it on both.
    let a = ray_floor::along(frame, mid, across)?;
    let b = ray_floor::along(frame, mid, (-across.0, -across.1))?;
    let floor = a.luma.max(b.luma);
    // The streak's top: its clip, or the light at the middle for a streak that does not clip.
    let top = luma_at(frame, mid.0, mid.1)?.min(f32::from(top_luma));
    let span = top - floor;
    if span < 1.0 {
        return None;
    }
    let levels = LEVELS.map(|f| floor + f * span);
    let lines_centre = (
        mid.0 + lines_offset_px * across.0,
        mid.1 + lines_offset_px * across.1,
    );
    let along_px = mirror_offset(
        frame,
        lines_centre,
        (along, across),
        &ALONG_LINES_PX,
        &levels,
        (
            NEAREST_CAP_OF_HALF_CHORD * half_chord_px,
            half_chord_px + BEYOND_CHORD_PX,
        ),
    )?;
    let on_bisector = (mid.0 + along_px * along.0, mid.1 + along_px * along.1);
    let reach_px = a.reach_px.max(b.reach_px);
    let across_px = centre_line_offset(
        frame,
        on_bisector,
        (across, along),
        across_half_span_px(half_chord_px, reach_px, lines_offset_px),
        &levels,
        reach_px,
    )?;
    Some((
        on_bisector.0 + across_px * across.0,
        on_bisector.1 + across_px * across.1,
    ))
}

/// How far along the chord from the bisector the lines across reach: as far as the streak's
/// body runs clear of its caps (half the chord less the floor's reach across, beyond which a
/// line would cross a cap) and, on an arc bent by `lines_offset_px` (half its bend), as far as
/// the circle keeps within [`ARC_PARABOLA_PX`] of the parabola fitted to the lines; at least
/// [`MIN_ACROSS_HALF_SPAN_PX`].
fn across_half_span_px(half_chord_px: f32, reach_px: f32, lines_offset_px: f32) -> f32 {
    let body_px = half_chord_px - reach_px;
    let bend_px = 2.0 * lines_offset_px.abs();
    let arc_px = if bend_px > 0.0 {
        // The radius of the arc of that bend on that chord: `c² / 8s` for a shallow one.
        let radius_px = half_chord_px * half_chord_px / (2.0 * bend_px);
        (8.0 * ARC_PARABOLA_PX * radius_px.powi(3)).powf(0.25)
    } else {
        f32::INFINITY
    };
    body_px
        .min(arc_px)
        .clamp(MIN_ACROSS_HALF_SPAN_PX, MAX_ACROSS_HALF_SPAN_PX)
}

/// The offset along `n` from `point` to the streak's centre line (`(n, d)`: `d` along the
/// chord), from the lines across it spread evenly within `half_span_px` of `point` along `d`:
/// the centre line `a + b u + c u²` (`u` the line's place along, over `half_span_px`) fitted
/// to each line's mirror point ([`line_midpoint`]), weighed as those are, read at `u = 0`. A
/// straight streak's cross-section at one place is placed by a few pixels, whose grid moves a
/// sharp spot's edges by tenths of a pixel; along the streak the edges cross the grid at every
/// phase, and the fit averages that out. The parabola follows an arc's bend, and the slope a
/// chord a little off the path's. Within a pixel of the bisector, or where the lines on one
/// side of it found no light, the lines' mean is the offset. `None` when no line has a level
/// crossed on both sides.
fn centre_line_offset(
    frame: &Frame<'_>,
    point: (f32, f32),
    (n, d): ((f32, f32), (f32, f32)),
    half_span_px: f32,
    levels: &[f32; LEVELS.len()],
    reach_px: f32,
) -> Option<f32> {
    let step_px = (half_span_px / ACROSS_LINES_EACH_SIDE as f32).max(MIN_ACROSS_STEP_PX);
    let steps = ((half_span_px / step_px + 1e-3) as usize).min(ACROSS_LINES_EACH_SIDE) as i32;
    // Weighted sums of u^k (k = 0..4) and of the mirror point times u^k (k = 0..2); which
    // sides of the bisector had light.
    let (mut moments, mut targets) = ([0.0f32; 5], [0.0f32; 3]);
    let (mut before, mut after) = (false, false);
    for k in -steps..=steps {
        let t_px = k as f32 * step_px;
        let start = (point.0 + t_px * d.0, point.1 + t_px * d.1);
        let Some((mid_px, w)) =
            line_midpoint(frame, start, n, levels, (0.0, reach_px), Falls::First)
        else {
            continue;
        };
        before |= k < 0;
        after |= k > 0;
        let u = t_px / half_span_px;
        let mut power = w;
        for (i, m) in moments.iter_mut().enumerate() {
            *m += power;
            if let Some(target) = targets.get_mut(i) {
                *target += power * mid_px;
            }
            power *= u;
        }
    }
    if moments[0] <= 0.0 {
        return None;
    }
    let mean_px = targets[0] / moments[0];
    if steps <= 2 || !(before && after) {
        return Some(mean_px);
    }
    let normal = Matrix3::new(
        moments[0], moments[1], moments[2], //
        moments[1], moments[2], moments[3], //
        moments[2], moments[3], moments[4],
    );
    let centre_line = normal
        .try_inverse()
        .map(|inverse| inverse * Vector3::from(targets));
    Some(
        centre_line
            .map_or(mean_px, |c| c[0])
            .clamp(-reach_px, reach_px),
    )
    .filter(|a| a.is_finite())
}

/// The offset along `d` from `point` to the mirror line of the light, from the lines parallel
/// to `d` at `offsets` along `n` (`(d, n)`): the mean over the lines of their mirror points
/// ([`line_midpoint`], with the falls between `walk_px`), weighed as those are. `None` when
/// no level is crossed on both sides of any line.
fn mirror_offset(
    frame: &Frame<'_>,
    point: (f32, f32),
    (d, n): ((f32, f32), (f32, f32)),
    offsets: &[f32],
    levels: &[f32; LEVELS.len()],
    walk_px: (f32, f32),
) -> Option<f32> {
    let (mut sum, mut weights) = (0.0f32, 0.0f32);
    for offset in offsets {
        let start = (point.0 + offset * n.0, point.1 + offset * n.1);
        if let Some((mid_px, w)) = line_midpoint(frame, start, d, levels, walk_px, Falls::Final) {
            sum += w * mid_px;
            weights += w;
        }
    }
    (weights > 0.0).then(|| sum / weights)
}

/// Which falls through a level pair up on a line.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Falls {
    /// The first on either side: the lines across the streak, whose falls are its sides'.
    First,
    /// The first on either side past which the light stays below the level
    /// ([`stays_below`]): the lines along the streak, whose falls must be its caps'.
    Final,
}

/// The mirror point of the light on the line through `start` along `d`, as an offset along
/// `d`, and its weight: the mean over `levels` of the midpoints of the first falls through a
/// level on either side, each walked out to the farther of `(nearest_px, reach_px)`; a level
/// whose fall on either side is nearer than the nearer, or (for [`Falls::Final`]) past which
/// the light rises back, is left out. `None` when no level is crossed on both sides.
fn line_midpoint(
    frame: &Frame<'_>,
    start: (f32, f32),
    d: (f32, f32),
    levels: &[f32; LEVELS.len()],
    (nearest_px, reach_px): (f32, f32),
    falls: Falls,
) -> Option<(f32, f32)> {
    let forward = first_falls(frame, start, d, levels, reach_px, Armed::AtStart);
    let back = first_falls(frame, start, (-d.0, -d.1), levels, reach_px, Armed::AtStart);
    let (mut sum, mut weights) = (0.0f32, 0.0f32);
    for ((f, b), &level) in forward.iter().zip(&back).zip(levels) {
        if let (Some(f), Some(b)) = (f, b) {
            if f.at_px < nearest_px || b.at_px < nearest_px {
                continue;
            }
            // Risen back means risen past the next level up: the read noise beyond a cap's fall
            // through the lowest level may touch the level itself.
            let rise = level + (levels[1] - levels[0]);
            if falls == Falls::Final
                && !(stays_below(frame, start, d, f.at_px, rise)
                    && stays_below(frame, start, (-d.0, -d.1), b.at_px, rise))
            {
                continue;
            }
            // A crossing moves by the luma's error over the slope there: each midpoint counts
            // by the inverse of its variance, so that a glow's shallow flank, where the
            // floor's texture and the noise move a crossing by pixels, counts little beside a
            // core's steep one.
            let (fs, bs) = (f.slope_per_px, b.slope_per_px);
            let w = 1.0 / (1.0 / (fs * fs) + 1.0 / (bs * bs));
            sum += w * 0.5 * (f.at_px - b.at_px);
            weights += w;
        }
    }
    (weights > 0.0).then(|| (sum / weights, weights))
}

/// How far past a fall the light is looked at again, to tell a cap's fall from a dip.
const BEYOND_FALL_PX: [f32; 3] = [1.0, 2.0, 3.0];

/// Whether the luma on the line from `start` along `d` stays below `level` past a fall at
/// `fall_px`, as it does past a cap's: a spot with one peak falls monotonically beyond the
/// streak's end. A dip inside the body rises back. On a thin streak, a line half a pixel off
/// the path runs on the shoulder, where the read noise dips the light below the upper levels
/// for a pixel or two. A dip beyond half the half-chord passes [`NEAREST_CAP_OF_HALF_CHORD`].
/// Paired with the far cap's fall, it moved the middle of a 0.83 px disk's 60 px streak
/// 1.44 px along (sweep seed 13, point 78).
fn stays_below(
    frame: &Frame<'_>,
    start: (f32, f32),
    d: (f32, f32),
    fall_px: f32,
    level: f32,
) -> bool {
    BEYOND_FALL_PX.iter().all(|beyond| {
        let u = fall_px + beyond;
        luma_at(frame, start.0 + u * d.0, start.1 + u * d.1).is_none_or(|v| v < level)
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::{FrameSize, PixelFormat};

    /// A clipped streak 3 rows thick from x = 12 to 68, its caps falling to a floor of 20 over
    /// 4 px (its middle at x = 40, y = 24), whose lower row dips to 120 at x = 42–43: below
    /// the two upper levels on the line half a pixel off the path, as a thin streak's
    /// shoulder dips with noise.
    fn streak_with_a_dip() -> Vec<u8> {
        streak_with_a_dip_at(42)
    }

    /// The same streak with its lower row's dip at `x` and `x + 1`.
    fn streak_with_a_dip_at(x: usize) -> Vec<u8> {
        let (width, height) = (80usize, 48usize);
        let mut bytes = vec![20u8; width * height];
        for y in 23..=25 {
            for x in 12..=68 {
                bytes[y * width + x] = 250;
            }
            for step in 1..=4u8 {
                let luma = 250 - 46 * step;
                bytes[y * width + 12 - usize::from(step)] = luma;
                bytes[y * width + 68 + usize::from(step)] = luma;
            }
        }
        for x in x..=x + 1 {
            bytes[25 * width + x] = 120;
        }
        bytes
    }

    /// The middle of the streak in `bytes` is its true one, (40, 24), within 0.1 px.
    fn assert_middle_at_40_24(bytes: &[u8]) {
        let size = FrameSize::new(80, 48).unwrap();
        let frame = Frame::new_checked_as(bytes, size, 80, PixelFormat::Grey).unwrap();
        let (x, y) =
            centre(&frame, (40.3, 24.0), (1.0, 0.0), (0.0, 1.0), 27.0, 0.0, 250).expect("a middle");
        assert!(
            (x - 40.0).abs() < 0.1 && (y - 24.0).abs() < 0.1,
            "({x}, {y})"
        );
    }

    /// A fall inside the body is not a cap's: the dip, 2 px from the middle, is left out,
    /// and the middle is where the caps put it. Paired with the caps' falls 28 px out, it
    /// moved the middle 1.7 px along.
    #[test]
    fn a_dip_inside_the_body_does_not_move_the_middle() {
        assert_middle_at_40_24(&streak_with_a_dip());
    }

    /// A dip farther out, 18 px from the middle (past half the 27 px half-chord, where a cap's
    /// fall may lie), is not a cap's either: the light rises back past it. Paired with the far
    /// cap's fall, it moved the middle 0.69 px along.
    #[test]
    fn a_dip_far_out_in_the_body_does_not_move_the_middle() {
        assert_middle_at_40_24(&streak_with_a_dip_at(58));
    }
}
