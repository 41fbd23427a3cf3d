//! Where the LED was at the start and the end of the exposure: the streak's tips, refined to
//! sub-pixel from the brightness ramps at its ends.
//!
//! A disk of radius R swept along a path leaves a footprint whose end cap is a circle of
//! radius R around the path's end. With saturation, the clipped region stops short of that
//! circle: past it, the brightness falls linearly to the floor over a ramp whose length grows
//! with the streak (a faster LED spends less time on each pixel). So, walking outward along
//! the streak from a skeleton end, the brightness ramp is measured at two levels and
//! extrapolated to where it meets the floor: that is the footprint's edge, R past the tip.
//!
//! R comes from the cross-section at the streak's middle, corrected for the same ramp, and
//! that is right for a round spot only. A lens squeezes the spot radially near the picture's
//! edge (and a defocused LED can be elliptic): a still or slow LED then leaves an elliptic blob
//! whose skeleton is a short line along its long axis, and subtracting the width across its
//! middle from the ends of that axis makes up a path of 1–2 px, with a velocity. So each end's
//! cap is measured on its own: a swept spot's footprint, cut at a brightness level, ends in the
//! spot's own outline, and the half-widths of that outline at several depths behind the cap's
//! apex are fitted with an ellipse (for any ellipse, however tilted, the squared half-length
//! of a chord is quadratic in the chord's position along the axis). Its semi-axis along the
//! streak is the spot's own extent there. A blob no longer along its axis than the spot's
//! extents at its two ends, within the fits' scatter, is a still LED: it has no path, and the
//! tracker takes the middle. So is a blob whose path is no longer than the streak is wide
//! (its cross-section at the low level): when the streak is no longer than the spot is wide,
//! there is no direction to choose, and the head is the middle.
//!
//! The tips of a longer streak still subtract the width across the middle: the caps' fitted
//! extents scatter by a few tenths of a pixel more than that width (a clipped edge is read to
//! about a pixel), and subtracting them instead doubled the head error on the 1280×720 scene.
//!
//! Across the path, a straight streak's tips are then moved onto the line through its body's
//! sections (`body_line.rs`): each end's own section and direction scatter by tenths of
//! a pixel.

use super::bilinear::Walk;
use super::bitimage::{BitImage, Window};
use super::body_line;
use super::line_profile;
use super::ray_floor;
use crate::frame::Frame;

/// The two ramp levels, as fractions of the way from the local floor to the clip level. The
/// low one stays well above the floor: the LED's faint glow and the floor's texture bend the
/// foot of the ramp, and measured on rendered scenes a level of 0.2 was off by pixels where 0.4
/// holds to a few tenths.
const LEVEL_LOW: f32 = 0.4;
const LEVEL_HIGH: f32 = 0.8;

/// Profile sampling step.
const STEP_PX: f32 = 0.1;

/// How far back from an end the second axis point is taken.
const AXIS_BASE_PX: f32 = 4.0;

/// Skeleton pixels within this distance of an end give the streak's direction there.
const DIRECTION_RADIUS_PX: f32 = 6.0;

/// Step between the depths at which a cap's half-width is measured. Half a pixel: finer steps
/// sample the same two pixels again (the contour is bilinear between pixel centres).
const CAP_STEP_PX: f32 = 0.5;

/// Most depths measured on one cap (an LED up to `CAP_MAX_DEPTHS × CAP_STEP_PX` px wide).
const CAP_MAX_DEPTHS: usize = 24;

/// A blob within this many of the caps' standard deviations of the spot's own length is still
/// (as the fitted model's rule in `streak.rs`).
const STILL_UNCERTAINTIES: f32 = 2.0;

/// The refined tips of a streak.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tips {
    /// The LED's centre at the two ends of the path, in the order of the skeleton ends.
    pub tips_px: [(f32, f32); 2],
    /// The LED's footprint radius.
    pub radius_px: f32,
    /// Path length from tip to tip through the middle.
    pub path_length_px: f32,
    /// The blob is no longer than the spot itself (within the caps' uncertainty): a still LED,
    /// whose tips say nothing.
    pub still: bool,
    /// The unit directions outward along the streak at its two ends.
    pub outward: [(f32, f32); 2],
    /// The footprint's length along the streak, from one brightness edge to the other.
    pub footprint_px: f32,
    /// The scatter of the spot's own extent as its two caps measure it (one deviation).
    pub spread_px: f32,
}

/// Refines the skeleton `ends` of a streak with middle `mid` into path tips. `clip_luma` is
/// the frame's top luma level. `None` when a ramp cannot be measured (a streak touching the
/// frame edge, or another blob in the way).
pub fn refine(
    frame: &Frame<'_>,
    skeleton: &BitImage,
    window: Window,
    ends: [(f32, f32); 2],
    mid: (f32, f32),
    clip_luma: u8,
) -> Option<Tips> {
    let clip = f32::from(clip_luma);
    let mut ramps = [(0.0f32, 0.0f32); 2]; // (distance from the end to the floor edge, ramp length)
    let mut dirs = [(0.0f32, 0.0f32); 2];
    let mut origins = ends;
    for i in 0..2 {
        let rough = end_direction(skeleton, window, ends[i])?;
        // A skeleton end sits up to a pixel off the streak's axis (thinning leaves stairs
        // on a diagonal), and the skeleton's direction is as rough: centre the end and a
        // point a little further back across the streak, and walk along the line they make.
        let back = (
            ends[i].0 - AXIS_BASE_PX * rough.0,
            ends[i].1 - AXIS_BASE_PX * rough.1,
        );
        origins[i] = centre_across(frame, ends[i], rough, clip)?;
        let base = centre_across(frame, back, rough, clip)?;
        let (dx, dy) = (origins[i].0 - base.0, origins[i].1 - base.1);
        let len = dx.hypot(dy);
        if len < 0.5 * AXIS_BASE_PX {
            return None;
        }
        let d = (dx / len, dy / len);
        let ramp = ramp_along(frame, origins[i], d, clip)?;
        ramps[i] = (ramp.edge_px, ramp.length_px);
        dirs[i] = d;
    }
    // The cross-section at the middle, perpendicular to the chord, measured on both sides.
    let chord = (ends[1].0 - ends[0].0, ends[1].1 - ends[0].1);
    let chord_len = chord.0.hypot(chord.1);
    if chord_len <= f32::EPSILON {
        return None;
    }
    let n = (-chord.1 / chord_len, chord.0 / chord_len);
    let side_a = ramp_along(frame, mid, n, clip)?;
    let side_b = ramp_along(frame, mid, (-n.0, -n.1), clip)?;
    let half_width_low = 0.5 * (side_a.low_px + side_b.low_px);
    let ramp_len = 0.5 * (ramps[0].1 + ramps[1].1);
    let radius_px = half_width_low.hypot(0.5 * LEVEL_LOW * ramp_len);
    let tip = |i: usize| {
        let back = ramps[i].0 - radius_px;
        (
            origins[i].0 + back * dirs[i].0,
            origins[i].1 + back * dirs[i].1,
        )
    };
    let mut tips = [tip(0), tip(1)];
    // A Gaussian-like spot's ends are where its line profile across puts them (the ramps'
    // rule is a disk's): the pairing needs the path's length, which the rule above gives.
    let path_px = dist(tips[0], mid) + dist(mid, tips[1]);
    if let Some(end_px) = line_profile::place_ends(frame, mid, n, origins, dirs, path_px, clip_luma)
    {
        for ((tip, o), (d, e)) in tips.iter_mut().zip(origins).zip(dirs.iter().zip(end_px)) {
            *tip = (o.0 + e * d.0, o.1 + e * d.1);
        }
    }
    // A straight streak's tips lie on its body's line, read on many sections.
    let sides = [&side_a, &side_b].map(|r| body_line::Side {
        level: r.low_luma,
        edge_px: r.low_px,
    });
    if let Some(line) = body_line::read(frame, origins, half_width_low, sides) {
        tips = tips.map(|t| line.onto(t));
    }
    // Each end's cap outline at the low level gives the spot's own extent along the axis
    // there, measured as deep as the outline is the spot's: no deeper than the spot is wide,
    // nor than half the footprint (a still spot's two caps meet in its middle).
    let half_length = 0.5 * (dist(origins[0], origins[1]) + ramps[0].0 + ramps[1].0);
    let mut along_px = [radius_px; 2];
    let mut spread = 0.0f32;
    for i in 0..2 {
        let (d, (edge, ramp_length)) = (dirs[i], ramps[i]);
        let low = edge - LEVEL_LOW * ramp_length;
        let apex = (origins[i].0 + low * d.0, origins[i].1 + low * d.1);
        let depth_px = radius_px.min(half_length) - 0.5 * LEVEL_LOW * ramp_length;
        // Without a cap to fit, the width across the middle stands in (a round spot).
        if let Some(c) = cap(frame, apex, d, depth_px, radius_px, clip) {
            along_px[i] = c.along_px;
            spread = spread.hypot(c.sigma_px);
        }
    }
    // One spot at both ends of a path this short: where its two measured extents disagree by
    // more than their fits say, that disagreement is the scatter to beat.
    spread = spread.hypot(along_px[0] - along_px[1]);
    // A footprint no longer along its axis than the spot's own extent at its two ends (within
    // the caps' scatter): the blob is the spot itself, and its tips would only be its outline.
    let footprint_px = dist(origins[0], origins[1]) + ramps[0].0 + ramps[1].0;
    // Or a path no longer than the streak is wide (its cross-section at the low level): there
    // is no direction to choose, and an end picked on a blob that round is off by half of it
    // (a still LED's tips made a 5 px path of a 0.8 px one). The path is the footprint along
    // less the footprint across, both from edge to edge as the ramps read them, so that what
    // the ramps make of a spot (a wide glow's long ramps) cancels. A slow LED taken for still
    // costs little: the tracker carries its middle by the frames' motion.
    let across_px = side_a.edge_px + side_b.edge_px;
    let still = footprint_px <= along_px[0] + along_px[1] + STILL_UNCERTAINTIES * spread
        || footprint_px - across_px <= 2.0 * half_width_low;
    let path_length_px = dist(tips[0], mid) + dist(mid, tips[1]);
    Some(Tips {
        tips_px: tips,
        radius_px,
        path_length_px,
        still,
        outward: dirs,
        footprint_px,
        spread_px: spread,
    })
}

/// A cap's outline fitted as an ellipse.
struct Cap {
    /// Its semi-axis along the streak.
    along_px: f32,
    /// One standard deviation of that, from the fit's residual.
    sigma_px: f32,
}

/// Gauss–Newton steps of the cap's two-parameter fit (it starts at a round spot, a few
/// tenths from the answer, and converges quadratically).
const CAP_FIT_STEPS: usize = 6;

/// Fits the half-widths `w` of the cap's outline at depths `u` behind its `apex` (along `-d`,
/// out to `depth_px`) with the ellipse of half-width `across_px` whose semi-axis along the
/// axis is `a`, centred `c` behind the apex: `w² = across² · (1 − ((u − c)/a)²)`. `None` when
/// too few widths could be read or the fit does not settle on a positive extent.
fn cap(
    frame: &Frame<'_>,
    apex: (f32, f32),
    d: (f32, f32),
    depth_px: f32,
    across_px: f32,
    clip: f32,
) -> Option<Cap> {
    let n = (-d.1, d.0);
    let mut widths = [(0.0f32, 0.0f32); CAP_MAX_DEPTHS];
    let mut count = 0usize;
    for j in 0..CAP_MAX_DEPTHS {
        let u = (j + 1) as f32 * CAP_STEP_PX;
        if u > depth_px {
            break;
        }
        let q = (apex.0 - u * d.0, apex.1 - u * d.1);
        let (Some(a), Some(b)) = (
            ramp_along(frame, q, n, clip),
            ramp_along(frame, q, (-n.0, -n.1), clip),
        ) else {
            continue;
        };
        if let Some(slot) = widths.get_mut(count) {
            *slot = (u, 0.5 * (a.low_px + b.low_px) / across_px);
            count += 1;
        }
    }
    let widths = widths.get(..count)?;
    if count < 3 {
        return None;
    }
    // y = 1 − ((u − c)/a)² with y = (w/across)²: the outline's centre c behind the apex
    // (free, so that where the apex was read does not matter) and its extent a, from a
    // round spot.
    let (mut c, mut a) = (across_px, across_px);
    let mut normal = [[0.0f32; 2]; 2];
    let mut sq = 0.0f32;
    for _ in 0..CAP_FIT_STEPS {
        normal = [[0.0f32; 2]; 2];
        let mut rhs = [0.0f32; 2];
        sq = 0.0;
        for &(u, w) in widths {
            let t = (u - c) / a;
            let r = w * w - (1.0 - t * t);
            let j = [2.0 * t / a, 2.0 * t * t / a];
            for (row, &ji) in normal.iter_mut().zip(&j) {
                for (cell, &jk) in row.iter_mut().zip(&j) {
                    *cell += ji * jk;
                }
            }
            for (ri, &ji) in rhs.iter_mut().zip(&j) {
                *ri += ji * r;
            }
            sq += r * r;
        }
        let [[p, q], [_, t]] = normal;
        let det = p * t - q * q;
        if det <= f32::EPSILON {
            return None;
        }
        c += (t * rhs[0] - q * rhs[1]) / det;
        a += (p * rhs[1] - q * rhs[0]) / det;
        if !(a.is_finite() && c.is_finite() && a > 0.0) {
            return None;
        }
    }
    // The residual's scatter through the fit's covariance.
    let [[p, q], [_, t]] = normal;
    let det = p * t - q * q;
    let dof = count as f32 - 2.0;
    if det <= f32::EPSILON || dof <= 0.0 {
        return None;
    }
    let variance = sq / dof * p / det;
    Some(Cap {
        along_px: a,
        sigma_px: variance.sqrt(),
    })
}

/// `point` moved across the streak (direction `d`) to the centre of its cross-section there.
fn centre_across(
    frame: &Frame<'_>,
    point: (f32, f32),
    d: (f32, f32),
    clip: f32,
) -> Option<(f32, f32)> {
    let n = (-d.1, d.0);
    let left = ramp_along(frame, point, n, clip)?;
    let right = ramp_along(frame, point, (-n.0, -n.1), clip)?;
    let offset = 0.5 * (left.low_px - right.low_px);
    Some((point.0 + offset * n.0, point.1 + offset * n.1))
}

fn dist(a: (f32, f32), b: (f32, f32)) -> f32 {
    (a.0 - b.0).hypot(a.1 - b.1)
}

/// The outward direction of the skeleton at `end`: from the mean of the skeleton pixels near
/// it towards the end itself.
fn end_direction(skeleton: &BitImage, window: Window, end: (f32, f32)) -> Option<(f32, f32)> {
    let (mut sx, mut sy, mut n) = (0.0f32, 0.0f32, 0u32);
    let r2 = DIRECTION_RADIUS_PX * DIRECTION_RADIUS_PX;
    for (x, y) in skeleton.ones_in(window) {
        let (dx, dy) = (x as f32 - end.0, y as f32 - end.1);
        if dx * dx + dy * dy <= r2 {
            sx += x as f32;
            sy += y as f32;
            n += 1;
        }
    }
    if n == 0 {
        return None;
    }
    let (ox, oy) = (end.0 - sx / n as f32, end.1 - sy / n as f32);
    let len = ox.hypot(oy);
    (len > 0.5).then(|| (ox / len, oy / len))
}

/// A brightness ramp measured along a ray.
struct Ramp {
    /// Distance from the ray's start to where the ramp meets the floor (extrapolated).
    edge_px: f32,
    /// Length of the ramp from clip to floor.
    length_px: f32,
    /// Distance to the low level.
    low_px: f32,
    /// The luma of the low level (over the floor this ramp was read on).
    low_luma: f32,
}

/// Walks from `start` along unit vector `d`, and measures where the brightness falls through
/// the high and the low level between the clip level and the floor the ray reaches
/// ([`ray_floor`]: where the LED's light, its glow included, has died away).
fn ramp_along(frame: &Frame<'_>, start: (f32, f32), d: (f32, f32), clip: f32) -> Option<Ramp> {
    let mut walk = Walk::new(frame);
    let mut at = |i: usize| {
        let u = i as f32 * STEP_PX;
        walk.luma_at(start.0 + u * d.0, start.1 + u * d.1)
    };
    let floor = ray_floor::along(frame, start, d)?;
    let samples = (floor.reach_px / STEP_PX) as usize;
    let floor = floor.luma;
    let span = clip - floor;
    if span < 1.0 {
        return None;
    }
    let level = |v: f32| (v - floor) / span;
    let mut prev = level(at(0)?);
    let (mut high, mut low) = (None, None);
    for i in 1..=samples {
        let t = level(at(i)?);
        let cross = |target: f32| {
            let frac = (prev - target) / (prev - t);
            (i as f32 - 1.0 + frac) * STEP_PX
        };
        if high.is_none() && prev >= LEVEL_HIGH && t < LEVEL_HIGH {
            high = Some(cross(LEVEL_HIGH));
        }
        if high.is_some() && prev >= LEVEL_LOW && t < LEVEL_LOW {
            low = Some(cross(LEVEL_LOW));
            break;
        }
        prev = t;
    }
    let (high, low) = (high?, low?);
    let length_px = (low - high) / (LEVEL_HIGH - LEVEL_LOW);
    Some(Ramp {
        edge_px: low + LEVEL_LOW * length_px,
        length_px,
        low_px: low,
        low_luma: floor + LEVEL_LOW * span,
    })
}
