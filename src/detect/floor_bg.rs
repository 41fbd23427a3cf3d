//! The floor as it looks without the light: a per-pixel running mean of the luma, learned
//! wherever no light is, for the streak fit ([`super::fit`]).
//!
//! The fit's model of a streak is the LED's light on a floor. A flat floor is wrong on a
//! textured one: the texture under the streak reads as light and pulls the fitted ends by up
//! to a pixel. But the floor under a moving streak was in view, unlit, in earlier frames, so
//! it can be measured rather than assumed. Each frame updates the mean everywhere except
//! around the frame's blobs (the light and the pixels the fit reads), and a pixel that is
//! brighter than its mean by more than the noise is light arriving, not floor: it is not
//! learned either. A pixel that becomes darker by more than the noise had light in it when it
//! was learned (a glow's tail, the LED of the first frame): its mean starts again from the new
//! value. Pixels never seen unlit (under an LED standing still since the start) stay unknown,
//! and the fit falls back to a flat floor there.
//!
//! Unlike [`super::bgdiff`], which takes the median of a learning set once (and keeps a plane
//! per learning frame), this is updated on every frame from two planes sized at start.

use super::bitimage::BitImage;
use super::blobs::{Blob, BoundingBox};
use crate::frame::{Frame, FrameSize};

/// The mean follows the last this many observations of a pixel (then it is an exponential
/// mean with this time constant, so a floor that changes slowly is followed).
const MEAN_FRAMES: u16 = 16;
/// A pixel more than this many noise deviations off its mean is light arriving (brighter) or
/// leaving (darker).
const GATE_DEVIATIONS: f32 = 4.0;
/// The gate never closes below this, so that a noiseless camera's quantisation does not read
/// as light.
const MIN_GATE_LUMA: f32 = 3.0;
/// Mean absolute deviation of a Gaussian over its standard deviation.
const MAD_PER_SIGMA: f32 = 0.797_884_6;
/// The farthest a blob's glow is followed from its box.
const MAX_GLOW_PX: usize = 48;
/// Fixed-point scale of the stored mean.
const MEAN_SCALE: f32 = 256.0;

/// The learned floor, one mean and one count per pixel, sized once.
pub struct FloorBackground {
    size: FrameSize,
    /// Mean luma × [`MEAN_SCALE`].
    mean: Vec<u16>,
    /// Observations folded into the mean, at most [`MEAN_FRAMES`]; 0 where never seen unlit.
    count: Vec<u8>,
    /// Where the light is in the frame being learned (the blobs grown by the margin).
    lit: BitImage,
    /// The read noise's standard deviation, measured on the last update (luma).
    noise_luma: f32,
}

impl FloorBackground {
    /// An empty floor for frames of `size`: every pixel unknown.
    pub fn new(size: FrameSize) -> Self {
        FloorBackground {
            size,
            mean: vec![0; size.pixels()],
            count: vec![0; size.pixels()],
            lit: BitImage::new(size),
            noise_luma: 0.0,
        }
    }

    /// The floor's luma at `(x, y)`, `None` where it has not been seen without the light.
    #[inline]
    pub fn luma(&self, x: usize, y: usize) -> Option<f32> {
        if x >= self.size.width() {
            return None;
        }
        let i = y.checked_mul(self.size.width())?.checked_add(x)?;
        match self.count.get(i) {
            Some(&c) if c > 0 => Some(f32::from(*self.mean.get(i)?) / MEAN_SCALE),
            _ => None,
        }
    }

    /// The read noise measured on the last update (standard deviation, luma).
    pub fn noise_luma(&self) -> f32 {
        self.noise_luma
    }

    /// Forgets everything learned.
    pub fn clear(&mut self) {
        self.count.fill(0);
    }

    /// Learns `frame` everywhere except within `margin_px(shorter side)` of each of `blobs`
    /// (the light in it). A frame of another size is ignored.
    pub fn update<'b>(
        &mut self,
        frame: &Frame<'_>,
        blobs: impl Iterator<Item = &'b Blob>,
        margin_px: impl Fn(usize) -> usize,
    ) {
        if frame.size() != self.size {
            return;
        }
        let mut any_lit = false;
        let gate = (GATE_DEVIATIONS * self.noise_luma).max(MIN_GATE_LUMA);
        for b in blobs {
            let b = b.bbox;
            let margin_px = margin_px(
                (b.x_max_px.saturating_sub(b.x_min_px)).min(b.y_max_px.saturating_sub(b.y_min_px))
                    + 1,
            )
            .max(self.glow_px(frame, b, gate));
            let x0 = b.x_min_px.saturating_sub(margin_px);
            let x1 = b.x_max_px + margin_px;
            let y0 = b.y_min_px.saturating_sub(margin_px);
            let y1 = (b.y_max_px + margin_px).min(self.size.height() - 1);
            for y in y0..=y1 {
                self.lit.set_run(y, x0, x1.min(self.size.width() - 1));
            }
            any_lit = true;
        }
        let (mut deviation_sum, mut deviations) = (0.0f32, 0u32);
        let width = self.size.width();
        let step = frame.luma_step();
        for (y, row) in frame.luma_rows().enumerate() {
            let lit_row = self.lit.row(y);
            let start = y * width;
            let (Some(means), Some(counts)) = (
                self.mean.get_mut(start..start + width),
                self.count.get_mut(start..start + width),
            ) else {
                continue;
            };
            for (x, ((&luma, mean), count)) in row
                .iter()
                .step_by(step)
                .zip(means.iter_mut())
                .zip(counts.iter_mut())
                .enumerate()
            {
                let lit = lit_row
                    .get(x / 64)
                    .is_some_and(|word| word >> (x % 64) & 1 == 1);
                if lit {
                    continue;
                }
                let value = f32::from(luma);
                if *count == 0 {
                    *mean = (value * MEAN_SCALE) as u16;
                    *count = 1;
                    continue;
                }
                let deviation = value - f32::from(*mean) / MEAN_SCALE;
                if deviation > gate {
                    continue;
                }
                if deviation < -gate {
                    *mean = (value * MEAN_SCALE) as u16;
                    *count = 1;
                    continue;
                }
                deviation_sum += deviation.abs();
                deviations += 1;
                let n = (u16::from(*count) + 1).min(MEAN_FRAMES);
                let next = f32::from(*mean) + deviation * MEAN_SCALE / f32::from(n);
                *mean = next.clamp(0.0, f32::from(u16::MAX)) as u16;
                *count = n as u8;
            }
        }
        if deviations > 0 {
            self.noise_luma = deviation_sum / deviations as f32 / MAD_PER_SIGMA;
        }
        if any_lit {
            self.lit.clear_all();
        }
    }
}

impl FloorBackground {
    /// How far the light of the blob in `b` reaches beyond its box, measured on the frame:
    /// walking out from the box's middle in the four directions, the distance at which the
    /// luma is back within `gate` of the learned floor (where it is not known yet, of the luma
    /// [`MAX_GLOW_PX`] out, or at the frame's edge). A glow too faint to be clipped still lights the floor around a
    /// blob, and learning it as floor would make the fit count it twice.
    fn glow_px(&self, frame: &Frame<'_>, b: BoundingBox, gate: f32) -> usize {
        let (cx, cy) = ((b.x_min_px + b.x_max_px) / 2, (b.y_min_px + b.y_max_px) / 2);
        let (w, h) = (self.size.width(), self.size.height());
        let walks: [(usize, usize, isize, isize); 4] = [
            (b.x_min_px, cy, -1, 0),
            (b.x_max_px, cy, 1, 0),
            (cx, b.y_min_px, 0, -1),
            (cx, b.y_max_px, 0, 1),
        ];
        let mut reach = 0;
        for (x0, y0, dx, dy) in walks {
            let at = |t: usize| {
                let x = x0.checked_add_signed(dx * t as isize).filter(|&x| x < w)?;
                let y = y0.checked_add_signed(dy * t as isize).filter(|&y| y < h)?;
                Some((x, y))
            };
            // The last pixel of the walk inside the frame.
            let far = (1..=MAX_GLOW_PX)
                .rev()
                .find_map(at)
                .and_then(|(x, y)| frame.luma(x, y))
                .map_or(0.0, f32::from);
            let mut t = 1;
            while let Some((x, y)) = at(t).filter(|_| t <= MAX_GLOW_PX) {
                let Some(luma) = frame.luma(x, y).map(f32::from) else {
                    break;
                };
                if luma <= self.luma(x, y).unwrap_or(far) + gate {
                    break;
                }
                t += 1;
            }
            reach = reach.max(t);
        }
        reach
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn yuyv(width: usize, height: usize, luma: impl Fn(usize, usize) -> u8) -> Vec<u8> {
        let mut bytes = vec![128u8; 2 * width * height];
        for y in 0..height {
            for x in 0..width {
                bytes[2 * (y * width + x)] = luma(x, y);
            }
        }
        bytes
    }

    fn blob(x0: usize, y0: usize, x1: usize, y1: usize) -> Blob {
        Blob {
            area_px: 1,
            bbox: BoundingBox {
                x_min_px: x0,
                y_min_px: y0,
                x_max_px: x1,
                y_max_px: y1,
            },
            mass_centre_px: (x0 as f32, y0 as f32),
            elongation: 1.0,
        }
    }

    #[test]
    fn learns_the_floor_but_not_the_light_and_forgets_light_that_leaves() {
        let size = FrameSize::new(64, 16).unwrap();
        let floor = |x: usize, y: usize| (60 + (x * 7 + y * 13) % 40) as u8;
        let mut bg = FloorBackground::new(size);
        assert_eq!(bg.luma(3, 3), None, "nothing seen yet");
        // The light stands at x 10..=12 in the first frame, with a faint tail beyond the
        // blob's margin at x 20 that is learned as floor there.
        let first = yuyv(64, 16, |x, y| match x {
            10..=12 => 255,
            20 => floor(x, y) + 30,
            _ => floor(x, y),
        });
        let frame = Frame::new_checked(&first, size, size.row_bytes()).unwrap();
        bg.update(&frame, [blob(10, 0, 12, 15)].iter(), |_| 2);
        assert_eq!(bg.luma(11, 5), None, "under the light");
        assert_eq!(bg.luma(9, 5), None, "within the margin");
        assert_eq!(bg.luma(30, 5), Some(f32::from(floor(30, 5))));
        assert_eq!(bg.luma(20, 5), Some(f32::from(floor(20, 5) + 30)));
        // The light moves on to x 40: what it left is learned, where it arrives is not, and
        // the tail that has gone is forgotten.
        let second = yuyv(64, 16, |x, y| match x {
            40..=42 => 255,
            44 => floor(x, y) + 50,
            _ => floor(x, y),
        });
        let frame = Frame::new_checked(&second, size, size.row_bytes()).unwrap();
        bg.update(&frame, [blob(40, 0, 42, 15)].iter(), |_| 1);
        assert_eq!(bg.luma(11, 5), Some(f32::from(floor(11, 5))));
        assert_eq!(bg.luma(20, 5), Some(f32::from(floor(20, 5))));
        assert_eq!(
            bg.luma(44, 5),
            Some(f32::from(floor(44, 5))),
            "light arriving outside the margin is not learned"
        );
        bg.clear();
        assert_eq!(bg.luma(30, 5), None);
    }
}
