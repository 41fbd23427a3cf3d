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
use super::luma_histogram::LumaHistogram;
use crate::frame::{Frame, FrameSize};

/// The mean follows the last this many observations of a pixel (then it is an exponential
/// mean with this time constant, so a floor that changes slowly is followed).
const MEAN_FRAMES: u8 = 16;
// The steady mean's step is a shift (see `learn_steady_run`).
const _: () = assert!(MEAN_FRAMES.is_power_of_two());
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
    /// Frames learned since the floor was made or cleared.
    frames_learned: u32,
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
            frames_learned: 0,
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

    /// Whether the next update learns the whole frame: the first `MEAN_FRAMES` (16) since the
    /// floor was made or cleared, which give every pixel a mean of that many observations.
    pub fn learns_everywhere(&self) -> bool {
        self.frames_learned < u32::from(MEAN_FRAMES)
    }

    /// The median floor luma seen around the box `x0..=x1`, `y0..=y1`: on the nearest of
    /// square rings 4, 8, 16, 32 and 64 px beyond it (every other pixel of each) that holds
    /// at least 24 learned pixels; `None` when none does. A pixel never seen unlit (under
    /// the light of a track's first frame) has no floor of its own, but its level is most
    /// likely the level around the light.
    pub fn floor_around(&self, (x0, y0): (usize, usize), (x1, y1): (usize, usize)) -> Option<f32> {
        let (w, h) = (self.size.width(), self.size.height());
        AROUND_RINGS_PX.iter().find_map(|&d| {
            let mut histogram = LumaHistogram::new();
            let (left, top) = (x0.checked_sub(d), y0.checked_sub(d));
            let (right, bottom) = (
                Some(x1 + d).filter(|&x| x < w),
                Some(y1 + d).filter(|&y| y < h),
            );
            let (xa, xb) = (x0.saturating_sub(d), (x1 + d).min(w.saturating_sub(1)));
            let (ya, yb) = (y0.saturating_sub(d), (y1 + d).min(h.saturating_sub(1)));
            let mut take = |x: usize, y: usize| {
                if let Some(luma) = self.luma(x, y) {
                    histogram.add(luma);
                }
            };
            for y in [top, bottom].into_iter().flatten() {
                (xa..=xb).step_by(2).for_each(|x| take(x, y));
            }
            for x in [left, right].into_iter().flatten() {
                (ya..=yb).step_by(2).for_each(|y| take(x, y));
            }
            (histogram.count() >= AROUND_MIN_PX)
                .then(|| histogram.median())
                .flatten()
        })
    }

    /// Forgets everything learned.
    pub fn clear(&mut self) {
        self.count.fill(0);
        self.frames_learned = 0;
    }

    /// Learns `frame` except within `margin_px(shorter side)` of each of `blobs` (the light in
    /// it): everywhere in the first `MEAN_FRAMES` (16) frames, then around the blobs
    /// (`near_blob_px`) and one row in `ROW_PHASES` (8) elsewhere. A frame of another size is
    /// ignored.
    pub fn update<'b>(
        &mut self,
        frame: &Frame<'_>,
        blobs: impl Iterator<Item = &'b Blob>,
        margin_px: impl Fn(usize) -> usize,
    ) {
        if frame.size() != self.size {
            return;
        }
        if self.frames_learned == 1 {
            self.noise_luma = self.first_deviation_luma(frame);
        }
        let mut any_lit = false;
        let gate = (GATE_DEVIATIONS * self.noise_luma).max(MIN_GATE_LUMA);
        let (width, height) = (self.size.width(), self.size.height());
        let mut near = Near::default();
        for b in blobs {
            let b = b.bbox;
            let (w, h) = (b.x_max_px - b.x_min_px + 1, b.y_max_px - b.y_min_px + 1);
            let margin_px = margin_px(w.min(h)).max(self.glow_px(frame, b, gate));
            let x0 = b.x_min_px.saturating_sub(margin_px);
            let x1 = b.x_max_px + margin_px;
            let y0 = b.y_min_px.saturating_sub(margin_px);
            let y1 = (b.y_max_px + margin_px).min(height - 1);
            for y in y0..=y1 {
                self.lit.set_run(y, x0, x1.min(width - 1));
            }
            let reach_px = margin_px + near_blob_px(w.max(h));
            near.add(NearWindow {
                y0: b.y_min_px.saturating_sub(reach_px),
                y1: (b.y_max_px + reach_px).min(height - 1),
                k0: b.x_min_px.saturating_sub(reach_px) / RUN_PX,
                k1: (b.x_max_px + reach_px).min(width - 1) / RUN_PX,
            });
            any_lit = true;
        }
        let everywhere = self.learns_everywhere();
        let phase = (self.frames_learned % ROW_PHASES as u32) as usize;
        self.frames_learned = self.frames_learned.saturating_add(1);
        // The gate in the mean's fixed point: a deviation `d` (×256, an integer) is beyond
        // the gate exactly when it is beyond its floor.
        let gate_fixed = (gate * MEAN_SCALE).floor() as i32;
        let (mut deviation_sum, mut deviations) = (0u64, 0u64);
        let step = frame.luma_step();
        let mut luma = [0u8; RUN_PX];
        for (y, row) in frame.luma_rows().enumerate() {
            let whole_row = everywhere || y % ROW_PHASES == phase;
            if !whole_row && !near.covers_row(y) {
                continue;
            }
            let lit_row = self.lit.row(y);
            let start = y * width;
            let (Some(means), Some(counts)) = (
                self.mean.get_mut(start..start + width),
                self.count.get_mut(start..start + width),
            ) else {
                continue;
            };
            // One run of pixels per word of the light's mask: a run wholly lit is skipped.
            let runs = means.chunks_mut(RUN_PX).zip(counts.chunks_mut(RUN_PX));
            for (k, (means, counts)) in runs.enumerate() {
                let lit = lit_row.get(k).copied().unwrap_or(0);
                if lit == u64::MAX || !(whole_row || near.covers(k, y)) {
                    continue;
                }
                let got = gather_luma(row, k * RUN_PX * step, step, &mut luma).min(means.len());
                // A row shorter than the frame says (never, for a checked frame) is not learned
                // from stale bytes.
                let (means, counts) = (
                    means.get_mut(..got).unwrap_or_default(),
                    counts.get_mut(..got).unwrap_or_default(),
                );
                let (sum, n) = learn_run(&luma, means, counts, lit, gate_fixed);
                deviation_sum += sum;
                deviations += n;
            }
        }
        if deviations > 0 {
            self.noise_luma = deviation_sum as f32 / MEAN_SCALE / deviations as f32 / MAD_PER_SIGMA;
        }
        if any_lit {
            self.lit.clear_all();
        }
    }
}

/// The first deviation is measured on at most this many pixels (a histogram bin holds up to
/// `u16::MAX`), evenly spread over the frame.
const NOISE_SAMPLES: usize = 32_768;
/// The first deviations are counted in steps of an eighth of a luma (up to 32 luma, beyond
/// which they are light, not noise).
const DEVIATION_STEPS_PER_LUMA: f32 = 8.0;
/// Median absolute deviation of a Gaussian over its standard deviation.
const MEDIAN_DEVIATION_PER_SIGMA: f32 = 0.674_49;

/// Past the first [`MEAN_FRAMES`] frames, a pixel away from the blobs is learned in one frame
/// of this many (a row of this many, in turn): the floor changes slowly, and the mean of a
/// pixel seen every few frames has the same noise as one seen every frame. Learning the whole
/// frame every frame cost more than everything else on the per-frame path together.
const ROW_PHASES: usize = 8;

/// The rings [`FloorBackground::floor_around`] reads, by their distance beyond the box: out to
/// past the widest glow a blob's light is followed ([`MAX_GLOW_PX`]), beyond which the floor
/// was learned while the light was in the last frame.
const AROUND_RINGS_PX: [usize; 5] = [4, 8, 16, 32, 64];
/// Learned pixels a ring needs for its median: a textured floor's median steadies within a
/// few luma over a few tens of pixels.
const AROUND_MIN_PX: usize = 24;

/// How far beyond a blob's light the floor is still learned every frame, for a blob whose
/// longer side is `max_side_px`: about where the light is in the next frame (a streak moves
/// about its own length from one frame to the next), so that the floor under it is as fresh
/// as under a floor learned everywhere every frame, and light that has just left a pixel is
/// forgotten before the light returns.
fn near_blob_px(max_side_px: usize) -> usize {
    max_side_px + NEAR_BLOB_MIN_PX
}

/// The least reach of [`near_blob_px`]: a still spot or a short streak may start moving.
const NEAR_BLOB_MIN_PX: usize = 16;

/// Most windows around blobs kept apart; more are merged into the last one.
const MAX_NEAR: usize = 16;

/// Rows `y0..=y1` and runs `k0..=k1` learned every frame (around a blob).
#[derive(Clone, Copy, Default)]
struct NearWindow {
    y0: usize,
    y1: usize,
    k0: usize,
    k1: usize,
}

/// The windows around a frame's blobs, at most [`MAX_NEAR`] (a frame with more blobs has its
/// last window grown to cover the rest: more is learned, never less).
#[derive(Default)]
struct Near {
    windows: [NearWindow; MAX_NEAR],
    len: usize,
}

impl Near {
    fn add(&mut self, w: NearWindow) {
        if let Some(slot) = self.windows.get_mut(self.len) {
            *slot = w;
            self.len += 1;
        } else if let Some(last) = self.windows.last_mut() {
            *last = NearWindow {
                y0: last.y0.min(w.y0),
                y1: last.y1.max(w.y1),
                k0: last.k0.min(w.k0),
                k1: last.k1.max(w.k1),
            };
        }
    }

    fn covers_row(&self, y: usize) -> bool {
        self.windows[..self.len]
            .iter()
            .any(|w| (w.y0..=w.y1).contains(&y))
    }

    fn covers(&self, k: usize, y: usize) -> bool {
        self.windows[..self.len]
            .iter()
            .any(|w| (w.y0..=w.y1).contains(&y) && (w.k0..=w.k1).contains(&k))
    }
}

/// Copies the luma of the run starting at byte `start` of `row` (every `step`-th byte) into
/// `luma`; returns how many pixels it had. The packed formats' steps have loops of their own,
/// which the compiler turns into vector code.
#[inline]
fn gather_luma(row: &[u8], start: usize, step: usize, luma: &mut [u8; RUN_PX]) -> usize {
    let rest = row.get(start..).unwrap_or_default();
    match step {
        1 if rest.len() >= RUN_PX => {
            luma.copy_from_slice(&rest[..RUN_PX]);
            RUN_PX
        }
        // The luma row ends on a luma byte: a full run reads 2 × 64 − 1 bytes.
        2 if rest.len() >= 2 * RUN_PX - 1 => {
            // A fixed-size span, which the compiler reads as vectors (through a slice's
            // iterator it copied one byte at a time).
            if let Some(Ok(span)) = rest
                .get(..2 * RUN_PX - 1)
                .map(<&[u8; 2 * RUN_PX - 1]>::try_from)
            {
                for (i, dst) in luma.iter_mut().enumerate() {
                    *dst = span[2 * i];
                }
            }
            RUN_PX
        }
        _ => {
            let mut got = 0;
            for (dst, &src) in luma.iter_mut().zip(rest.iter().step_by(step.max(1))) {
                *dst = src;
                got += 1;
            }
            got
        }
    }
}

/// Pixels learned together: one word of the light's mask.
const RUN_PX: usize = 64;
// The steady run sums its deviations' bytes in 16 bits (see `learn_steady_run`).
const _: () = assert!(RUN_PX * 0xff <= u16::MAX as usize);

/// Learns one run of at most [`RUN_PX`] pixels (`luma`, the means and counts, and the `lit`
/// bits of the run's mask word) with the gate `gate_fixed` in the mean's fixed point. This is
/// every pixel of every frame: a whole run whose unlit pixels were all seen [`MEAN_FRAMES`]
/// times (nearly all of them) is learned on fixed-size arrays, without a branch per pixel and
/// with 16-bit integer lanes, which the compiler turns into vector code. Returns the sum of
/// the learned deviations (fixed point) and their count, for the noise.
fn learn_run(
    luma: &[u8; RUN_PX],
    means: &mut [u16],
    counts: &mut [u8],
    lit: u64,
    gate_fixed: i32,
) -> (u64, u64) {
    if let (Ok(means), Ok(counts)) = (
        <&mut [u16; RUN_PX]>::try_from(&mut *means),
        <&mut [u8; RUN_PX]>::try_from(&mut *counts),
    ) {
        let kept = lit_lanes(lit);
        let steady = counts.iter().zip(&kept).fold(true, |all, (&count, &kept)| {
            all & ((count == MEAN_FRAMES) | (kept != 0))
        });
        let (sum, n) = if steady {
            let gate = gate_fixed.clamp(0, i32::from(u16::MAX)) as u16;
            learn_steady_run(luma, means, counts, &kept, gate)
        } else {
            learn_young_run(luma, means, counts, &kept, gate_fixed)
        };
        return (u64::from(sum), u64::from(n));
    }
    // The frame's last run, when the width is not a multiple of the run.
    let (mut sum, mut n) = (0u32, 0u32);
    let pixels = luma.iter().zip(means.iter_mut()).zip(counts.iter_mut());
    for (i, ((&luma, mean), count)) in pixels.enumerate() {
        let lit = (lit >> i) & 1 == 1;
        let (deviation, learned) = learn_pixel(luma, mean, count, lit, gate_fixed);
        sum += deviation;
        n += u32::from(learned);
    }
    (u64::from(sum), u64::from(n))
}

/// All ones when `on`, else zero: a lane's choice as a mask.
#[inline(always)]
fn mask(on: bool) -> u16 {
    0u16.wrapping_sub(u16::from(on))
}

/// The `lit` bits of a run as lanes: all ones where lit, zero elsewhere.
#[inline]
fn lit_lanes(lit: u64) -> [u16; RUN_PX] {
    if lit == 0 {
        return [0; RUN_PX];
    }
    core::array::from_fn(|i| mask((lit >> i) & 1 == 1))
}

/// [`learn_pixel`] on a run whose pixels are lit (`kept` all ones) or seen [`MEAN_FRAMES`]
/// times: a mean moves by `deviation / MEAN_FRAMES`, rounded towards minus infinity as an
/// arithmetic shift of the deviation would, and a pixel darker than its mean by more than
/// `gate` starts again. The deviation is kept as its two saturated halves (brighter and
/// darker), so that every lane is 16 bits wide (eight pixels a vector instruction where 32-bit
/// lanes took four) and every choice is a select.
#[inline(always)]
fn learn_steady_run(
    luma: &[u8; RUN_PX],
    means: &mut [u16; RUN_PX],
    counts: &mut [u8; RUN_PX],
    kept: &[u16; RUN_PX],
    gate: u16,
) -> (u32, u32) {
    const SHIFT: u32 = MEAN_FRAMES.trailing_zeros();
    const REST: u16 = (1 << SHIFT) - 1;
    // The learned deviations' sum, as the sums of their high and low bytes: 64 of either
    // fit 16 bits, so the sums stay in the loop's 16-bit lanes.
    let (mut n, mut high, mut low) = (0u16, 0u16, 0u16);
    let mut restarted = [0u16; RUN_PX];
    for i in 0..RUN_PX {
        let value = u16::from(luma[i]) << 8;
        let old = means[i];
        let brighter = value.saturating_sub(old);
        let darker = old.saturating_sub(value);
        // Each choice as a lane mask (all ones or zero), each store unconditional: written
        // with `if`, the stores stayed conditional and the loop scalar.
        let free = !kept[i];
        let restart = free & mask(darker > gate);
        let learned = free & !restart & mask(brighter <= gate);
        let down = (darker >> SHIFT) + u16::from(darker & REST != 0);
        let stepped = old.wrapping_add(brighter >> SHIFT).wrapping_sub(down);
        means[i] = (value & restart) | (stepped & learned) | (old & !(restart | learned));
        restarted[i] = restart;
        let deviation = (brighter | darker) & learned;
        high += deviation >> 8;
        low += deviation & 0xff;
        n += learned & 1;
    }
    let sum = (u32::from(high) << 8) + u32::from(low);
    // Rare (light learned into a mean has left): the counts are not written otherwise, which
    // keeps every lane of the loop above 16 bits wide.
    if restarted.iter().fold(0, |any, &r| any | r) != 0 {
        for (count, &restart) in counts.iter_mut().zip(&restarted) {
            if restart != 0 {
                *count = 1;
            }
        }
    }
    (sum, u32::from(n))
}

/// [`learn_pixel`] on a whole run, lit where `kept` is all ones, some of whose pixels were
/// seen fewer than [`MEAN_FRAMES`] times (the first frames, and light that has just left): the
/// same means and counts, in 32-bit lanes without a branch per pixel (one at a time, with its
/// float division and conversions, it cost about 50 instructions a pixel, and these runs are
/// most of a frame's around the moving light).
///
/// `learn_pixel` truncates `old + deviation / frames`, computed in `f32`; that value lies
/// between two means, both within `0..=u16::MAX`, and is an integer or at least `1 / frames ≥
/// 1/16` from one, while the float's rounding errors stay below `1/128`. So the truncation is
/// rounding to nearest after subtracting [`BELOW_HALF`] (just under a half less than any
/// fraction it can have), and the rounding is the float's own, by adding [`ROUND_TO_INTEGER`]:
/// the same integer, without a conversion the compiler can only do one lane at a time.
#[inline(always)]
fn learn_young_run(
    luma: &[u8; RUN_PX],
    means: &mut [u16; RUN_PX],
    counts: &mut [u8; RUN_PX],
    kept: &[u16; RUN_PX],
    gate_fixed: i32,
) -> (u32, u32) {
    let mut n = 0u32;
    let mut deviations = [0u32; RUN_PX];
    for i in 0..RUN_PX {
        let value = i32::from(luma[i]) << 8;
        let old = i32::from(means[i]);
        let frames_seen = i32::from(counts[i]);
        let deviation = value - old;
        let known = frames_seen > 0;
        let keep = (kept[i] != 0) | (known & (deviation > gate_fixed));
        let restart = !known | (deviation < -gate_fixed);
        let frames = (frames_seen + 1).min(i32::from(MEAN_FRAMES));
        let exact = old as f32 + deviation as f32 / frames as f32 - BELOW_HALF;
        let stepped = ((exact + ROUND_TO_INTEGER).to_bits() as i32)
            .wrapping_sub(ROUND_TO_INTEGER.to_bits() as i32);
        let learned = lane(!keep & !restart);
        let restarted = lane(!keep & restart);
        let unchanged = !(learned | restarted);
        means[i] = ((stepped & learned) | (value & restarted) | (old & unchanged)) as u16;
        counts[i] = ((frames & learned) | (1 & restarted) | (frames_seen & unchanged)) as u8;
        deviations[i] = deviation.unsigned_abs() & learned as u32;
        n += (learned & 1) as u32;
    }
    (deviations.iter().sum(), n)
}

/// All ones when `on`, else zero, in a 32-bit lane.
#[inline(always)]
fn lane(on: bool) -> i32 {
    -i32::from(on)
}

/// What [`learn_young_run`] subtracts before rounding to nearest, so that the rounding
/// truncates: below a half by more than the float's error, above a half less the least
/// fraction, `1/16`, by as much.
const BELOW_HALF: f32 = 15.0 / 32.0;
/// `1.5 · 2²³`: a float in `±2²²` plus this lands where the float's step is 1, rounded to the
/// nearest integer, which its bits then read off.
const ROUND_TO_INTEGER: f32 = 12_582_912.0;

/// Learns one pixel, unless `lit`. Returns its absolute deviation from the mean (fixed
/// point) if it was learned into the mean (not lit, not light arriving, not restarted), else
/// zero, and whether it was.
#[inline(always)]
fn learn_pixel(
    luma: u8,
    mean: &mut u16,
    count: &mut u8,
    lit: bool,
    gate_fixed: i32,
) -> (u32, bool) {
    let value = i32::from(luma) << 8;
    let old = i32::from(*mean);
    let frames_seen = i32::from(*count);
    let deviation = value - old;
    let known = frames_seen > 0;
    // Under the light, or light arriving: left alone.
    let keep = lit | (known & (deviation > gate_fixed));
    // Never seen, or light that was there when it was learned has left: start again.
    let restart = !known | (deviation < -gate_fixed);
    let frames = (frames_seen + 1).min(i32::from(MEAN_FRAMES));
    // Between the old mean and the value, so within 0..=u16::MAX.
    let stepped = (old as f32 + deviation as f32 / frames as f32) as i32;
    let learned = !keep & !restart;
    let restarted = !keep & restart;
    let (new_mean, new_count) = if learned {
        (stepped, frames)
    } else if restarted {
        (value, 1)
    } else {
        (old, frames_seen)
    };
    *mean = new_mean as u16;
    *count = new_count as u8;
    let learned_deviation = if learned { deviation.unsigned_abs() } else { 0 };
    (learned_deviation, learned)
}

impl FloorBackground {
    /// The deviation of `frame` from a floor learned from one frame, measured before any is
    /// learned into it (standard deviation, luma): the median absolute deviation of up to
    /// [`NOISE_SAMPLES`] pixels on a grid over the frame, over that of a Gaussian.
    ///
    /// Every later frame's gate is four of the deviations the frame before measured on the
    /// pixels it learned, but the second frame has no frame before it to measure: gated at
    /// the least gate (3 luma), it learned only the deviations below 3 luma, read a camera
    /// with 3.2 luma of noise as 2.0 (deviations of 4.5), and took half the floor's pixels
    /// for light arriving or leaving, so that they kept or restarted from one frame's value.
    /// A median is not moved by the few pixels that are light.
    fn first_deviation_luma(&self, frame: &Frame<'_>) -> f32 {
        let mut histogram = LumaHistogram::new();
        let width = self.size.width();
        // The grid's step, the same across and down.
        let grid = ((self.size.pixels() as f32 / NOISE_SAMPLES as f32)
            .sqrt()
            .ceil() as usize)
            .max(1);
        let step = frame.luma_step();
        for (y, row) in frame.luma_rows().enumerate().step_by(grid) {
            let start = y * width;
            let (Some(means), Some(counts)) = (
                self.mean.get(start..start + width),
                self.count.get(start..start + width),
            ) else {
                continue;
            };
            let pixels = row.iter().step_by(step).zip(means).zip(counts);
            for ((&luma, &mean), &count) in pixels.step_by(grid) {
                if count > 0 {
                    let deviation = (f32::from(luma) - f32::from(mean) / MEAN_SCALE).abs();
                    // Light far off the floor still counts as above the median.
                    histogram.add((deviation * DEVIATION_STEPS_PER_LUMA).min(255.0));
                }
            }
        }
        let median = histogram.median().unwrap_or(0.0);
        median / DEVIATION_STEPS_PER_LUMA / MEDIAN_DEVIATION_PER_SIGMA
    }

    /// How far the light of the blob in `b` reaches beyond its box, measured on the frame:
    /// walking out from the box's middle in the four directions, the distance at which the
    /// luma is back within `gate` of the learned floor (where it is not known yet, of the luma
    /// [`MAX_GLOW_PX`] out, or at the frame's edge). A glow too faint to be clipped still
    /// lights the floor around a blob, and learning it as floor would make the fit count it
    /// twice.
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

    /// The run kernels learn exactly what [`learn_pixel`] learns one pixel at a time: random
    /// runs, most pixels near their means (as on a floor), some far above or below (light
    /// arriving or leaving), some lit, some never seen, some seen a few times, at several gates.
    #[test]
    fn the_run_kernels_learn_what_the_pixel_rule_learns() {
        let mut state = 0x9e37_79b9_7f4a_7c15u64;
        let mut next = move |bound: u32| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state % u64::from(bound)) as u32
        };
        for round in 0..4000 {
            let gate_fixed = [0, 768, 1021, 5000, 70_000][round % 5];
            let steady = round % 2 == 0;
            let mut luma = [0u8; RUN_PX];
            let mut means = [0u16; RUN_PX];
            let mut counts = [0u8; RUN_PX];
            for i in 0..RUN_PX {
                means[i] = next(65_536) as u16;
                let near = (i32::from(means[i] >> 8) + next(9) as i32 - 4).clamp(0, 255);
                luma[i] = if next(4) == 0 { next(256) } else { near as u32 } as u8;
                counts[i] = if steady { MEAN_FRAMES } else { next(17) as u8 };
            }
            let lit = match round % 3 {
                0 => 0,
                1 => u64::from(next(u32::MAX)) << 32 | u64::from(next(u32::MAX)),
                _ => (1u64 << next(64)).wrapping_sub(1),
            };
            let (mut want_means, mut want_counts) = (means, counts);
            let (mut want_sum, mut want_n) = (0u64, 0u64);
            for i in 0..RUN_PX {
                let (d, learned) = learn_pixel(
                    luma[i],
                    &mut want_means[i],
                    &mut want_counts[i],
                    (lit >> i) & 1 == 1,
                    gate_fixed,
                );
                want_sum += u64::from(d);
                want_n += u64::from(learned);
            }
            let got = learn_run(&luma, &mut means, &mut counts, lit, gate_fixed);
            assert_eq!(means, want_means, "round {round}: means");
            assert_eq!(counts, want_counts, "round {round}: counts");
            assert_eq!(got, (want_sum, want_n), "round {round}: deviations");
        }
    }

    /// Around a light that has stood in the only frame learned, the floor under it is not
    /// known, and the floor around it is the median of the nearest ring with enough learned
    /// pixels: past the light's margin, on a floor textured 40 luma deep.
    #[test]
    fn the_floor_around_unseen_pixels_is_the_median_of_the_nearest_learned_ring() {
        let size = FrameSize::new(160, 120).unwrap();
        let floor = |x: usize, y: usize| (60 + (x * 7 + y * 13) % 41) as u8;
        let mut bg = FloorBackground::new(size);
        assert_eq!(
            bg.floor_around((70, 50), (90, 70)),
            None,
            "nothing seen yet"
        );
        let first = yuyv(160, 120, |x, y| {
            if (70..=90).contains(&x) && (50..=70).contains(&y) {
                255
            } else {
                floor(x, y)
            }
        });
        let frame = Frame::new_checked(&first, size, size.row_bytes()).unwrap();
        // A margin of 10 px: the rings 4 and 8 px beyond the box are unknown.
        bg.update(&frame, [Blob::boxed(70, 50, 90, 70)].iter(), |_| 10);
        assert_eq!(bg.luma(80, 60), None);
        let around = bg
            .floor_around((70, 50), (90, 70))
            .expect("learned 16 px out");
        // The ring 16 px beyond the box, every other pixel, as the function reads it.
        let mut ring: Vec<u8> = Vec::new();
        for x in (54..=106).step_by(2) {
            ring.extend([floor(x, 34), floor(x, 86)]);
        }
        for y in (34..=86).step_by(2) {
            ring.extend([floor(54, y), floor(106, y)]);
        }
        ring.sort_unstable();
        let median = f32::from(ring[ring.len().div_ceil(2) - 1]);
        assert_eq!(around, median);
        // At the frame's edge the rings are cut: the two sides inside still hold enough.
        bg.update(&frame, [Blob::boxed(0, 0, 20, 20)].iter(), |_| 10);
        assert!(bg.floor_around((0, 0), (20, 20)).is_some());
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
        bg.update(&frame, [Blob::boxed(10, 0, 12, 15)].iter(), |_| 2);
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
        bg.update(&frame, [Blob::boxed(40, 0, 42, 15)].iter(), |_| 1);
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

    /// The second frame is gated by its own deviation from the first, measured before any of
    /// it is learned: on a textured floor with 3 luma of noise, the floor learned from one
    /// frame deviates from the next by √2 × 3 luma, and nearly every pixel of the second frame
    /// is learned into its mean. Gated at the least gate (3 luma), about half of them were
    /// taken for light arriving or leaving, and the deviation was read as 2.0 luma.
    #[test]
    fn the_second_frame_is_gated_by_its_own_deviation() {
        let (width, height) = (256usize, 128usize);
        let size = FrameSize::new(256, 128).unwrap();
        let sigma_luma = 3.0f32;
        let mut state = 0x2545_f491_4f6c_dd1du64;
        let mut uniform = move || {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 11) as f32 / (1u64 << 53) as f32
        };
        let floor = |x: usize, y: usize| (100 + (x * 7 + y * 13) % 40) as f32;
        let mut bg = FloorBackground::new(size);
        for _ in 0..2 {
            // Irwin–Hall: twelve uniforms less six are close to a standard normal.
            let noise: Vec<f32> = (0..width * height)
                .map(|_| (0..12).map(|_| uniform()).sum::<f32>() - 6.0)
                .collect();
            let bytes = yuyv(width, height, |x, y| {
                (floor(x, y) + sigma_luma * noise[y * width + x]).round() as u8
            });
            let frame = Frame::new_checked(&bytes, size, size.row_bytes()).unwrap();
            bg.update(&frame, core::iter::empty(), |_| 0);
        }
        let want = 2f32.sqrt() * sigma_luma;
        assert!(
            (bg.noise_luma() - want).abs() < 0.1 * want,
            "deviation {} luma, want {want}",
            bg.noise_luma()
        );
        let twice = bg.count.iter().filter(|&&c| c == 2).count();
        assert!(
            twice as f32 > 0.99 * (width * height) as f32,
            "{twice} of {} pixels learned from both frames",
            width * height
        );
    }

    #[test]
    fn a_learned_floor_follows_slowly_and_restarts_where_light_left() {
        // 100 px wide: a whole run of the mask's words and a partial one.
        let size = FrameSize::new(100, 8).unwrap();
        let floor = |x: usize, y: usize| (60 + (x * 7 + y * 13) % 40) as u8;
        let mut bg = FloorBackground::new(size);
        let still = yuyv(100, 8, floor);
        let frame = Frame::new_checked(&still, size, size.row_bytes()).unwrap();
        for _ in 0..2 * MEAN_FRAMES {
            bg.update(&frame, core::iter::empty(), |_| 0);
        }
        assert_eq!(bg.noise_luma(), 0.0);
        // Everything 2 brighter (within the gate), light arriving at x 10 and 80, and light
        // that was there when learned leaving x 30 and 70.
        let next = yuyv(100, 8, |x, y| match x {
            10 | 80 => floor(x, y) + 40,
            30 | 70 => floor(x, y) - 30,
            _ => floor(x, y) + 2,
        });
        let frame = Frame::new_checked(&next, size, size.row_bytes()).unwrap();
        bg.update(&frame, core::iter::empty(), |_| 0);
        let step = 2.0 / f32::from(MEAN_FRAMES);
        // Past the first frames, a row away from the light learned in this frame.
        let y = 2 * usize::from(MEAN_FRAMES) % ROW_PHASES;
        for x in [0, 20, 63, 64, 75, 99] {
            assert_eq!(bg.luma(x, y), Some(f32::from(floor(x, y)) + step), "x {x}");
        }
        for x in [10, 80] {
            assert_eq!(
                bg.luma(x, y),
                Some(f32::from(floor(x, y))),
                "x {x}: light arriving"
            );
        }
        for x in [30, 70] {
            assert_eq!(
                bg.luma(x, y),
                Some(f32::from(floor(x, y) - 30)),
                "x {x}: restarted"
            );
        }
        assert!((bg.noise_luma() - 2.0 / MAD_PER_SIGMA).abs() < 1e-5);
    }

    #[test]
    fn past_the_first_frames_the_floor_is_learned_around_the_light_and_in_turn_elsewhere() {
        // Two runs of the mask's words a row.
        let size = FrameSize::new(128, 64).unwrap();
        let floor = |x: usize, y: usize| (60 + (x * 7 + y * 13) % 40) as u8;
        let mut bg = FloorBackground::new(size);
        let still = yuyv(128, 64, floor);
        let frame = Frame::new_checked(&still, size, size.row_bytes()).unwrap();
        for _ in 0..MEAN_FRAMES {
            bg.update(&frame, core::iter::empty(), |_| 0);
        }
        // The whole floor 2 brighter (within the gate), and a light at x 10..=12, y 20..=22:
        // learned around it (as far as `near_blob_px` beyond its margin, so rows up to 43 of
        // the first run) and elsewhere in the rows of this frame's turn only.
        let light = |x: usize, y: usize| (10..=12).contains(&x) && (20..=22).contains(&y);
        let next = yuyv(
            128,
            64,
            |x, y| if light(x, y) { 255 } else { floor(x, y) + 2 },
        );
        let frame = Frame::new_checked(&next, size, size.row_bytes()).unwrap();
        bg.update(&frame, [Blob::boxed(10, 20, 12, 22)].iter(), |_| 2);
        let phase = usize::from(MEAN_FRAMES) % ROW_PHASES;
        let step = 2.0 / f32::from(MEAN_FRAMES);
        let learned = |x: usize, y: usize| bg.luma(x, y) == Some(f32::from(floor(x, y)) + step);
        let kept = |x: usize, y: usize| bg.luma(x, y) == Some(f32::from(floor(x, y)));
        for (x, y) in [(40, 21), (63, 0), (0, 43), (30, 35)] {
            assert!(
                learned(x, y),
                "({x}, {y}) beside the light: {:?}",
                bg.luma(x, y)
            );
        }
        for y in [phase, phase + ROW_PHASES, 63 - (63 - phase) % ROW_PHASES] {
            for x in [64, 100, 127] {
                assert!(learned(x, y), "({x}, {y}) in this frame's rows");
            }
        }
        for (x, y) in [(100, 21), (64, 1), (5, 50), (127, 63)] {
            assert!(y % ROW_PHASES != phase);
            assert!(
                kept(x, y),
                "({x}, {y}) far from the light: {:?}",
                bg.luma(x, y)
            );
        }
        // The light's own pixels and its margin are never learned.
        assert!(kept(11, 21) && kept(9, 20));
    }
}
