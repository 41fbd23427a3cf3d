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
//! The same holds across the streak at the middle, whose cross-section is mirror-symmetric
//! about the path. Each crossing moves by the luma's error over the slope there, so each
//! pair of crossings counts by the inverse of its variance (the slopes squared).
//!
//! The intensity-weighted centroid the middle started from weighs every pixel of the streak's
//! rim, and on a 60 px streak a rim pixel 25 px from the middle whose luma the floor's texture
//! or the read noise moves carries that lever arm: on the sweep's 60 px streaks (seed 11) the
//! centroid was 0.13 / 0.56 px off along the streak (median / p95), the crossings here
//! 0.07 / 0.55 px. What is left is mostly blooms: where a glow reaches the levels on its own,
//! every crossing is on its shallow flank, which the floor's texture moves by tenths of a pixel.

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

/// The lines across the streak that place the middle across it, as offsets along the chord
/// from the bisector, in pixels: within a pixel, so that an arc's bend (its centre line moves
/// across by `t² / 2r` at `t` from the middle) stays below 0.02 px on the sweep's tightest
/// circle (15 px).
const ACROSS_LINES_PX: [f32; 5] = [-1.0, -0.5, 0.0, 0.5, 1.0];

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
        half_chord_px + BEYOND_CHORD_PX,
    )?;
    let on_bisector = (mid.0 + along_px * along.0, mid.1 + along_px * along.1);
    let across_px = mirror_offset(
        frame,
        on_bisector,
        (across, along),
        &ACROSS_LINES_PX,
        &levels,
        a.reach_px.max(b.reach_px),
    )?;
    Some((
        on_bisector.0 + across_px * across.0,
        on_bisector.1 + across_px * across.1,
    ))
}

/// The offset along `d` from `point` to the mirror line of the light, from the lines parallel
/// to `d` at `offsets` along `n` (`(d, n)`): the mean over the lines and `levels` of the
/// midpoints of the first falls through a level on either side, each walked out to
/// `reach_px`. `None` when no level is crossed on both sides of any line.
fn mirror_offset(
    frame: &Frame<'_>,
    point: (f32, f32),
    (d, n): ((f32, f32), (f32, f32)),
    offsets: &[f32],
    levels: &[f32; LEVELS.len()],
    reach_px: f32,
) -> Option<f32> {
    let (mut sum, mut weights) = (0.0f32, 0.0f32);
    for offset in offsets {
        let start = (point.0 + offset * n.0, point.1 + offset * n.1);
        let forward = first_falls(frame, start, d, levels, reach_px, Armed::AtStart);
        let back = first_falls(frame, start, (-d.0, -d.1), levels, reach_px, Armed::AtStart);
        for (f, b) in forward.iter().zip(&back) {
            if let (Some(f), Some(b)) = (f, b) {
                // A crossing moves by the luma's error over the slope there: each midpoint
                // counts by the inverse of its variance, so that a glow's shallow flank, where
                // the floor's texture and the noise move a crossing by pixels, counts little
                // beside a core's steep one.
                let (fs, bs) = (f.slope_per_px, b.slope_per_px);
                let w = 1.0 / (1.0 / (fs * fs) + 1.0 / (bs * bs));
                sum += w * 0.5 * (f.at_px - b.at_px);
                weights += w;
            }
        }
    }
    (weights > 0.0).then(|| sum / weights)
}
