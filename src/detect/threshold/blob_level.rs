//! The automatic level, blob by blob.
//!
//! One level for the whole frame (its top luma minus a margin) lets the brightest thing in
//! view decide what else may count as saturated: a single hot pixel at 247 hides an LED that
//! peaks at 240, a window that clips hides a dimmer LED beside it, and of three LEDs on one
//! body the dimmer ones come and go with the brightest one's level. Here every blob of the
//! first, low cut is cut again at its own top level minus [`AUTO_MARGIN_LUMA`], so each bright
//! thing is measured on itself:
//!
//! - blobs smaller than the LED's minimum area (a hot pixel, a speck of noise) are dropped
//!   and set no level;
//! - blobs whose top is too dark to be a clipped (or nearly clipped) light are dropped, as the
//!   whole frame was before;
//! - a static window or lamp keeps its own level and cannot raise anyone else's; telling it
//!   from the LED is the tracker's job (it learns what stands still).
//!
//! Only the pixels of the low cut are visited, so the cost is that of the few bright pixels in
//! view, not of the frame.

use super::{Levels, AUTO_MARGIN_LUMA, MIN_CLIP_LUMA};
use crate::detect::bitimage::BitImage;
use crate::detect::blobs::{Labeler, MAX_BLOBS};
use crate::frame::Frame;

/// What the blob-by-blob cut found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct BlobCut {
    /// Pixels left set in the mask.
    pub count: usize,
    /// The level of the brightest blob that kept any pixels (`None` when none did).
    pub brightest_level_luma: Option<u8>,
}

/// Cuts every blob that `labeler` found in `mask` (the low first cut of `frame`) at its own
/// top luma minus [`AUTO_MARGIN_LUMA`], clearing blobs of fewer than `min_area_px` pixels and
/// blobs whose top is below [`MIN_CLIP_LUMA`]. `None` when the labeller overflowed, so that the
/// caller can fall back to one level for the frame.
pub fn cut_each_blob(
    frame: &Frame<'_>,
    labeler: &Labeler,
    min_area_px: u32,
    mask: &mut BitImage,
) -> Option<BlobCut> {
    if labeler.overflow().any() {
        return None;
    }
    let blobs = labeler.blobs();
    let mut tops = [0u8; MAX_BLOBS];
    for run in labeler.runs() {
        let (Some(slot), y) = (run.blob(), usize::from(run.y)) else {
            continue;
        };
        let run_top = (usize::from(run.x0)..=usize::from(run.x1))
            .filter_map(|x| frame.luma(x, y))
            .max()
            .unwrap_or(0);
        if let Some(top) = tops.get_mut(slot) {
            *top = (*top).max(run_top);
        }
    }
    let level_of = |slot: usize| -> Option<u8> {
        let blob = blobs.get(slot)?;
        let top = *tops.get(slot)?;
        (blob.area_px >= min_area_px && top >= MIN_CLIP_LUMA)
            .then(|| top.saturating_sub(AUTO_MARGIN_LUMA))
    };
    let mut count = 0;
    let mut brightest_level_luma = None;
    for run in labeler.runs() {
        let y = usize::from(run.y);
        let level = run.blob().and_then(level_of);
        for x in usize::from(run.x0)..=usize::from(run.x1) {
            let keep = match (level, frame.luma(x, y)) {
                (Some(level), Some(luma)) => luma >= level,
                _ => false,
            };
            if keep {
                count += 1;
            } else {
                mask.clear(x, y);
            }
        }
        if level.is_some() {
            brightest_level_luma = brightest_level_luma.max(level);
        }
    }
    Some(BlobCut {
        count,
        brightest_level_luma,
    })
}

/// The levels of one blob of the final mask: its own top and the cut below it, from its runs.
pub fn levels_of_blob(frame: &Frame<'_>, labeler: &Labeler, index: usize) -> Levels {
    let top_luma = labeler
        .runs_of(index)
        .flat_map(|run| {
            let y = usize::from(run.y);
            (usize::from(run.x0)..=usize::from(run.x1)).filter_map(move |x| frame.luma(x, y))
        })
        .max()
        .unwrap_or(0);
    Levels {
        top_luma,
        threshold_luma: Some(top_luma.saturating_sub(AUTO_MARGIN_LUMA)),
    }
}
