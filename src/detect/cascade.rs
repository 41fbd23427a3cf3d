//! When the ramps' reading of a streak is doubtful, so that `--streak-model auto` fits it
//! ([`super::fit`]) instead.
//!
//! The ramps ([`super::tips`]) are built for a sharp-edged spot: a disk whose light stops at
//! its rim, so that the luma across the streak falls from the clip to the floor within a
//! pixel, wherever the tone curve, the noise and the floor put the levels. There the ramps
//! place the ends to a few tenths of a pixel. A spot whose edge is resolved (a Gaussian, a
//! glow around a core) falls over several pixels, and every level the ramps and the line
//! profile cut it at lands on a shallow flank, where the floor's texture and the noise move a
//! crossing by tenths of a pixel to pixels, and where the ends depend on a fall the ramps do
//! not model (a glow, a tone curve). Over the 200 points of seed 11 (`tests/streak_sweep.rs`,
//! every frame run through both models), the frames this module calls doubtful had the ramps
//! out of a bound in 28 % of them (a head more than 1.5 px off, a speed more than 10 %, a
//! 60 px streak's middle more than 0.5 px) and the fit in 10 %; the frames it leaves to the
//! ramps had the ramps out in 2.1 %, the fit in 0.5 % (seed 12: 42 % and 12 %; 1.7 % and 1.7 %).
//!
//! So the cascade measures the fall across the streak's middle, perpendicular to the skeleton's
//! chord (along the rows for a blob without an axis, whose light falls alike every way): from
//! 0.8 to 0.2 of the way from the floor to the clip, on both sides, where the floor is where
//! the light has died away (`ray_floor`), the brighter of the two sides' reads. A fall wider
//! than [`SHARP_EDGE_PX`] is a resolved edge, and the streak is fitted. So is one whose floor
//! cannot be reached (the light still falling `ray_floor::MAX_REACH_PX` (64 px) out: a glow
//! wider than the ramps read), and a streak with an axis whose ramps could not be read at all.
//!
//! A sharp edge is not enough: the ramps also judge whether the blob is the spot itself (a
//! still LED, whose head the tracker carries from the middle), from its caps' outline and its
//! width, and on a short streak or an arc of a narrow disk that judgement misfires while their
//! own tips lie a whole streak apart. Their reading then contradicts itself
//! ([`ramps_contradict`]), and the streak is fitted: such frames had the head carried 1.1–5.7 px
//! off on short arcs, and left short lines without a speed (`tests/streak_cascade.rs`); on the
//! 200-point sweeps of seeds 11 and 12 the rule keeps 5 and 1 points within the bounds.
//!
//! A sharp edge on a narrow spot is not enough either: under [`NARROW_SPOT_PX`] of radius the
//! spot's outline is drawn by the pixels as much as by the LED, and the ramps' disk rule
//! reads narrow Gaussians and narrow disks a few tenths of a pixel off at each end, a few per
//! cent of a short path. A path shorter than [`SHORT_PATH_PX`] of such a spot is fitted
//! (`tests/streak_cascade.rs`: four sweep points' speed p95 from 10–16 % to 2–6 %).
//!
//! The edge is the LED's, not the frame's: the spot and its edge are the same from one frame
//! to the next, but one frame's fall is read on a few samples through noise and the floor's
//! texture, and a Gaussian spot's reads lie either side of [`SHARP_EDGE_PX`]. So it is judged
//! by the median of its falls over the LED's last frames ([`super::edge_memory`]), and an LED
//! whose median has read resolved, and whose fit held, is fitted again however sharp its edge
//! reads next ([`super::spot_memory::SpotMemory::remembers`]): the two models misread a spot
//! outside their families by different steady offsets, which the tracker learns for each
//! model from the frames that model read (`track::length_offset`), so that a track passed
//! between them learns neither, and its length and speed jump with the model. Over the 200
//! points of seeds 11, 12 and 13 this puts 34, 41 and 29 points out of the bounds, against
//! 35, 41 and 32 judged frame by frame (the median alone: 34, 42 and 31). A fit taken for the
//! frame's own doubt (a contradiction, a bend) is not kept: kept too, the sweep gave 32, 37
//! and 27, but a sharp disk stayed fitted after two robots crossed (`tests/several_robots.rs`:
//! its middle p95 0.16 → 0.53 px, the fit reading a 5.5 px disk's middle half a pixel off),
//! and without the median after the first frame whose edge read resolved at the limit
//! (`circles`: 50 of 60 frames fitted, against 5).

use super::level_falls::{first_falls, Armed};
use super::ray_floor;
use super::tips::Tips;
use crate::frame::Frame;

/// A sharp edge falls from 0.8 to 0.2 of its step within about this distance. Read by
/// bilinear interpolation along the rows, a step falls over 0.6 px where its edge lies on a
/// pixel's border, and over up to 1.2 px where it runs through a pixel's middle and leaves
/// that pixel half lit. Over where the edge lies, that is 0.91 px on average for a step that
/// does not clip, 0.70 px at 3× the clip and 0.63 px at 10×, where the half-lit pixel clips
/// too (more along a diagonal). A moving LED's edge lies elsewhere in each frame, and the
/// median of its frames' falls is what is judged ([`super::edge_memory`]). Over the sweep's
/// moving points (seed 11) the median fall is 0.73 px for its disks (p95 2.2 px: noise, the
/// floor's texture), 1.43 px for its Gaussians, 6.1 px for its glows. Narrow Gaussians (σ
/// 0.9–1.3 px) read about a pixel, as a disk that barely clips may: a bound of 0.85 px
/// fitted them, and also sharp disks that the fit reads worse (README, "A lower bound for a
/// sharp edge"). Their short paths are fitted by their width instead ([`NARROW_SPOT_PX`]).
pub const SHARP_EDGE_PX: f32 = 1.0;

/// The levels the fall is read between, as fractions of the way from the floor to the clip:
/// clear of the clip (a bilinear sample beside a clipped pixel understates it) and of the
/// floor (its texture).
const FALL_LEVELS: [f32; 2] = [0.8, 0.2];

/// How far the edge of the streak whose middle is `mid_px` and skeleton ends `ends_px` takes
/// to fall across its middle (the mean of its two sides), so that the ramps can read it when
/// that is within [`SHARP_EDGE_PX`] ([`is_sharp`]); `None` when it cannot be read. `spans`
/// says the ends make an axis (else the light is read along the rows). `clip_luma` is the
/// blob's top level.
pub fn edge_fall_px(
    frame: &Frame<'_>,
    mid_px: (f32, f32),
    ends_px: [(f32, f32); 2],
    clip_luma: u8,
    spans: bool,
) -> Option<f32> {
    let chord = (ends_px[1].0 - ends_px[0].0, ends_px[1].1 - ends_px[0].1);
    let chord_px = chord.0.hypot(chord.1);
    let across = if spans && chord_px > f32::EPSILON {
        (-chord.1 / chord_px, chord.0 / chord_px)
    } else {
        (1.0, 0.0)
    };
    let clip = f32::from(clip_luma);
    let rays = [across, (-across.0, -across.1)];
    let [Some(a), Some(b)] = rays.map(|d| ray_floor::along(frame, mid_px, d)) else {
        return None;
    };
    // The light falls to one floor on both sides; the brighter of the two reads is it. A dark
    // grout line that a ray runs along (crossed at a grazing angle, longer than the floor's
    // window) drags that side's read below the floor beside the streak, and its lower level
    // is then crossed only where the floor itself darkens, pixels out: on `circles`' tight
    // arcs of a sharp disk a fall of 8.9 px on one side against 1.2 px on the other.
    let floor_luma = a.luma.max(b.luma);
    let falls = [(rays[0], a.reach_px), (rays[1], b.reach_px)]
        .map(|(d, reach_px)| fall_px(frame, mid_px, d, clip, floor_luma, reach_px));
    match falls {
        [Some(a), Some(b)] => Some(0.5 * (a + b)),
        _ => None,
    }
}

/// Whether an edge that falls over `fall_px` ([`edge_fall_px`]) is sharp.
pub fn is_sharp(fall_px: f32) -> bool {
    fall_px <= SHARP_EDGE_PX
}

/// How far the luma along the ray from `start` along unit vector `d` takes to fall from the
/// upper to the lower of [`FALL_LEVELS`], between `clip` and `floor_luma`, within `reach_px`
/// (where the ray's light died away); `None` when the light spans less than a level, `start`
/// is below the upper level (not inside the light: nothing to read), or the ray does not fall
/// through both levels within its reach.
fn fall_px(
    frame: &Frame<'_>,
    start: (f32, f32),
    d: (f32, f32),
    clip: f32,
    floor_luma: f32,
    reach_px: f32,
) -> Option<f32> {
    let span = clip - floor_luma;
    if span < 1.0 {
        return None;
    }
    let levels = FALL_LEVELS.map(|f| floor_luma + f * span);
    match first_falls(frame, start, d, &levels, reach_px, Armed::AtStart) {
        [Some(upper), Some(lower)] => Some(lower.at_px - upper.at_px),
        _ => None,
    }
}

/// Whether a blob of `area_px` in a frame of `frame_px` pixels is a glow clipped past the glare
/// limit ([`super::MAX_BLOB_FRACTION`]; such a blob is kept only when it moved), which the fit
/// cannot read: it starts from the blob's outline, whose rough ends lie far inside the path's
/// in a glow tens of pixels wide (a 33 px stadium in the clipped glow of a 60 px path,
/// `tests/wide_glow.rs`), may move them only a few pixels, and samples a bounded number of
/// pixels of thousands clipped flat. Its paths there came out 42–56 px long (with a deviation
/// of 0.6–1 px) and its heads up to 8.8 px off; the ramps read the ends from the glow's
/// outline along the skeleton, and kept every report within 3 px.
pub fn beyond_the_fit(area_px: u32, frame_px: usize) -> bool {
    area_px as f32 > super::MAX_BLOB_FRACTION * frame_px as f32
}

/// Whether the ramps' reading of a streak contradicts itself: they call the blob still (no
/// longer than the spot, so that its tips would only be its outline) while their tips lie
/// farther apart than the spot they measured is wide (twice its radius). A still spot's tips
/// lie within its own footprint, so one of the two readings is wrong, and the frame does not
/// say which.
pub fn ramps_contradict(tips: &Tips) -> bool {
    tips.still && tips.path_length_px > 2.0 * tips.radius_px
}

/// Below this footprint radius (the ramps' `radius_px`, at their low level) a spot's short
/// path ([`SHORT_PATH_PX`]) is fitted even where its edge is sharp. The ramps read a disk:
/// each end is where the footprint's outline, less the disk's radius, puts it. A spot only a
/// few pixels across is drawn by the pixels as much as by the LED: its outline is two or
/// three pixels, their area and the interpolation move it by tenths of a pixel, and whether
/// it is a disk or a narrow Gaussian the frame does not tell (the line profile's foot reads
/// 0.49 for a σ 0.9 px Gaussian, 0.5–0.8 for the sweep's disks), so the ramps read the
/// narrow Gaussians with the disk's rule. The fit draws the pixel's area and the spot's
/// profile. On the sweep (seeds 11–13, 600 points), fitting every sharp spot under a bound of
/// 0 (none), 2, 2.5, 3, 3.5, 4 and 5 px put 69, 66, 65, 58, 59, 58 and 57 points out: most of
/// what the fit gains is had at 3 px. Wider sharp disks stay with the ramps, which read
/// `circles`' 4 px disk's middle 0.06 px off in the median against the fit's 0.25 px
/// (`tests/replay_accuracy.rs`).
pub const NARROW_SPOT_PX: f32 = 3.0;

/// The paths of narrow spots ([`NARROW_SPOT_PX`]) shorter than this are fitted. A few tenths
/// of a pixel at each end are 2–3 % of a 20 px path's length, the median bound on the
/// speed, and less on longer paths, where the fit of a narrow sharp disk's long streak is
/// mostly refused: on `fast-line` drawn with a 1.5 px disk, fitting every such path held in
/// 42 of 600 frames and doubled the replay's CPU time (0.20 → 0.38 s) for the same figures.
/// With the bound at 15, 20 and 30 px the sweep put 60 points out either way (58 without
/// it).
pub const SHORT_PATH_PX: f32 = 20.0;

/// Whether the ramps' reading of a streak is a short path of a narrow spot, which the fit
/// reads better ([`NARROW_SPOT_PX`], [`SHORT_PATH_PX`]).
pub fn too_narrow_for_the_ramps(tips: &Tips) -> bool {
    tips.radius_px < NARROW_SPOT_PX && tips.path_length_px < SHORT_PATH_PX
}
