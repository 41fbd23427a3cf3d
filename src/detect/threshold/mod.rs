//! The saturation threshold: luma bytes of a frame (YUYV, UYVY or GREY) to a bit-packed mask,
//! in place.
//!
//! A saturated LED is the brightest thing in a short-exposure frame, but "saturated" is not a
//! fixed number: full-range cameras clip at Y = 255, studio-range ones (most UVC webcams) near
//! Y = 235–243. The automatic threshold therefore follows the frame's own top luma level, and
//! refuses to call anything saturated when that top level is too dark to be a clipped LED.
//!
//! The luma bytes are read straight out of the packed frame, 64 pixels to a mask word; the
//! automatic level costs one full pass at the lowest level it can have, plus a re-cut of the
//! few bright pixels, blob by blob ([`blob_level`]): each bright thing is cut at its own top
//! level, so neither a hot pixel nor a window can lift the level above a dimmer LED.

use core::fmt;

use super::bitimage::BitImage;
use crate::frame::Frame;

pub mod blob_level;
mod kernels;
pub mod large_blob;
pub mod static_map;
pub mod steady;

/// The lowest top luma level that can be a clipped sensor. Studio range clips at 235, so
/// anything dimmer than this is a frame with nothing saturated in it (lights dimmer than this
/// are only taken blob by blob, see [`MIN_LIGHT_LUMA`]).
pub const MIN_CLIP_LUMA: u8 = 230;

/// How far below the frame's top level the automatic threshold sits, in luma levels. Pixels of
/// a clipped LED sit exactly at the top level; the margin admits its brightest rim too.
pub const AUTO_MARGIN_LUMA: u8 = 8;

/// The dimmest top a light that does not clip may have to be cut blob by blob (a dot seen on
/// real footage peaked at 216–250 beside a window that clipped at 244+). Such a blob must also
/// stand out from what surrounds it by [`blob_level::LIGHT_CONTRAST_LUMA`], so that a bright
/// floor or the rim of a window is not one. One full pass at this level is the only cost.
pub const MIN_LIGHT_LUMA: u8 = 208;

/// How the saturation level is chosen for each frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Threshold {
    /// Follow each frame's top luma level (works for full- and studio-range cameras alike).
    #[default]
    Auto,
    /// A pixel is saturated when its luma is at least this value.
    Fixed(u8),
}

impl fmt::Display for Threshold {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Threshold::Auto => write!(f, "auto"),
            Threshold::Fixed(v) => write!(f, "{v}"),
        }
    }
}

/// The level a threshold pass used, and the frame's top level that led to it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Levels {
    /// The brightest luma in the frame (only measured for [`Threshold::Auto`], else 255).
    pub top_luma: u8,
    /// Pixels at or above this luma were set in the mask; `None` when nothing can be
    /// saturated, in which case the mask is empty.
    pub threshold_luma: Option<u8>,
}

/// The level the first, fused pass cuts at: the lowest automatic threshold there can be.
pub const AUTO_FIRST_PASS_LUMA: u8 = MIN_LIGHT_LUMA - AUTO_MARGIN_LUMA;

/// Writes one bit per pixel into `mask`, set where luma ≥ `threshold_luma`, and returns how
/// many pixels were set. `mask` must have the frame's dimensions.
pub fn threshold_into(frame: &Frame<'_>, threshold_luma: u8, mask: &mut BitImage) -> usize {
    let format = frame.format();
    frame
        .rows()
        .enumerate()
        .map(|(y, row)| kernels::row_threshold(format, row, threshold_luma, mask.row_mut(y)))
        .sum()
}

/// Applies `threshold` to `frame`: fills `mask` (cleared when nothing can be saturated) and
/// returns the levels used and the count of set pixels.
///
/// The automatic threshold needs the frame's top level before it can cut, which would take
/// two full passes. Instead one pass cuts at the lowest level the threshold can have while
/// measuring the top; then only the rows that have any bit set (a few, around the LED) are cut
/// again at the real level.
pub fn apply(frame: &Frame<'_>, threshold: Threshold, mask: &mut BitImage) -> (Levels, usize) {
    if let Threshold::Fixed(level) = threshold {
        let levels = Levels {
            top_luma: u8::MAX,
            threshold_luma: Some(level),
        };
        return (levels, threshold_into(frame, level, mask));
    }
    let (top_luma, count) = first_cut(frame, mask);
    if top_luma < MIN_CLIP_LUMA {
        mask.clear_all();
        return (
            Levels {
                top_luma,
                threshold_luma: None,
            },
            0,
        );
    }
    let level = top_luma - AUTO_MARGIN_LUMA;
    let levels = Levels {
        top_luma,
        threshold_luma: Some(level),
    };
    (levels, recut_rows(frame, level, mask, count))
}

/// The first pass of the automatic threshold: cuts `frame` into `mask` at
/// [`AUTO_FIRST_PASS_LUMA`] while measuring the frame's top luma. Returns the top and the
/// count of set pixels; when the top is below [`MIN_LIGHT_LUMA`] nothing can be a light and
/// the mask is cleared (count 0).
pub fn first_cut(frame: &Frame<'_>, mask: &mut BitImage) -> (u8, usize) {
    let format = frame.format();
    let mut top_luma = 0;
    let mut count = 0;
    for (y, row) in frame.rows().enumerate() {
        let words = mask.row_mut(y);
        let (n, top) = kernels::row_threshold_max(format, row, AUTO_FIRST_PASS_LUMA, words);
        count += n;
        top_luma = top_luma.max(top);
    }
    if top_luma < MIN_LIGHT_LUMA {
        mask.clear_all();
        return (top_luma, 0);
    }
    (top_luma, count)
}

/// Cuts again, at `level`, the rows of a first cut (holding `count` pixels) that have any
/// pixel set: one level for the whole frame. Returns the new count.
pub fn recut_rows(frame: &Frame<'_>, level: u8, mask: &mut BitImage, count: usize) -> usize {
    if level <= AUTO_FIRST_PASS_LUMA {
        return count;
    }
    let format = frame.format();
    let mut count = 0;
    for (y, row) in frame.rows().enumerate() {
        let words = mask.row_mut(y);
        if words.iter().any(|&w| w != 0) {
            count += kernels::row_threshold(format, row, level, words);
        }
    }
    count
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::FrameSize;

    fn frame_from_luma(width: usize, lumas: &[u8]) -> Vec<u8> {
        assert_eq!(lumas.len() % width, 0);
        lumas.iter().flat_map(|&y| [y, 128]).collect()
    }

    #[test]
    fn auto_follows_studio_and_full_range_tops() {
        let size = FrameSize::new(4, 2).unwrap();
        let mut mask = BitImage::new(size);
        for (top, expect) in [(255u8, "..#."), (235, "..#.")] {
            let bytes = frame_from_luma(4, &[90, 200, top, 120, 100, 100, 100, 100]);
            let frame = Frame::new_checked(&bytes, size, 8).unwrap();
            let (levels, count) = apply(&frame, Threshold::Auto, &mut mask);
            assert_eq!(levels.top_luma, top);
            assert_eq!(count, 1);
            assert_eq!(mask.to_ascii()[0], expect);
        }
    }

    #[test]
    fn a_frame_with_nothing_clipped_yields_an_empty_mask() {
        let size = FrameSize::new(2, 1).unwrap();
        let bytes = frame_from_luma(2, &[180, 200]);
        let frame = Frame::new_checked(&bytes, size, 4).unwrap();
        let mut mask = BitImage::new(size);
        mask.set(0, 0);
        let (levels, count) = apply(&frame, Threshold::Auto, &mut mask);
        assert_eq!(levels.threshold_luma, None);
        assert_eq!((count, mask.count_ones()), (0, 0));
        let (_, fixed) = apply(&frame, Threshold::Fixed(190), &mut mask);
        assert_eq!(
            fixed, 1,
            "an explicit threshold overrides the automatic floor"
        );
    }
}
