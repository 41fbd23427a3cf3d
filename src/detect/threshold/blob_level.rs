//! The automatic level, blob by blob.
//!
//! One level for the whole frame (its top luma minus a margin) lets the brightest thing in
//! view decide what else may count as saturated: a single hot pixel at 247 hides an LED that
//! peaks at 240, a window that clips hides a dimmer LED beside it, and of three LEDs on one
//! body the dimmer ones come and go with the brightest one's level. Here every blob of the
//! first, low cut is cut again at its own plateau's level (its top for a sensor's hard clip,
//! the most common level near the top of a spread one) minus [`AUTO_MARGIN_LUMA`], so each
//! bright thing is measured on itself:
//!
//! - blobs smaller than the LED's minimum area (a hot pixel, a speck of noise) are dropped
//!   and set no level, and so are clipped blobs larger than an LED's usual size (a window:
//!   cut again, a window whose noise straddles its own level would break into thousands of
//!   specks) unless they moved since the last frame (an LED in a wide glow, see
//!   [`large_blob`](super::large_blob)), all but what has just come into them (an LED touching
//!   a window the static map has not learned yet, see [`steady`](super::steady));
//! - blobs whose top is too dark to be a clipped light ([`MIN_CLIP_LUMA`]) are dropped, unless
//!   they are a light that does not clip: a top of at least [`MIN_LIGHT_LUMA`] and at least
//!   [`LIGHT_CONTRAST_LUMA`] above the mean luma of a ring around the blob (a dot on the floor,
//!   not a bright floor, nor the rim of a window);
//! - a static window or lamp keeps its own level and cannot raise anyone else's; telling it
//!   from the LED is the tracker's job (it learns what stands still).
//!
//! Only the pixels of the low cut are visited, so the cost is that of the few bright pixels in
//! view, not of the frame.

use super::{Levels, AUTO_MARGIN_LUMA, MIN_CLIP_LUMA, MIN_LIGHT_LUMA};
use crate::detect::bitimage::BitImage;
use crate::detect::blobs::{Blob, BoundingBox, Labeler, MAX_BLOBS};
use crate::frame::Frame;

/// How far above its surroundings a light that does not clip must peak: a quarter of the luma
/// range. A dot on a floor stands out by far more; a speck of bright floor or the unlearned
/// rim of a window, by far less.
pub const LIGHT_CONTRAST_LUMA: u8 = 64;

/// Pixels between a blob's bounding box and the ring its surroundings are measured on: clear
/// of its own blur.
pub const RING_GAP_PX: usize = 3;

/// What the blob-by-blob cut found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BlobCut {
    /// Pixels left set in the mask.
    pub count: usize,
    /// The level of the brightest blob that kept any pixels (`None` when none did).
    pub brightest_level_luma: Option<u8>,
    /// Pixels of the clipped blobs dropped as larger than an LED's usual size and not moving
    /// (a window, a lamp in the lens, a white frame): glare, for the "blinded" test.
    pub glare_px: usize,
    /// The sensor's clip level as this frame's blobs show it (see `sensor_clip_luma`):
    /// `None` when no blob showed a plateau.
    pub sensor_clip_luma: Option<u8>,
}

/// Which of a blob's pixels at its level are kept.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kept {
    /// All of them.
    Whole,
    /// Only those that have just come into it (a large blob that stood still).
    Fresh,
}

/// Cuts every blob that `labeler` found in `mask` (the low first cut of `frame`) at its own
/// plateau's level minus [`AUTO_MARGIN_LUMA`], clearing blobs of fewer than `min_area_px` pixels,
/// and blobs that are not lights (see the module's rules). Of a clipped blob of more than
/// `max_area_px` for which `large_moved` is false (it stood still) only the pixels for which
/// `is_fresh` is true are kept, cut at its level or, when they are dimmer, at their own top's
/// (by the margin): what has just come into it (an LED touching a window, see
/// [`steady`](super::steady)). A blob whose pixels show no plateau of their own is cut below
/// the sensor's clip when its top lies above it: this frame's clip, or else `known_clip_luma`,
/// the one an earlier frame showed (see `plateau_luma`). `None` when the labeller
/// overflowed, so that the caller can fall back to one level for the frame.
#[allow(clippy::too_many_arguments)]
pub fn cut_each_blob(
    frame: &Frame<'_>,
    labeler: &Labeler,
    min_area_px: u32,
    max_area_px: u32,
    known_clip_luma: Option<u8>,
    mut large_moved: impl FnMut(&Blob) -> bool,
    is_fresh: impl Fn(usize, usize) -> bool,
    mask: &mut BitImage,
) -> Option<BlobCut> {
    if labeler.overflow().any() {
        return None;
    }
    let blobs = labeler.blobs();
    let mut tops = [0u8; MAX_BLOBS];
    // The top of what is fresh in each large blob: a light dimmer than the window it touches
    // is cut at its own level.
    let mut fresh_tops = [0u8; MAX_BLOBS];
    for run in labeler.runs() {
        let (Some(slot), y) = (run.blob(), usize::from(run.y)) else {
            continue;
        };
        // One pass over the run for both tops; the fresh pixels are asked of large blobs only.
        let large = blobs.get(slot).is_some_and(|b| b.area_px > max_area_px);
        let (mut run_top, mut fresh_top) = (0u8, 0u8);
        for x in usize::from(run.x0)..=usize::from(run.x1) {
            let Some(luma) = frame.luma(x, y) else {
                continue;
            };
            run_top = run_top.max(luma);
            if large && is_fresh(x, y) {
                fresh_top = fresh_top.max(luma);
            }
        }
        if let Some(top) = tops.get_mut(slot) {
            *top = (*top).max(run_top);
        }
        if let Some(top) = fresh_tops.get_mut(slot) {
            *top = (*top).max(fresh_top);
        }
    }
    let mut near_top = [[0u32; PLATEAU_WINDOW_LUMA + 1]; MAX_BLOBS];
    for run in labeler.runs() {
        let (Some(slot), y) = (run.blob(), usize::from(run.y)) else {
            continue;
        };
        let (Some(&top), Some(counts)) = (tops.get(slot), near_top.get_mut(slot)) else {
            continue;
        };
        // Only a clipped blob has a plateau (see [`plateau_luma`]).
        if top < MIN_CLIP_LUMA {
            continue;
        }
        for x in usize::from(run.x0)..=usize::from(run.x1) {
            count_near_top(counts, top, frame.luma(x, y));
        }
    }
    let clip_luma = sensor_clip_luma(blobs, &tops, &near_top, min_area_px);
    let mut levels = [None; MAX_BLOBS];
    let mut glare_px = 0;
    let rows = levels
        .iter_mut()
        .zip(blobs)
        .zip(&tops)
        .zip(&near_top)
        .zip(&fresh_tops);
    for ((((level, blob), &top), counts), &fresh_top) in rows {
        // Below the frame's own clip by more than the rim's margin, a blob did not clip,
        // however bright: a speck of floor lit by a clipped glow beside it is not a light
        // unless it stands out as one.
        let clipped = top >= MIN_CLIP_LUMA
            && clip_luma.is_none_or(|clip| top.saturating_add(AUTO_MARGIN_LUMA) >= clip);
        let kept = if blob.area_px < min_area_px {
            None
        } else if blob.area_px <= max_area_px {
            Some(Kept::Whole)
        } else if !clipped {
            // Only a clipped light can be an LED's glow.
            None
        } else if large_moved(blob) {
            Some(Kept::Whole)
        } else {
            glare_px += blob.area_px as usize;
            Some(Kept::Fresh)
        };
        let light = clipped
            || (top >= MIN_LIGHT_LUMA
                && ring_mean_luma(frame, &blob.bbox)
                    .is_some_and(|ring| f32::from(top) >= ring + f32::from(LIGHT_CONTRAST_LUMA)));
        let level_luma = plateau_luma(top, counts, clip_luma.or(known_clip_luma))
            .saturating_sub(AUTO_MARGIN_LUMA);
        *level = match kept.filter(|_| light) {
            Some(Kept::Fresh) if fresh_top < MIN_LIGHT_LUMA => None,
            Some(Kept::Fresh) => Some((
                level_luma.min(fresh_top.saturating_sub(AUTO_MARGIN_LUMA)),
                Kept::Fresh,
            )),
            kept => kept.map(|kept| (level_luma, kept)),
        };
    }
    let level_of = |slot: usize| -> Option<(u8, Kept)> { *levels.get(slot)? };
    let mut count = 0;
    let mut brightest_level_luma = None;
    for run in labeler.runs() {
        let y = usize::from(run.y);
        let level = run.blob().and_then(level_of);
        let mut kept_any = false;
        for x in usize::from(run.x0)..=usize::from(run.x1) {
            let keep = match (level, frame.luma(x, y)) {
                (Some((level, Kept::Whole)), Some(luma)) => luma >= level,
                (Some((level, Kept::Fresh)), Some(luma)) => luma >= level && is_fresh(x, y),
                _ => false,
            };
            if keep {
                count += 1;
                kept_any = true;
            } else {
                mask.clear(x, y);
            }
        }
        // A large blob that stood still has a level only where something fresh is kept.
        if kept_any || matches!(level, Some((_, Kept::Whole))) {
            brightest_level_luma = brightest_level_luma.max(level.map(|(level, _)| level));
        }
    }
    Some(BlobCut {
        count,
        brightest_level_luma,
        glare_px,
        sensor_clip_luma: clip_luma,
    })
}

/// The sensor's clip level as this frame shows it: the highest plateau of a blob at least
/// `min_area_px` (an LED's least size, so not a hot pixel) whose pixels pile up at one level
/// near its top ([`PLATEAU_MIN_PX`] of them at least). A camera clips every saturated pixel at
/// that level, whatever the light, so a blob that tops out well below it did not clip. `None`
/// when no blob shows a plateau: then every top from [`MIN_CLIP_LUMA`] up may be a clip.
fn sensor_clip_luma(
    blobs: &[Blob],
    tops: &[u8; MAX_BLOBS],
    near_top: &[[u32; PLATEAU_WINDOW_LUMA + 1]; MAX_BLOBS],
    min_area_px: u32,
) -> Option<u8> {
    blobs
        .iter()
        .zip(tops)
        .zip(near_top)
        .filter(|((blob, &top), _)| blob.area_px >= min_area_px && top >= MIN_CLIP_LUMA)
        .filter_map(|((_, &top), counts)| {
            let plateau = plateau_luma(top, counts, None);
            let at_plateau = counts.get(usize::from(top - plateau)).copied().unwrap_or(0);
            (at_plateau >= PLATEAU_MIN_PX).then_some(plateau)
        })
        .max()
}

/// Pixels at one level that make a clipped blob's plateau evidence of the sensor's clip
/// (see [`sensor_clip_luma`]): a few pixels of a speck may share a level by chance, a clipped
/// LED's core holds dozens.
const PLATEAU_MIN_PX: u32 = 8;

/// The mean luma on the rectangle [`RING_GAP_PX`] outside `bbox` (its sides clipped to the
/// frame); `None` when no side of it lies in the frame.
fn ring_mean_luma(frame: &Frame<'_>, bbox: &BoundingBox) -> Option<f32> {
    let x0 = bbox.x_min_px.checked_sub(RING_GAP_PX);
    let y0 = bbox.y_min_px.checked_sub(RING_GAP_PX);
    let (x1, y1) = (bbox.x_max_px + RING_GAP_PX, bbox.y_max_px + RING_GAP_PX);
    let (xa, xb) = (x0.unwrap_or(0), x1);
    let (ya, yb) = (y0.unwrap_or(0), y1);
    let rows = [y0, Some(y1)]
        .into_iter()
        .flatten()
        .flat_map(|y| (xa..=xb).map(move |x| (x, y)));
    let cols = [x0, Some(x1)]
        .into_iter()
        .flatten()
        .flat_map(|x| (ya..=yb).map(move |y| (x, y)));
    let (sum, n) = rows
        .chain(cols)
        .filter_map(|(x, y)| frame.luma(x, y))
        .fold((0u64, 0u32), |(s, n), l| (s + u64::from(l), n + 1));
    (n > 0).then(|| sum as f32 / n as f32)
}

/// The levels of one blob of the final mask: its plateau's level (a clipped blob's most common
/// level near its top, which a hard clip's top is, or the sensor's clip `clip_luma` where
/// its own pixels show no plateau, see `plateau_luma`) and the cut below it, from its runs.
pub fn levels_of_blob(
    frame: &Frame<'_>,
    labeler: &Labeler,
    index: usize,
    clip_luma: Option<u8>,
) -> Levels {
    // One pass: every level's count, the top and the counts below it read off after.
    let mut by_luma = [0u32; 256];
    for run in labeler.runs_of(index) {
        let y = usize::from(run.y);
        for x in usize::from(run.x0)..=usize::from(run.x1) {
            if let Some(count) = frame
                .luma(x, y)
                .and_then(|l| by_luma.get_mut(usize::from(l)))
            {
                *count += 1;
            }
        }
    }
    let top = by_luma.iter().rposition(|&n| n > 0).unwrap_or(0) as u8;
    let mut counts = [0u32; PLATEAU_WINDOW_LUMA + 1];
    for (depth, count) in counts.iter_mut().enumerate() {
        *count = usize::from(top)
            .checked_sub(depth)
            .and_then(|luma| by_luma.get(luma))
            .copied()
            .unwrap_or(0);
    }
    let top_luma = plateau_luma(top, &counts, clip_luma);
    Levels {
        top_luma,
        threshold_luma: Some(top_luma.saturating_sub(AUTO_MARGIN_LUMA)),
    }
}

/// Levels below a clipped blob's top where its plateau may lie.
pub const PLATEAU_WINDOW_LUMA: usize = 16;

/// Counts `luma` at its depth below `top` in `counts`, when within the window.
pub fn count_near_top(counts: &mut [u32; PLATEAU_WINDOW_LUMA + 1], top: u8, luma: Option<u8>) {
    let Some(luma) = luma else { return };
    if let Some(count) = counts.get_mut(usize::from(top.saturating_sub(luma))) {
        *count += 1;
    }
}

/// The level of a blob's saturated plateau, from the `counts` of its pixels by depth below
/// its `top`: the most common level near the top of a clipped blob, its top otherwise.
///
/// A sensor that clips writes its saturated pixels at one level, the top, and a blob's
/// pixels below it are its rim, a few at each level. Processing after the clip (compression,
/// sharpening, denoising) spreads the plateau by a few luma around that level instead, and
/// its top is then the plateau's highest noise: cut a margin below that, a third to a half
/// of a plateau spread by 2–3 luma fell out of the mask, and the streak's skeleton broke up
/// around the holes. The plateau's most common level is its level either way.
///
/// A light that does not clip has no plateau: its pixels spread over the levels below its
/// peak, a few at each, and its most common level is anywhere among them. A plateau is a peak
/// of the counts, [`PLATEAU_PEAK`] times their mean at least (a plateau spread by noise of
/// 3 luma holds 0.13 of its pixels at its level, 2.3 times the mean over the window).
///
/// Without a peak of its own, a blob whose top lies above `clip_luma`, the sensor's clip as
/// other blobs or earlier frames showed it, and within the window of it, clipped there: no
/// light reads above the clip but for the noise after it. A thin streak's hundred pixels are
/// too few for the peak to show reliably: on sweep seed 12's point 86 (a 0.89 px disk clipped
/// 1.7×, noise of 2.8 luma after a studio-range clip at 235) the peak stood 2.5–3.7 times the
/// mean in five frames and 1.96 in the sixth, whose top, 242, then cut the streak at 234
/// into pieces, one 17.6 px piece of its 60 px reported. Without a peak or a clip below the
/// top, the top stands.
fn plateau_luma(top: u8, counts: &[u32; PLATEAU_WINDOW_LUMA + 1], clip_luma: Option<u8>) -> u8 {
    if top < MIN_CLIP_LUMA {
        return top;
    }
    let mut mode = 0;
    for (depth, &count) in counts.iter().enumerate() {
        if count > counts[mode] {
            mode = depth;
        }
    }
    let total: u32 = counts.iter().sum();
    let peaked = counts[mode] as f32 * counts.len() as f32 >= PLATEAU_PEAK * total as f32;
    let below_clip =
        clip_luma.filter(|&clip| clip < top && usize::from(top - clip) <= PLATEAU_WINDOW_LUMA);
    match (peaked, below_clip) {
        (true, _) => top - mode as u8,
        (false, Some(clip)) => clip,
        (false, None) => top,
    }
}

/// How far above the mean count a plateau's level stands (see [`plateau_luma`]).
const PLATEAU_PEAK: f32 = 2.0;

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::FrameSize;

    /// A 64×32 YUYV frame of a floor at `floor` luma with `spots` painted on it.
    fn frame_bytes(floor: u8, spots: &[(usize, usize, usize, usize, u8)]) -> Vec<u8> {
        let mut luma = vec![floor; 64 * 32];
        for &(x0, y0, w, h, level) in spots {
            for y in y0..y0 + h {
                luma[y * 64 + x0..y * 64 + x0 + w].fill(level);
            }
        }
        luma.iter().flat_map(|&y| [y, 128]).collect()
    }

    /// Cuts every blob of the frame's first cut at [`MIN_LIGHT_LUMA`]; returns the mask.
    fn cut(bytes: &[u8]) -> BitImage {
        cut_knowing(bytes, None)
    }

    /// [`cut`], with the sensor's clip `known_clip_luma` shown by an earlier frame.
    fn cut_knowing(bytes: &[u8], known_clip_luma: Option<u8>) -> BitImage {
        let size = FrameSize::new(64, 32).unwrap();
        let frame = Frame::new_checked(bytes, size, size.row_bytes()).unwrap();
        let mut mask = BitImage::new(size);
        for y in 0..32 {
            for x in 0..64 {
                if frame.luma(x, y).is_some_and(|l| l >= MIN_LIGHT_LUMA) {
                    mask.set(x, y);
                }
            }
        }
        let mut labeler = Labeler::new();
        labeler.label(&mask);
        cut_each_blob(
            &frame,
            &labeler,
            4,
            10_000,
            known_clip_luma,
            |_| false,
            |_, _| false,
            &mut mask,
        )
        .unwrap();
        mask
    }

    /// A speck of floor at 238 beside an LED clipped at 255 did not clip: it is no light,
    /// standing out from the floor by less than a light must. Alone, 238 may be a
    /// studio-range camera's clip, and the speck stays.
    #[test]
    fn a_speck_well_below_the_clip_the_frame_shows_is_no_clipped_light() {
        let speck = (40, 14, 3, 2, 238);
        let led = (10, 10, 8, 8, 255);
        let beside = cut(&frame_bytes(200, &[led, speck]));
        assert_eq!(beside.count_ones(), 64, "the LED kept, the speck dropped");
        assert!(!beside.get(41, 14));
        let alone = cut(&frame_bytes(200, &[speck]));
        assert_eq!(alone.count_ones(), 6, "the speck alone may be a clip");
        // A light that does not clip but stands out from a dark floor stays beside the LED.
        let dot = (40, 14, 3, 2, 238);
        let on_dark = cut(&frame_bytes(120, &[led, dot]));
        assert_eq!(on_dark.count_ones(), 70);
    }

    /// A 2 px line on the floor, 40 px long, whose noise after a clip at 235 spreads its
    /// pixels evenly over 229–241 (each column one level): too few and too spread for a
    /// plateau of its own. Cut below its top it breaks into pieces where its columns read
    /// 229–232; cut below the clip an earlier frame showed, it is one blob.
    #[test]
    fn a_line_too_thin_to_show_its_plateau_is_cut_below_the_known_clip() {
        let columns: Vec<_> = (0..40)
            .map(|i| (12 + i, 15, 1, 2, 229 + (i % 13) as u8))
            .collect();
        let bytes = frame_bytes(120, &columns);
        let blobs = |mask: &BitImage| {
            let mut labeler = Labeler::new();
            labeler.label(mask);
            labeler.blobs().len()
        };
        let alone = cut(&bytes);
        assert!(blobs(&alone) > 1, "cut below its top, in pieces");
        let knowing = cut_knowing(&bytes, Some(235));
        assert_eq!(blobs(&knowing), 1);
        assert_eq!(knowing.count_ones(), 80);
    }

    /// The counts near the top of sweep seed 12's point 86, frame 5 (a 0.89 px disk's 60 px
    /// line, clipped at 235 with noise of 2.8 luma after the clip), from its top, 242, down:
    /// no peak. The clip known from another blob or an earlier frame is its plateau when it
    /// lies below the top within the window, and only then; a blob with a peak of its own
    /// keeps it.
    #[test]
    fn a_plateau_without_a_peak_is_the_known_clip_below_its_top() {
        let counts = [1, 6, 4, 7, 9, 10, 12, 8, 12, 8, 9, 10, 0, 6, 1, 0, 1];
        assert_eq!(plateau_luma(242, &counts, None), 242);
        assert_eq!(plateau_luma(242, &counts, Some(235)), 235);
        assert_eq!(
            plateau_luma(242, &counts, Some(242)),
            242,
            "a clip at the top"
        );
        assert_eq!(
            plateau_luma(242, &counts, Some(250)),
            242,
            "a clip above the top"
        );
        assert_eq!(
            plateau_luma(242, &counts, Some(220)),
            242,
            "a clip past the window"
        );
        let mut peaked = counts;
        peaked[3] = 40;
        assert_eq!(plateau_luma(242, &peaked, Some(235)), 239);
    }

    fn counts_of(lumas: impl IntoIterator<Item = u8>) -> (u8, [u32; PLATEAU_WINDOW_LUMA + 1]) {
        let lumas: Vec<u8> = lumas.into_iter().collect();
        let top = lumas.iter().copied().max().unwrap_or(0);
        let mut counts = [0; PLATEAU_WINDOW_LUMA + 1];
        for &luma in &lumas {
            count_near_top(&mut counts, top, Some(luma));
        }
        (top, counts)
    }

    /// A hard clip's plateau is its top, however many rim pixels lie below it; a plateau
    /// spread around 246 by noise after the clip is at 246, not at its highest noise.
    #[test]
    fn the_plateau_is_the_top_of_a_hard_clip_and_the_middle_of_a_spread_one() {
        let rim = (200..250).step_by(3);
        let (top, counts) = counts_of(rim.clone().chain([250; 40]));
        assert_eq!(plateau_luma(top, &counts, None), 250);
        let spread = [
            243, 244, 245, 245, 246, 246, 246, 246, 247, 247, 248, 249, 250,
        ];
        let (top, counts) = counts_of(rim.chain(spread.iter().cycle().take(130).copied()));
        assert_eq!(top, 250);
        assert_eq!(plateau_luma(top, &counts, None), 246);
        // A light that does not clip keeps its top: below the clip's levels, or with its
        // pixels spread evenly below its peak.
        let (top, counts) = counts_of([200, 210, 210, 210, 215]);
        assert_eq!(plateau_luma(top, &counts, None), 215);
        let dome = (233..=248).flat_map(|l| [l, l]).chain([240, 249]);
        let (top, counts) = counts_of(dome);
        assert_eq!(plateau_luma(top, &counts, None), 249);
    }
}
