//! Streak geometry of one blob: sub-pixel centroid, skeleton, the seed's point, and the ends.
//!
//! A moving LED smears into a streak whose middle is where the LED was halfway through the
//! exposure. The intensity-weighted centroid finds that middle to a fraction of a pixel on a
//! straight streak, but on a curved one (small fast circles) it lies inside the curve. The
//! seed's answer is the skeleton pixel nearest the mass centre. Here that pixel is refined: by
//! symmetry, the arc's middle lies on the line through the centroid perpendicular to the chord
//! between the streak's ends, so the middle is the centroid moved along that line to the
//! intensity centre of the streak's cross-section there.
//!
//! The rim's weights fall to nothing at the floor, and the floor is measured around the blob
//! (its mean plus `FLOOR_DEVIATIONS` deviations) where it is brighter than a fixed fraction
//! of the threshold: a bright, textured floor beside a streak otherwise carries weight and
//! pulls its centroid by tenths of a pixel (over the 200 sweep points the 60 px streaks'
//! middle went from 0.347 / 0.964 px to 0.217 / 0.664 px, median / p95).
//!
//! Even so, the centroid weighs the rim far out along a long streak, where the floor's texture
//! and the noise move it along the streak: a streak clearly longer than it is wide takes its
//! middle from the mirror symmetry of its light instead ([`mirror_middle`]; seed 11's 60 px
//! streaks 0.116 / 0.820 px with the ramps).

use heapless::Deque;

use super::bitimage::{BitImage, Window, NEIGHBOURS_8};
use super::blobs::{Blob, BoundingBox, Labeler};
use super::cascade;
use super::edge_memory::EdgeMemory;
use super::fit::{self, NoFit, PathFit, Rough, FWHM_PER_SIGMA};
use super::floor_bg::FloorBackground;
use super::light_centre;
use super::mirror_middle;
use super::moments::{Moments, StadiumPath};
use super::morph::{self, Kernel};
use super::skeleton::{self, SkeletonMethod, SkeletonScratch, SEED_PRE_DILATIONS};
use super::spot_memory::SpotMemory;
use super::spot_shape::{self, SpotOptics, SpotShape};
use super::threshold::Levels;
use super::tips;
use crate::frame::{Frame, FrameSize};

/// Pixels around a blob whose partial brightness still says where its edge is.
pub const HALO_PX: u32 = 2;

/// Below this fraction of the threshold a pixel carries no weight in the centroid: it is floor.
pub const WEIGHT_FLOOR_FRACTION: f32 = 0.6;

/// The rim weights start this many of the floor's deviations above its mean.
const FLOOR_DEVIATIONS: f32 = 3.0;

/// A chord shorter than this gives no direction; the streak is treated as a dot.
pub const MIN_CHORD_PX: f32 = 2.0;

/// A path within this many of the fit's standard deviations of the spot's width is still.
const STILL_UNCERTAINTIES: f32 = 2.0;

/// A streak at most this many spot widths long takes its middle from the light's centre...
const SHORT_STREAK_SPOTS: f32 = 3.0;

/// ... unless the fit measured its path to within this fraction of its length (one standard
/// deviation of its ends): the goal for the single-frame speed, the path's length over
/// the exposure, is 3 % (median).
const MEASURED_PATH_FRACTION: f32 = 0.03;

/// A fitted path's middle farther than this fraction of its length (plus a pixel) from the
/// streak's middle is not the light's path (see [`off_its_light`]).
const LIGHT_OFF_PATH_FRACTION: f32 = 0.25;

/// Of that, the fraction of the path left to the reading of the light's middle (the quarter
/// less the sixth a steady acceleration may put it off): the allowance across a fitted path
/// beyond its sagitta (see [`off_its_light`]).
const ACROSS_READING_FRACTION: f32 = LIGHT_OFF_PATH_FRACTION - 1.0 / 6.0;

/// A blob whose skeleton's chord is at least this many times its thickness is a streak with
/// an axis, whose middle is placed by the symmetry of its light ([`mirror_middle`]).
const ELONGATED_WIDTHS: f32 = 2.0;
/// A skeleton's chord more than 45° off an elongated blob's axis lies across it (halfway
/// between along and across; on point 182 of the sweep's seed 11 a spur's chord lay about 85°
/// off).
const ACROSS_AXIS_COS: f32 = core::f32::consts::FRAC_1_SQRT_2;

/// Skeleton pixels the walk to the ends may visit; more belong to no LED.
pub const MAX_SKELETON_PX: usize = 2048;

/// The geometry of one streak, in image pixels with (0, 0) the centre of the top-left pixel.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Streak {
    /// Intensity-weighted centroid of the blob and its rim.
    pub centroid_px: (f32, f32),
    /// The skeleton pixel nearest the centroid (the seed's point).
    pub seed_point_px: (u16, u16),
    /// The streak's middle, the seed's point refined to sub-pixel.
    pub mid_px: (f32, f32),
    /// The two ends of the skeleton, farthest apart along it.
    pub ends_px: [(f32, f32); 2],
    /// Steps along the skeleton from one end to the other.
    pub skeleton_length_px: u32,
    /// Pixels in the skeleton.
    pub skeleton_px: u32,
    /// Mean thickness: area over skeleton length.
    pub thickness_px: f32,
    /// Where the LED was at both ends of the exposure; `None` when they could not be
    /// measured (the fit failed, or a ramp could not be read).
    pub path: Option<StreakPath>,
    /// The streak model was fitted and failed: the middle is the only position to trust
    /// (nothing is extrapolated from it).
    pub path_failed: bool,
    /// Which of `ends_px` the frame's edge cut: the light runs on past what the camera sees
    /// there (an LED driving into or out of view), so the middle and length are the visible
    /// part's, not the path's, and that end is not where the LED was. An end is cut where a
    /// step past it, by half the blob's thickness and a pixel, leaves the picture; a blob
    /// that reaches the edge with no end cut so (the last sliver of a leaving LED's light) is
    /// cut at both.
    pub cut_ends: [bool; 2],
}

impl Streak {
    /// Whether the frame's edge cut either end of the streak.
    pub fn cut_by_edge(&self) -> bool {
        self.cut_ends[0] || self.cut_ends[1]
    }

    /// Whether the streak model was fitted to it ([`StreakModel::Fit`], or
    /// [`StreakModel::Auto`] on a doubtful streak).
    pub fn fitted(&self) -> bool {
        self.path_failed || self.path.is_some_and(|p| p.fit_px.is_some())
    }

    /// The path, where it was read as moving: longer than the spot is wide, beyond its ends'
    /// deviations (a still path's ends are both its middle, and the ramps give a still spot
    /// no path).
    pub fn moving_path(&self) -> Option<StreakPath> {
        self.path.filter(|p| p.ends_px[0] != p.ends_px[1])
    }

    /// The longest path the LED can have taken during the exposure that left this blob: its
    /// light lies along the whole path, so the blob reaches from end to end of it, and a
    /// barely clipped end may fall short of the clip by a spot's width. Both widths are the
    /// diameter of a disk of the blob's area (a streak's own width is less), and the length
    /// the skeleton's.
    pub fn longest_path_px(&self) -> f32 {
        let area_px = self.thickness_px * (self.skeleton_length_px as f32 + 1.0);
        let diameter_px = 2.0 * (area_px / core::f32::consts::PI).sqrt();
        self.skeleton_length_px as f32 + 2.0 * diameter_px
    }
}

/// How the LED's position at the start and end of the exposure is measured.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum StreakModel {
    /// The brightness ramps at the streak's ends, extrapolated to the floor
    /// ([`tips`]): built for a sharp-edged disk spot.
    Ramps,
    /// A swept-spot model fitted to the pixels ([`fit`]): the spot's width, brightness and
    /// the camera's tone come from the frame itself.
    Fit,
    /// The ramps, and the fit where the ramps' reading is doubtful ([`cascade`]). The default:
    /// it holds nearly as much of the sweep as the fit, at the ramps' cost on a sharp disk.
    #[default]
    Auto,
}

/// The LED's path over the exposure.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StreakPath {
    /// The LED at the two ends of the exposure, in the order of the skeleton's ends. For a
    /// still LED (a streak no longer than the spot is wide) both are the middle: there is no
    /// direction to tell them apart.
    pub ends_px: [(f32, f32); 2],
    /// Length of the path from end to end.
    pub path_length_px: f32,
    /// One standard deviation of the ends, from the fit's residual ([`StreakModel::Fit`]).
    pub fit_px: Option<f32>,
    /// One standard deviation of the path's length as the fit states it
    /// ([`StreakModel::Fit`], `PathFit::length_noise_px`), in image pixels.
    pub length_noise_px: Option<f32>,
    /// The same with each pixel's own residual, at least `length_noise_px`
    /// ([`StreakModel::Fit`], `PathFit::length_deviation_px`), in image pixels:
    /// where the model's profile misses the LED's at the ends, the misfit shows here.
    pub length_deviation_px: Option<f32>,
    /// The floor the fit read the light on ([`StreakModel::Fit`]).
    pub fit_floor: Option<FitFloor>,
    /// Where the fit called its path still (`ends_px` the middle), the ends it read: a bloom
    /// clipped far into its glow fits a spot as wide as the glow, wider than a path of
    /// 10–20 px, which the fit still reads to a fraction of a pixel. One frame cannot tell
    /// that path from a still bloom's misfit; the middles' motion can (the tracker's rule).
    pub still_ends_px: Option<[(f32, f32); 2]>,
}

/// The floor under a fitted streak: learned where the floor was seen without the light, else
/// one fitted flat floor (the first frames, an LED standing still since the start), whose
/// texture the fit may read as light.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FitFloor {
    /// Every fitted pixel's floor was learned.
    Learned,
    /// Some were: the others shared a fitted flat floor.
    Partly,
    /// None was: the fit ran on a fitted flat floor.
    Flat,
}

impl FitFloor {
    /// Of the fraction of the fitted pixels whose floor was learned.
    fn of(measured: f32) -> Self {
        if measured >= 1.0 {
            FitFloor::Learned
        } else if measured > 0.0 {
            FitFloor::Partly
        } else {
            FitFloor::Flat
        }
    }

    /// The name used in the output.
    pub fn name(self) -> &'static str {
        match self {
            FitFloor::Learned => "learned",
            FitFloor::Partly => "partly",
            FitFloor::Flat => "flat",
        }
    }
}

/// Scratch for the streak stage, sized once to the frame.
pub struct StreakScratch {
    blob: BitImage,
    halo: BitImage,
    skeleton: BitImage,
    visited: BitImage,
    skeleton_scratch: SkeletonScratch,
    queue: Deque<(u16, u16), MAX_SKELETON_PX>,
    /// Where the last analysis wrote, cleared before the next one so no stale pixels remain.
    last_window: Option<Window>,
}

impl StreakScratch {
    /// Images of `width × height`.
    pub fn new(width_px: usize, height_px: usize) -> Self {
        let image = || BitImage::with_dimensions(width_px, height_px);
        StreakScratch {
            blob: image(),
            halo: image(),
            skeleton: image(),
            visited: image(),
            skeleton_scratch: SkeletonScratch::new(width_px, height_px),
            queue: Deque::new(),
            last_window: None,
        }
    }

    /// Clears what the last analysis left in the scratch images.
    pub fn reset(&mut self) {
        if let Some(window) = self.last_window.take() {
            clear(self, window);
        }
    }

    /// The skeleton of the last analysed blob (valid inside its window).
    pub fn skeleton(&self) -> &BitImage {
        &self.skeleton
    }
}

/// Analyses blob `index` of `labeler` on `frame`. `threshold_luma` is the level the mask was
/// cut at; rim pixels are weighted by how close they come to it. The tips of
/// [`StreakModel::Ramps`] are placed for the spot's shape at the blob ([`spot_shape`]): through
/// `optics` (a lens that squeezes a round spot) or, without one, a round spot; either way a tip
/// run on into something bright beside the LED is refused.
#[allow(clippy::too_many_arguments)]
pub fn analyze(
    frame: &Frame<'_>,
    labeler: &Labeler,
    index: usize,
    blob: &Blob,
    levels: Levels,
    method: SkeletonMethod,
    model: StreakModel,
    background: Option<&FloorBackground>,
    optics: Option<&dyn SpotOptics>,
    (spots, edges): (&mut SpotMemory, &mut EdgeMemory),
    scratch: &mut StreakScratch,
) -> Streak {
    let threshold_luma = levels.threshold_luma.unwrap_or(levels.top_luma);
    let b = blob.bbox;
    let margin = (SEED_PRE_DILATIONS + HALO_PX + 1) as usize;
    let window = scratch
        .blob
        .window_around(b.x_min_px, b.y_min_px, b.x_max_px, b.y_max_px, margin);
    scratch.reset();
    scratch.last_window = Some(window);
    for run in labeler.runs_of(index) {
        scratch
            .blob
            .set_run(run.y.into(), run.x0.into(), run.x1.into());
    }

    scratch.halo.copy_window_from(&scratch.blob, window);
    morph::dilate_n(
        &mut scratch.halo,
        &mut scratch.visited,
        Kernel::Square,
        HALO_PX,
        window,
    );
    scratch.visited.clear_window(window);
    skeleton::skeletonize(
        method,
        &scratch.blob,
        &mut scratch.skeleton,
        &mut scratch.skeleton_scratch,
        window,
    );

    let weights = Weights::new(threshold_luma, floor_around(frame, b, margin));
    let centroid_px =
        weighted_centroid(frame, &scratch.halo, window, &weights).unwrap_or(blob.mass_centre_px);
    let source = if scratch.skeleton.window_is_empty(window) {
        &scratch.blob
    } else {
        &scratch.skeleton
    };
    let (seed_point, skeleton_px) = nearest_set_pixel(source, window, centroid_px);
    let seed_point_px = seed_point.unwrap_or((
        centroid_px.0.round().max(0.0) as u16,
        centroid_px.1.round().max(0.0) as u16,
    ));

    let (end_a, _) = farthest_along(
        &scratch.skeleton,
        &mut scratch.visited,
        &mut scratch.queue,
        window,
        seed_point_px,
    );
    scratch.visited.clear_window(window);
    let (end_b, steps) = farthest_along(
        &scratch.skeleton,
        &mut scratch.visited,
        &mut scratch.queue,
        window,
        end_a,
    );
    let ends_px = [to_f32(end_a), to_f32(end_b)];
    let thickness_px = blob.area_px as f32 / (steps as f32 + 1.0);

    let mid_px = middle(
        frame,
        &scratch.halo,
        window,
        &weights,
        centroid_px,
        ends_px,
        seed_point_px,
        thickness_px,
        levels.top_luma,
    );
    let spans = spans_its_middle(ends_px, mid_px);
    let ramps = |scratch: &StreakScratch| {
        ramps_path(
            frame,
            &scratch.skeleton,
            window,
            (ends_px, mid_px, spans),
            levels,
            optics,
        )
    };
    // Whether the fit read this LED in its last frames, and its fit held: asked before this
    // frame's fit takes the spot's place.
    let fitted_before = model == StreakModel::Auto && spots.remembers(mid_px);
    let mut fitted = || {
        let moments = Moments::of_runs(labeler.runs_of(index).map(|r| (r.y, r.x0, r.x1)));
        fitted_path(
            frame,
            blob,
            (ends_px, mid_px, thickness_px),
            moments.map(|m| m.stadium()),
            levels,
            background,
            (shape_at(optics, mid_px), spots, model),
        )
    };
    let (mid_px, path, fitted_now) = match model {
        StreakModel::Ramps => (mid_px, ramps_streak_path(ramps(scratch)), false),
        StreakModel::Fit => {
            let (mid, path) = fitted();
            (mid, path.ok(), true)
        }
        StreakModel::Auto => {
            // A resolved edge first: the ramps are not read where they would be dropped. A
            // bent streak is fitted too: the ramps' middle is read for a straight one (a blob
            // whose ends do not span its middle has no axis to be bent along).
            let straight = !(spans && bent(bend_px(ends_px, mid_px), thickness_px));
            // The edge is the LED's, not the frame's (see `cascade`): judged by the median of
            // its falls over the LED's last frames, and once that has read resolved, the LED is
            // fitted while its fit holds.
            let sharp = straight && {
                let fall_px = cascade::edge_fall_px(frame, mid_px, ends_px, levels.top_luma, spans);
                let verdict = edges.judge(mid_px, dist(ends_px[0], ends_px[1]), fall_px);
                verdict.is_some_and(|v| {
                    cascade::is_sharp(v.pooled_fall_px) && !(v.resolved_before && fitted_before)
                })
            };
            let tips = sharp.then(|| ramps(scratch));
            // The ramps' reading stands: read now, unless it was above.
            let ramps_stand = || {
                (
                    mid_px,
                    ramps_streak_path(tips.unwrap_or_else(|| ramps(scratch))),
                    false,
                )
            };
            match tips {
                // A glow clipped past the glare limit: the fit cannot read it, so the ramps'
                // reading stands, as with `--streak-model ramps` (no path where they have none).
                _ if cascade::beyond_the_fit(blob.area_px, frame.size().pixels()) => ramps_stand(),
                // Sharp, wide enough for the ramps' disk, and read without contradiction (or
                // with no axis to read them on).
                Some(tips)
                    if tips.is_some_and(|t| {
                        !cascade::ramps_contradict(&t) && !cascade::too_narrow_for_the_ramps(&t)
                    }) || (tips.is_none() && !spans) =>
                {
                    ramps_stand()
                }
                _ => match fitted() {
                    // The fitted model contradicts the pixels at an end, cannot tell its path
                    // from a still LED, or lies off the light: the ramps' reading (with their
                    // own guards, such as the tip refused past the spot's extent) stands.
                    (_, Err(NoFit::EndOffTheClip | NoFit::Uncertain | NoFit::OffItsLight)) => {
                        ramps_stand()
                    }
                    (mid, path) => (mid, path.ok(), true),
                },
            }
        }
    };

    // A round blob whose fitted path reads still has no axis for the fit's middle to rest on:
    // where the floor under it is known, the centre of its light is the more precise of the
    // two (see [`light_centre`]); the still path's ends are its middle.
    let chord_px = (ends_px[1].0 - ends_px[0].0).hypot(ends_px[1].1 - ends_px[0].1);
    let still_fit_px = path
        .filter(|p| p.ends_px[0] == p.ends_px[1])
        .and_then(|p| p.fit_px);
    let light = still_fit_px
        .filter(|_| chord_px < ELONGATED_WIDTHS * thickness_px)
        .and_then(|fit_px| {
            background
                .and_then(|f| {
                    let others = labeler.blobs().iter().enumerate();
                    let others = others.filter(|&(i, _)| i != index).map(|(_, o)| o);
                    light_centre::light_centre(
                        frame,
                        blob,
                        thickness_px,
                        levels.top_luma,
                        f,
                        others,
                    )
                })
                .filter(|c| c.sigma_px < fit_px)
        });
    let (mid_px, path) = match light {
        Some(c) => (
            c.centre_px,
            path.map(|p| StreakPath {
                ends_px: [c.centre_px; 2],
                ..p
            }),
        ),
        None => (mid_px, path),
    };
    Streak {
        centroid_px,
        seed_point_px,
        mid_px,
        ends_px,
        skeleton_length_px: steps,
        skeleton_px: skeleton_px as u32,
        thickness_px,
        path,
        path_failed: fitted_now && path.is_none(),
        cut_ends: ends_cut(b, ends_px, thickness_px, frame.size()),
    }
}

/// Which of a blob's skeleton `ends` the frame's edge cut: where the blob (box `b`, mean
/// thickness `thickness_px`) reaches an edge, an end is cut when a step past it, away from
/// the other end, by half the thickness and a pixel, leaves the frame (the skeleton of a
/// streak cut by the edge runs to within about half its width of the cut). A blob that
/// reaches the edge with neither end cut so, or with no chord to step along, is cut at
/// both: the last sliver of an LED leaving the view is a blob along the edge whose
/// skeleton steps along it (an LED leaving at 450 px/s read 11 px short and 86 % slow
/// from it), and from one frame it cannot be told from a streak along the edge whose light
/// only grazes it.
fn ends_cut(
    b: BoundingBox,
    ends: [(f32, f32); 2],
    thickness_px: f32,
    size: FrameSize,
) -> [bool; 2] {
    let touches = b.x_min_px == 0
        || b.y_min_px == 0
        || b.x_max_px + 1 >= size.width()
        || b.y_max_px + 1 >= size.height();
    if !touches {
        return [false; 2];
    }
    let (width_px, height_px) = (size.width() as f32, size.height() as f32);
    let chord_px = dist(ends[0], ends[1]);
    if chord_px < MIN_CHORD_PX {
        return [true; 2];
    }
    let step_px = 0.5 * thickness_px + 1.0;
    let past = |end: (f32, f32), other: (f32, f32)| {
        let (x, y) = (
            end.0 + (end.0 - other.0) / chord_px * step_px,
            end.1 + (end.1 - other.1) / chord_px * step_px,
        );
        // Pixel centres run from 0 to the size less one: past half a pixel beyond them is
        // outside the picture.
        x < -0.5 || y < -0.5 || x > width_px - 0.5 || y > height_px - 0.5
    };
    match [past(ends[0], ends[1]), past(ends[1], ends[0])] {
        [false, false] => [true; 2],
        cut => cut,
    }
}

/// The ramps' tips of a streak with skeleton ends `ends_px` and middle `mid_px`: `None` when
/// they cannot be read, or when the ends do not span the middle (`spans`, from
/// [`spans_its_middle`]; then they are not tried).
fn ramps_path(
    frame: &Frame<'_>,
    skeleton: &BitImage,
    window: Window,
    (ends_px, mid_px, spans): ([(f32, f32); 2], (f32, f32), bool),
    levels: Levels,
    optics: Option<&dyn SpotOptics>,
) -> Option<tips::Tips> {
    spans
        .then(|| tips::refine(frame, skeleton, window, ends_px, mid_px, levels.top_luma))
        .flatten()
        .and_then(|t| spot_shape::through_lens(t, ends_px, mid_px, shape_at(optics, mid_px)))
}

/// The shape `optics` makes of a round spot at `px`; round without a lens, or where the lens
/// cannot say.
fn shape_at(optics: Option<&dyn SpotOptics>, px: (f32, f32)) -> SpotShape {
    optics
        .and_then(|o| o.spot_shape_at(px))
        .unwrap_or_else(SpotShape::identity)
}

/// The path of the ramps' tips. A still LED has no path: its ends would only be the spot's
/// own outline, and the tracker carries its middle by the frames' velocity instead.
fn ramps_streak_path(tips: Option<tips::Tips>) -> Option<StreakPath> {
    tips.filter(|t| !t.still).map(|t| StreakPath {
        ends_px: t.tips_px,
        path_length_px: t.path_length_px,
        fit_px: None,
        length_noise_px: None,
        length_deviation_px: None,
        fit_floor: None,
        still_ends_px: None,
    })
}

/// The middle and the path from the fitted streak model of a spot of the lens's `shape`, with
/// the still rule (judged in ideal pixels, where the spot is round); the streak's own middle
/// and why there is no path when the fit fails ([`NoFit`]), or when its path is longer than
/// the spot is wide and its ends' deviation longer than the path. Those two refusals, and the
/// fitted end off the clip ([`NoFit::EndOffTheClip`]), are made for `auto` only, where the
/// ramps' reading stands behind the fit: with `--streak-model fit` alone a refused path is a
/// frame without one, which cost the sweep more than the rare wrong end (3 points out on seed
/// 11, 37 -> 40, from the deviation rule; 1 on seed 12 from the end rule). A path whose middle
/// lies off the light ([`NoFit::OffItsLight`]) is refused in both: it is tens of pixels wrong,
/// and no sweep frame had one.
fn fitted_path(
    frame: &Frame<'_>,
    blob: &Blob,
    (ends_px, mid_px, thickness_px): ([(f32, f32); 2], (f32, f32), f32),
    stadium: Option<StadiumPath>,
    levels: Levels,
    background: Option<&FloorBackground>,
    (shape, spots, model): (SpotShape, &mut SpotMemory, StreakModel),
) -> ((f32, f32), Result<StreakPath, NoFit>) {
    let ramps_behind = model == StreakModel::Auto;
    // A round blob's skeleton is a dot, and area over length is then its area: its width is
    // at most the diameter of a disk of that area.
    let disk_diameter_px = 2.0 * (blob.area_px as f32 / core::f32::consts::PI).sqrt();
    let skeleton = Rough {
        ends_px,
        mid_px,
        thickness_px: thickness_px.min(disk_diameter_px),
    };
    // The skeleton of a blob no longer than it is wide is noise: the stadium of its moments
    // is the better start there (a short streak in a wide glow). So is a skeleton whose ends
    // lie across the stadium of an elongated blob: thinning a blob tens of pixels thick leaves
    // spurs, and a spur's end taken for the streak's starts the fit across the streak.
    let rough = match stadium {
        Some(s)
            if dist(s.ends_px[0], s.ends_px[1]) < s.width_px || chord_lies_across(ends_px, s) =>
        {
            Rough {
                ends_px: s.ends_px,
                mid_px: s.mid_px,
                thickness_px: s.width_px,
            }
        }
        _ => skeleton,
    };
    let f = match spots.fit_at(rough.mid_px, |warm| {
        fit::fit(
            frame,
            &rough,
            levels.top_luma,
            background,
            shape,
            warm,
            ramps_behind,
        )
    }) {
        Ok(f) => f,
        Err(why) => return (mid_px, Err(why)),
    };
    let spot_width_px = FWHM_PER_SIGMA * f.spot_sigma_px;
    // A path longer than the spot is wide whose ends are uncertain by more than its own
    // length is not measured: the fit cannot tell it from a still LED, and the still rule
    // below (the path within the width plus two deviations) would call it still on the
    // deviation alone, as it did a 16 px streak beside a white square (deviation 17 px),
    // both ends 8 px off at the middle. (A path within the width is still whatever the
    // deviation: the still Blooms' deviations reach 3.6 px. Refusing every path longer than
    // the width whose deviation exceeded the width, a sharp disk's narrow fitted spot made
    // that 1-10 px on right paths of 4-39 px, and cost 7 sweep points on seed 11.)
    //
    // These rules read the ends' deviation from the noise alone (`noise_px`), which their
    // constants were measured on; the wider one with the model's misfit (`uncertainty_px`)
    // is reported, and weighed against the frames' motion by the tracker. Read here, it
    // called a 60 px halo streak's fitted path unmeasured where it was right (independent
    // scenes seed 3, scene 28: a middle 0.54 px off where the fitted one was 0.09).
    if ramps_behind && f.ideal_path_length_px > spot_width_px && f.noise_px > f.ideal_path_length_px
    {
        return (mid_px, Err(NoFit::Uncertain));
    }
    // A path whose middle lies farther from the streak's own middle than any steady
    // acceleration or bend puts the light is not the light's path, in either model: the fit
    // wandered off it (a halo clipped at 56 full wells on 1280x720, independent scenes seed 4
    // scene 5: a fitted middle 30.5 px from the light's on a 95 px path, the head 38 px off).
    if off_its_light(&f, mid_px) {
        return (mid_px, Err(NoFit::OffItsLight));
    }
    // No longer than the spot is wide, within the noise's deviation: still, and both ends
    // are the middle.
    let still = f.ideal_path_length_px <= spot_width_px + STILL_UNCERTAINTIES * f.noise_px;
    // On a streak a few spots long, the light's symmetric centre is a steadier middle than
    // the fitted path's, which trades length against the spot's width; unless the fit pinned
    // the moving path's ends to a small fraction of its length, so that the trade did not
    // happen. That is the case of a long streak whose core is buried in a saturated glow: the
    // fitted spot is the glow, a few glows make a 60 px streak "short", and its light's centre,
    // read over a wide glow on a floor whose texture lifts one flank more than the other, was
    // 0.5-1.3 px off where the fitted middle is within a few tenths.
    let measured = !still && f.noise_px <= MEASURED_PATH_FRACTION * f.ideal_path_length_px;
    let mid = if f.ideal_path_length_px <= SHORT_STREAK_SPOTS * spot_width_px && !measured {
        mid_px
    } else {
        f.mid_px
    };
    let path = StreakPath {
        ends_px: if still { [mid; 2] } else { f.ends_px },
        still_ends_px: still.then_some(f.ends_px),
        path_length_px: f.path_length_px,
        fit_px: Some(f.uncertainty_px),
        length_noise_px: Some(f.length_noise_px * image_per_ideal(&f)),
        length_deviation_px: Some(f.length_deviation_px * image_per_ideal(&f)),
        fit_floor: Some(FitFloor::of(f.floor_measured)),
    };
    (mid, Ok(path))
}

/// Whether the fitted path `f` lies off the light whose middle the streak's pixels put at
/// `light_mid_px`. An LED lays its light over the exposure in time, so the light's centre is
/// its mean position: under a steady acceleration, from rest included, that is at most a
/// sixth of the path from the path's middle, and the clip, which spreads a saturated
/// streak's light evenly along it, draws it nearer. The bound is a quarter of the path, the
/// rest of it left to the reading of the light's middle (a skeleton's on an arc), plus a
/// pixel. Over sweep seeds 11-13 (2,851 moving fitted paths) the largest distance was 0.26 of
/// a 35 px path and 0.34 of a 1 px one (0.33 px).
///
/// Across the path's chord the light's centre lies on a straight path's line whatever the
/// speed, and on an arc between the arc's middle and the chord's (the centre of an arc's
/// light is nearer the chord than the arc is), so no farther off than the sagitta. Across,
/// the bound is the sagitta plus the same allowance for the reading (a twelfth of the path,
/// the quarter less the sixth) and a pixel. A straight 180 px path of a halo clipped 110 px
/// wide, seen by a 1920×1080 camera (independent scenes seed 2, scene 26), was fitted along
/// the blob's flank, 42 px beside its light, within the quarter of its length; over the
/// independent scenes at 640×480 (seeds 1-9), 1280×720 (seeds 1-6) and 320×240 and
/// 1920×1080 (seeds 1-2), 9,400 fitted paths, beyond that one and seed 4's scene 5 (already
/// off by the quarter) the light lay at most 2.9 px across beyond the sagitta (0.03 of a
/// 106 px path whose fit was uncertain by 31 px), 2.2 px of a 29 px path (0.08 of it), and
/// under 0.8 px on every other.
fn off_its_light(f: &PathFit, light_mid_px: (f32, f32)) -> bool {
    let length_px = f.path_length_px;
    if dist(f.mid_px, light_mid_px) > LIGHT_OFF_PATH_FRACTION * length_px + 1.0 {
        return true;
    }
    let [a, b] = f.ends_px;
    let chord_px = dist(a, b);
    if chord_px <= 0.0 {
        return false;
    }
    let chord_mid_px = (0.5 * (a.0 + b.0), 0.5 * (a.1 + b.1));
    let sagitta_px = dist(f.mid_px, chord_mid_px);
    let (dx, dy) = (light_mid_px.0 - f.mid_px.0, light_mid_px.1 - f.mid_px.1);
    let across_px = (dx * (b.1 - a.1) - dy * (b.0 - a.0)).abs() / chord_px;
    across_px > sagitta_px + ACROSS_READING_FRACTION * length_px + 1.0
}

/// Image pixels per ideal pixel along a fitted path (1 where it is too short to tell): the
/// fit states its length's deviation in ideal pixels, the tracker compares image lengths.
fn image_per_ideal(f: &PathFit) -> f32 {
    if f.ideal_path_length_px > 1.0 {
        f.path_length_px / f.ideal_path_length_px
    } else {
        1.0
    }
}

/// Whether the chord between the skeleton's `ends` lies across the axis of `stadium`, an
/// elongated blob's (a path at least as long as the stadium is wide): more than
/// [`ACROSS_AXIS_COS`]'s angle off it. A streak's skeleton runs along its blob.
fn chord_lies_across(ends: [(f32, f32); 2], stadium: StadiumPath) -> bool {
    let axis = sub(stadium.ends_px[1], stadium.ends_px[0]);
    let chord = sub(ends[1], ends[0]);
    let (axis_px, chord_px) = (axis.0.hypot(axis.1), chord.0.hypot(chord.1));
    axis_px >= stadium.width_px
        && chord_px > 0.0
        && (axis.0 * chord.0 + axis.1 * chord.1).abs() < ACROSS_AXIS_COS * axis_px * chord_px
}

/// Whether the skeleton's `ends` make a spine whose tips can be read: a chord of at least
/// [`MIN_CHORD_PX`] whose midpoint is no farther from the streak's middle than half the chord
/// (a path bent by up to a half turn). Thinning a round blob (a still LED in a wide glow) can
/// leave a short spur on its rim, whose "ends" lie a radius from its middle: ramps read from
/// there made a path of 25–36 px of a still LED.
fn spans_its_middle(ends: [(f32, f32); 2], mid: (f32, f32)) -> bool {
    let chord_px = dist(ends[0], ends[1]);
    let centre = (0.5 * (ends[0].0 + ends[1].0), 0.5 * (ends[0].1 + ends[1].1));
    chord_px >= MIN_CHORD_PX && dist(centre, mid) <= 0.5 * chord_px
}

fn sub(a: (f32, f32), b: (f32, f32)) -> (f32, f32) {
    (a.0 - b.0, a.1 - b.1)
}

fn dist(a: (f32, f32), b: (f32, f32)) -> f32 {
    (a.0 - b.0).hypot(a.1 - b.1)
}

fn clear(scratch: &mut StreakScratch, window: Window) {
    scratch.blob.clear_window(window);
    scratch.halo.clear_window(window);
    scratch.skeleton.clear_window(window);
    scratch.visited.clear_window(window);
}

fn to_f32(p: (u16, u16)) -> (f32, f32) {
    (f32::from(p.0), f32::from(p.1))
}

/// The floor around a blob: the mean and deviation of the luma on the rectangle `margin_px`
/// outside its box (what of it lies in the frame); `None` when none of it does.
fn floor_around(frame: &Frame<'_>, b: BoundingBox, margin_px: usize) -> Option<(f32, f32)> {
    let (x0, y0) = (
        b.x_min_px.checked_sub(margin_px),
        b.y_min_px.checked_sub(margin_px),
    );
    let (x1, y1) = (b.x_max_px + margin_px, b.y_max_px + margin_px);
    let (mut n, mut sum, mut sq) = (0u32, 0.0f32, 0.0f32);
    let mut add = |x: usize, y: usize| {
        if let Some(v) = frame.luma(x, y) {
            let v = f32::from(v);
            n += 1;
            sum += v;
            sq += v * v;
        }
    };
    let left = x0.unwrap_or(0);
    for x in left..=x1 {
        if let Some(y) = y0 {
            add(x, y);
        }
        add(x, y1);
    }
    for y in y0.map_or(0, |y| y + 1)..y1 {
        if let Some(x) = x0 {
            add(x, y);
        }
        add(x1, y);
    }
    if n == 0 {
        return None;
    }
    let mean = sum / n as f32;
    Some((mean, (sq / n as f32 - mean * mean).max(0.0).sqrt()))
}

/// Rim weighting: 1 at and above the threshold, falling linearly to 0 at the floor level (the
/// higher of a fixed fraction of the threshold and the measured floor around the blob).
struct Weights {
    floor_luma: f32,
    span_luma: f32,
}

impl Weights {
    /// Weights for a blob cut at `threshold_luma` on a floor of `floor` (mean, deviation).
    fn new(threshold_luma: u8, floor: Option<(f32, f32)>) -> Self {
        let threshold = f32::from(threshold_luma);
        // A bright floor beside the streak is no light of the LED's: the weights start above it.
        let floor_luma = floor.map_or(0.0, |(mean, deviation)| mean + FLOOR_DEVIATIONS * deviation);
        let floor_luma = (threshold * WEIGHT_FLOOR_FRACTION)
            .max(floor_luma)
            .min(threshold - 1.0);
        Weights {
            floor_luma,
            span_luma: (threshold - floor_luma).max(1.0),
        }
    }

    #[inline]
    fn of(&self, luma: u8) -> f32 {
        ((f32::from(luma) - self.floor_luma) / self.span_luma).clamp(0.0, 1.0)
    }
}

/// Calls `f(x, y, weight)` for every pixel of `region` inside `window` with a positive weight.
fn for_each_weighted(
    frame: &Frame<'_>,
    region: &BitImage,
    window: Window,
    weights: &Weights,
    mut f: impl FnMut(f32, f32, f32),
) {
    for (x, y) in region.ones_in(window) {
        let Some(luma) = frame.luma(x, y) else {
            continue;
        };
        let w = weights.of(luma);
        if w > 0.0 {
            f(x as f32, y as f32, w);
        }
    }
}

fn weighted_centroid(
    frame: &Frame<'_>,
    region: &BitImage,
    window: Window,
    weights: &Weights,
) -> Option<(f32, f32)> {
    let (mut sw, mut sx, mut sy) = (0.0f32, 0.0f32, 0.0f32);
    for_each_weighted(frame, region, window, weights, |x, y, w| {
        sw += w;
        sx += w * x;
        sy += w * y;
    });
    (sw > 0.0).then(|| (sx / sw, sy / sw))
}

/// The set pixel of `image` in `window` nearest `target`, and how many pixels are set there.
fn nearest_set_pixel(
    image: &BitImage,
    window: Window,
    target: (f32, f32),
) -> (Option<(u16, u16)>, usize) {
    let mut best = None;
    let mut best_d2 = f32::INFINITY;
    let mut count = 0;
    for (x, y) in image.ones_in(window) {
        count += 1;
        let (dx, dy) = (x as f32 - target.0, y as f32 - target.1);
        let d2 = dx * dx + dy * dy;
        if d2 < best_d2 {
            best_d2 = d2;
            best = Some((x as u16, y as u16));
        }
    }
    (best, count)
}

/// Breadth-first walk over the 8-connected skeleton from `start`: the last pixel reached is
/// the farthest, in steps. Returns it and its distance.
fn farthest_along(
    skeleton: &BitImage,
    visited: &mut BitImage,
    queue: &mut Deque<(u16, u16), MAX_SKELETON_PX>,
    window: Window,
    start: (u16, u16),
) -> ((u16, u16), u32) {
    queue.clear();
    let inside = |x: usize, y: usize| {
        y >= window.y0 && y < window.y1 && x / 64 >= window.k0 && x / 64 < window.k1
    };
    let mut farthest = (start, 0u32);
    // Distances ride along in the queue as a layer marker: process one layer at a time.
    visited.set(start.0.into(), start.1.into());
    if queue.push_back(start).is_err() {
        return farthest;
    }
    let mut depth = 0u32;
    while !queue.is_empty() {
        let layer = queue.len();
        for _ in 0..layer {
            let Some((x, y)) = queue.pop_front() else {
                break;
            };
            farthest = ((x, y), depth);
            for (dx, dy) in NEIGHBOURS_8 {
                let (Some(nx), Some(ny)) = (
                    usize::from(x).checked_add_signed(dx),
                    usize::from(y).checked_add_signed(dy),
                ) else {
                    continue;
                };
                if !inside(nx, ny) || !skeleton.get(nx, ny) || visited.get(nx, ny) {
                    continue;
                }
                visited.set(nx, ny);
                // A full queue means a skeleton no LED makes; the walk stops growing there.
                let _ = queue.push_back((nx as u16, ny as u16));
            }
        }
        depth += 1;
    }
    farthest
}

/// A streak is bent when its middle lies more than this many thicknesses from the chord
/// through its skeleton's ends. A line through the middle parallel to the chord then meets
/// each round cap more than half its radius off the cap's axis, where a crossing moves along
/// by more than 0.58 (`1/√3`) of any error across, and by more the farther out it meets it:
/// the symmetric middle's lines are then moved halfway to the chord, where they stay within
/// half the bend of the path from the middle to both caps, and `auto` fits the streak, whose
/// model is an arc. Within it the lines stay through the middle: a fat blob's skeleton ends
/// curl sideways by up to a pixel or two, and moving the lines by that on straight blooms made
/// the sweep's 60 px middles worse (p95 0.820 → 0.885 and 0.694 → 0.793 px, seeds 11 and 12,
/// for a bend over 1 px), while half the thickness left a sharp disk's 60 px arc on a 115 px
/// circle (bent 3.9 px) read through its sides.
const BENT_THICKNESSES: f32 = 0.25;

/// How far `mid` lies from the chord through `ends`, signed along the chord's left normal.
fn bend_px(ends: [(f32, f32); 2], mid: (f32, f32)) -> f32 {
    let chord = (ends[1].0 - ends[0].0, ends[1].1 - ends[0].1);
    let length = chord.0.hypot(chord.1);
    if length <= f32::EPSILON {
        return 0.0;
    }
    let n = (-chord.1 / length, chord.0 / length);
    (ends[0].0 - mid.0) * n.0 + (ends[0].1 - mid.1) * n.1
}

/// Whether a streak `thickness_px` thick whose middle lies `bend_px` from its chord is bent
/// (see [`BENT_THICKNESSES`]).
fn bent(bend_px: f32, thickness_px: f32) -> bool {
    bend_px.abs() > BENT_THICKNESSES * thickness_px
}

/// The streak's middle: the centroid moved across the streak to the centre of its
/// cross-section through the centroid, perpendicular to the chord between the ends; for a
/// streak at least [`ELONGATED_WIDTHS`] times longer than thick, that point moved to where the
/// symmetry of the light puts the middle ([`mirror_middle::centre`]).
#[allow(clippy::too_many_arguments)]
fn middle(
    frame: &Frame<'_>,
    region: &BitImage,
    window: Window,
    weights: &Weights,
    centroid: (f32, f32),
    ends: [(f32, f32); 2],
    seed_point: (u16, u16),
    thickness_px: f32,
    top_luma: u8,
) -> (f32, f32) {
    let chord = (ends[1].0 - ends[0].0, ends[1].1 - ends[0].1);
    let length = (chord.0 * chord.0 + chord.1 * chord.1).sqrt();
    if length < MIN_CHORD_PX {
        return centroid;
    }
    let d = (chord.0 / length, chord.1 / length);
    let n = (-d.1, d.0);
    let p = to_f32(seed_point);
    let reach = 0.5 * thickness_px + HALO_PX as f32 + 0.5;
    let (mut sw, mut s_off) = (0.0f32, 0.0f32);
    for_each_weighted(frame, region, window, weights, |x, y, w| {
        let along = (x - centroid.0) * d.0 + (y - centroid.1) * d.1;
        let across_seed = (x - p.0) * n.0 + (y - p.1) * n.1;
        if along.abs() <= 1.0 && across_seed.abs() <= reach {
            sw += w;
            s_off += w * ((x - centroid.0) * n.0 + (y - centroid.1) * n.1);
        }
    });
    let rough = if sw > 0.0 {
        let offset = s_off / sw;
        (centroid.0 + offset * n.0, centroid.1 + offset * n.1)
    } else {
        p
    };
    // A blob no longer than about twice its width has no axis to be symmetric along: its
    // skeleton is a spur of a round blob, and its chord points anywhere.
    if length < ELONGATED_WIDTHS * thickness_px {
        return rough;
    }
    let bend = bend_px(ends, rough);
    let lines_offset_px = if bent(bend, thickness_px) {
        0.5 * bend
    } else {
        0.0
    };
    mirror_middle::centre(frame, rough, d, n, 0.5 * length, lines_offset_px, top_luma)
        .unwrap_or(rough)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::detect::fit::SpotFit;

    /// A fitted path from `a` to `b` whose middle is `mid` (on the chord for a straight path,
    /// a sagitta off it for an arc) and whose length is `length_px`.
    fn fitted(a: (f32, f32), b: (f32, f32), mid: (f32, f32), length_px: f32) -> PathFit {
        PathFit {
            ends_px: [a, b],
            mid_px: mid,
            path_length_px: length_px,
            ideal_path_length_px: length_px,
            spot_sigma_px: 2.0,
            noise_px: 0.5,
            length_noise_px: 0.5,
            length_deviation_px: 0.5,
            uncertainty_px: 0.5,
            floor_measured: 1.0,
            spot: SpotFit::with_cost(1.0),
        }
    }

    /// Along a path the light may lie up to a quarter of it from the fitted middle (an LED
    /// speeding up or slowing down lays more light at its slow end); across a straight path
    /// it lies on the path's line, and across an arc between the arc and its chord. A
    /// straight 180 px path fitted 42 px beside its light (independent scenes seed 2, scene 26
    /// at 1920×1080) is within the quarter, and off its light across.
    #[test]
    fn a_fitted_path_beside_its_light_is_off_it_where_one_along_it_or_round_it_is_not() {
        let straight = fitted((100.0, 100.0), (280.0, 100.0), (190.0, 100.0), 180.0);
        assert!(!off_its_light(&straight, (220.0, 101.0)), "30 px along");
        assert!(off_its_light(&straight, (240.0, 100.0)), "50 px along");
        assert!(!off_its_light(&straight, (190.0, 110.0)), "10 px across");
        assert!(off_its_light(&straight, (190.0, 142.0)), "42 px across");
        // An arc bulging 60 px to +y (r 97.5 px): a uniform arc's light centres 21 px inside
        // its middle, toward the chord.
        let arc = fitted((100.0, 100.0), (280.0, 100.0), (190.0, 160.0), 229.4);
        assert!(!off_its_light(&arc, (190.0, 139.0)), "inside the arc");
        // A gentle one, 15 px: its light may lie up to the chord, not 35 px outside it.
        let gentle = fitted((100.0, 100.0), (280.0, 100.0), (190.0, 115.0), 183.3);
        assert!(!off_its_light(&gentle, (190.0, 100.0)), "on the chord");
        assert!(
            off_its_light(&gentle, (190.0, 150.0)),
            "35 px outside the arc"
        );
    }
}
