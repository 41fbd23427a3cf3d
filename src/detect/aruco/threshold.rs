//! Adaptive threshold: a pixel is dark when it is darker than the mean of its square window by
//! a margin, and optionally by a ratio.
//!
//! A fixed threshold fails under shadows and studio-range cameras; comparing with the local mean
//! keeps the marker's black border dark wherever it lies. The margin alone (OpenCV's rule) also
//! marks the shadowed side of a hard shadow edge as dark, in a band that joins the marker's border
//! to the shadow's and hides the marker's square outline. A shadow scales brightness, so the ratio
//! of a pixel to its surroundings tells black ink from shadow: black ink on white paper is a few
//! times darker than its surroundings, the shadowed side of a shadow edge only about half as
//! bright. Grey ink (35–50 % of the paper) is no darker by ratio than a shadow, so the detector
//! runs passes with and without the ratio (see `DetectorConfig`).
//!
//! The window mean comes from running box sums (per column over the window's rows, then along
//! the row): a few additions per pixel whatever the window size. The buffers are sized once for
//! the whole frame; a region of interest uses their first entries.

use crate::frame::Frame;

/// A mask pixel brighter than its surroundings (or not darker by the margin).
pub const LIGHT: u8 = 0;
/// A mask pixel darker than its surroundings.
pub const DARK: u8 = 1;
/// With the ratio test, a dark pixel is below this share of its window's mean, in percent.
pub const MAX_DARK_RATIO_PCT: u32 = 50;
/// The ratio share that turns the ratio test off: below the mean, which the margin implies.
pub const NO_RATIO_PCT: u32 = 100;
/// Largest window radius: keeps the integral sums (times 100) within `u32`.
pub const MAX_RADIUS_PX: usize = 100;

/// A rectangle of the frame, in pixels.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Roi {
    pub x_px: usize,
    pub y_px: usize,
    pub width_px: usize,
    pub height_px: usize,
}

/// `DARK` if `luma` is darker than the window mean (`sum / area`) by `offset` and below
/// `ratio_pct` percent of it.
#[inline(always)]
fn classify(luma: u8, sum: u32, area: u32, offset: u32, ratio_pct: u32) -> u8 {
    let l = u32::from(luma);
    let by_margin = (l + offset) * area < sum;
    let by_ratio = l * area * 100 < sum * ratio_pct;
    u8::from(by_margin & by_ratio) * DARK
}

/// Threshold scratch, allocated once for the largest region (the whole frame).
#[derive(Debug)]
pub struct Thresholder {
    /// The region's luma, `width × height`, gathered once from the YUYV pairs for all passes.
    plane: Vec<u8>,
    /// Per column, the sum of luma over the window's rows (a running box filter: each row is
    /// added once when the window reaches it and subtracted once when it leaves).
    column_sums: Vec<u32>,
    /// Prefix sums of `column_sums` along the current row, `width + 1` entries.
    prefix: Vec<u32>,
    /// The mask of the current region, `width × height`, row-major: `LIGHT` or `DARK`.
    mask: Vec<u8>,
    width_px: usize,
    height_px: usize,
}

impl Thresholder {
    /// Scratch for regions up to `max_width_px × max_height_px`.
    pub fn new(max_width_px: usize, max_height_px: usize) -> Self {
        Thresholder {
            plane: vec![0; max_width_px * max_height_px],
            column_sums: vec![0; max_width_px],
            prefix: vec![0; max_width_px + 1],
            mask: vec![LIGHT; max_width_px * max_height_px],
            width_px: 0,
            height_px: 0,
        }
    }

    /// Takes the luma of `roi` of `frame` (already clipped to it and no larger than the scratch)
    /// for the passes that follow.
    pub fn load(&mut self, frame: &Frame<'_>, roi: Roi) {
        let (w, h) = (roi.width_px, roi.height_px);
        let Some(plane) = self.plane.get_mut(..w * h) else {
            // The caller sizes regions within the scratch; an oversize one yields an empty mask.
            self.width_px = 0;
            self.height_px = 0;
            return;
        };
        self.width_px = w;
        self.height_px = h;
        // One luma byte every `step` bytes of a row, whatever the pixel format.
        let step = frame.luma_step();
        for (y, out) in plane.chunks_exact_mut(w.max(1)).enumerate() {
            let row = frame
                .luma_row(roi.y_px + y)
                .and_then(|row| {
                    row.get(step * roi.x_px..(step * (roi.x_px + w) + 1).saturating_sub(step))
                })
                .unwrap_or(&[]);
            for (d, l) in out.iter_mut().zip(row.iter().step_by(step)) {
                *d = *l;
            }
        }
    }

    /// Thresholds the loaded region: dark where `luma + offset < window mean` and
    /// `luma < ratio_pct % × window mean` (`ratio_pct` at most [`NO_RATIO_PCT`]), the window
    /// being `2 × radius + 1` pixels square (radius at most [`MAX_RADIUS_PX`]), cut at the
    /// region's edges.
    pub fn run(&mut self, radius_px: usize, offset: u8, ratio_pct: u32) {
        let (w, h) = (self.width_px, self.height_px);
        let (Some(plane), Some(columns), Some(prefix), Some(mask)) = (
            self.plane.get(..w * h),
            self.column_sums.get_mut(..w),
            self.prefix.get_mut(..w + 1),
            self.mask.get_mut(..w * h),
        ) else {
            return;
        };
        let r = radius_px.min(MAX_RADIUS_PX);
        let offset = u32::from(offset);
        let ratio_pct = ratio_pct.min(NO_RATIO_PCT);
        let luma_row = |y: usize| plane.get(y * w..(y + 1) * w).unwrap_or(&[]);
        columns.fill(0);
        for y in 0..r.min(h) {
            for (c, l) in columns.iter_mut().zip(luma_row(y)) {
                *c += u32::from(*l);
            }
        }
        for y in 0..h {
            // Window rows are [y − r, y + r], cut at the region: add the row entering it and
            // drop the one that left.
            if y + r < h {
                for (c, l) in columns.iter_mut().zip(luma_row(y + r)) {
                    *c += u32::from(*l);
                }
            }
            if y > r {
                for (c, l) in columns.iter_mut().zip(luma_row(y - r - 1)) {
                    *c -= u32::from(*l);
                }
            }
            let rows = ((y + r + 1).min(h) - y.saturating_sub(r)) as u32;
            // Prefix sums along the row turn every window sum into one subtraction.
            prefix[0] = 0;
            for x in 0..w {
                prefix[x + 1] = prefix[x] + columns[x];
            }
            let luma = luma_row(y);
            let Some(out) = mask.get_mut(y * w..(y + 1) * w) else {
                return;
            };
            if luma.len() != w {
                return;
            }
            // Columns whose window is cut by the region's sides, one by one...
            for x in (0..r.min(w)).chain(w.saturating_sub(r).max(r.min(w))..w) {
                let (x0, x1) = (x.saturating_sub(r), (x + r + 1).min(w));
                let area = rows * (x1 - x0) as u32;
                out[x] = classify(luma[x], prefix[x1] - prefix[x0], area, offset, ratio_pct);
            }
            // ...and the rest with a full window, in a loop the compiler can vectorise.
            if w > 2 * r {
                let area = rows * (2 * r + 1) as u32;
                let ends = prefix[2 * r + 1..=w].iter().zip(&prefix[..w - 2 * r]);
                for ((m, &l), (hi, lo)) in out[r..w - r].iter_mut().zip(&luma[r..w - r]).zip(ends) {
                    *m = classify(l, hi - lo, area, offset, ratio_pct);
                }
            }
        }
    }

    /// The mask of the last region, and its width and height.
    pub fn mask_mut(&mut self) -> (&mut [u8], usize, usize) {
        let len = self.width_px * self.height_px;
        let (w, h) = (self.width_px, self.height_px);
        (self.mask.get_mut(..len).unwrap_or(&mut []), w, h)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::FrameSize;

    fn yuyv(luma: &[u8]) -> Vec<u8> {
        luma.iter().flat_map(|&l| [l, 128]).collect()
    }

    #[test]
    fn dark_square_on_light_keeps_a_dark_rim_even_under_a_gradient() {
        // 16x12 frame: brightness ramps left to right (a soft shadow), a dark 6x6 square inside.
        let (w, h) = (16, 12);
        let luma: Vec<u8> = (0..w * h)
            .map(|i| {
                let (x, y) = (i % w, i / w);
                let light = 120 + 2 * x as u8;
                if (5..11).contains(&x) && (3..9).contains(&y) {
                    light / 5
                } else {
                    light
                }
            })
            .collect();
        let bytes = yuyv(&luma);
        let frame = Frame::new_checked(&bytes, FrameSize::new(16, 12).unwrap(), 32).unwrap();
        let mut t = Thresholder::new(w, h);
        let roi = Roi {
            x_px: 0,
            y_px: 0,
            width_px: w,
            height_px: h,
        };
        t.load(&frame, roi);
        t.run(2, 5, MAX_DARK_RATIO_PCT);
        let (mask, mw, _) = t.mask_mut();
        let picture: Vec<String> = mask
            .chunks(mw)
            .map(|r| {
                r.iter()
                    .map(|&m| if m == DARK { '#' } else { '.' })
                    .collect()
            })
            .collect();
        // The ring inside the square's outline is as wide as the window lets light in; deeper
        // in, the window sees only ink, which is not darker than itself.
        let want = [
            "................",
            "................",
            "................",
            ".....######.....",
            ".....##..##.....",
            ".....#....#.....",
            ".....#....#.....",
            ".....##..##.....",
            ".....######.....",
            "................",
            "................",
            "................",
        ];
        assert_eq!(picture, want);
    }

    #[test]
    fn a_hard_shadow_edge_is_not_dark() {
        // White paper, the right half in a shadow that takes 60 % of the light.
        let (w, h) = (16, 6);
        let luma: Vec<u8> = (0..w * h)
            .map(|i| if i % w < 8 { 215 } else { 86 })
            .collect();
        let bytes = yuyv(&luma);
        let frame = Frame::new_checked(&bytes, FrameSize::new(16, 6).unwrap(), 32).unwrap();
        let mut t = Thresholder::new(w, h);
        let roi = Roi {
            x_px: 0,
            y_px: 0,
            width_px: w,
            height_px: h,
        };
        t.load(&frame, roi);
        t.run(3, 7, MAX_DARK_RATIO_PCT);
        assert!(t.mask_mut().0.iter().all(|&m| m == LIGHT));
        // Without the ratio test, the margin alone marks the shadowed side of the edge.
        t.run(3, 7, NO_RATIO_PCT);
        assert!(t.mask_mut().0.contains(&DARK));
    }
}
