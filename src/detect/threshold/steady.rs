//! Which bright pixels have been bright without a break for a while: what is new in a large
//! blob that stands still.
//!
//! The static map ([`static_map`](super::static_map)) learns a window in 3.2 s, and it must be
//! that slow (a parked robot's LED must not be learned). Until then a clipped window is a
//! large blob that stands still, dropped as glare ([`large_blob`](super::large_blob)); an LED
//! that touches it joins its blob and was dropped with it, lost for as long as it touched (5
//! frames of an LED passing along a window's edge at 900 px/s). What tells the LED's pixels
//! from the window's is how long they have been bright: a window's pixels have been bright in
//! every frame since it came into view, a passing LED's only since it arrived.
//!
//! So each pixel counts the frames it has been bright in a row (a 4-bit counter, bit-sliced
//! into four planes: bit `k` of 64 pixels' counters in one `u64`), reset by a frame it is
//! dark in. A pixel is steady once it has been bright in every frame for at least
//! [`STEADY_US`], counted in frame time as the static map counts. Of a large blob that stood
//! still, the pixels that are not steady are fresh: opened by a 3×3 square (eroded, then
//! dilated back inside the fresh pixels) so that a window's rim, whose pixels straddle its
//! level and flicker, leaves no specks, only a light at least 3 px wide.
//!
//! The choice of [`STEADY_US`]: longer keeps more of a slow LED's pixels fresh, and leaves a
//! window that has just come into view fresh, a large blob too large to be a candidate, for
//! as long. An LED must cross its own width in about that time to stay fresh where it touches
//! an unlearned window: 32 px/s for an 8 px spot.
//!
//! Cost: a few word operations per 64 pixels of the rows that are lit or were lit in the last
//! frame (a test of each word of the others); the fresh pixels are worked out only inside the
//! boxes of large blobs, in frames that have one.
//!
//! Memory: the four counter planes, the fresh plane and a flag a row, allocated once.

use crate::detect::bitimage::{BitImage, Window};
use crate::detect::morph::{self, Kernel};

/// How long a pixel must have been bright in every frame to be steady: a quarter of a second.
pub const STEADY_US: u64 = 250_000;

/// Bits of each pixel's counter: it counts up to 15 frames in a row.
const COUNTER_BITS: usize = 4;

/// The most frames in a row a counter holds; at more than 60 fps [`STEADY_US`] holds more
/// frames than that, and steady means bright for the last 15 frames.
const MAX_COUNT: usize = (1 << COUNTER_BITS) - 1;

/// Each pixel's count of frames bright in a row, and the fresh pixels of the last large blobs.
pub struct SteadyPixels {
    counter: [BitImage; COUNTER_BITS],
    /// The rows whose counters are not all zero.
    counting_rows: Vec<bool>,
    fresh: BitImage,
    /// The times of the last frames, newest at `(next + MAX_COUNT - 1) % MAX_COUNT`.
    times_us: [u64; MAX_COUNT],
    /// Frames observed since the last reset (at most [`MAX_COUNT`] are remembered).
    observed: usize,
    next: usize,
    /// How many frames in a row make a pixel steady now (from the frames' times).
    steady_count: usize,
}

impl SteadyPixels {
    /// Counters for masks of `width_px × height_px`, nothing bright yet.
    pub fn new(width_px: usize, height_px: usize) -> Self {
        let plane = || BitImage::with_dimensions(width_px, height_px);
        SteadyPixels {
            counter: [plane(), plane(), plane(), plane()],
            counting_rows: vec![false; height_px],
            fresh: plane(),
            times_us: [0; MAX_COUNT],
            observed: 0,
            next: 0,
            steady_count: MAX_COUNT,
        }
    }

    /// Counts the bright pixels (`bright`, of the counters' size) of the frame at `t_us`: up
    /// where bright (saturating), back to zero where dark. A mask of another size is ignored;
    /// time going backwards starts the count afresh.
    pub fn observe(&mut self, bright: &BitImage, t_us: u64) {
        if !bright.same_shape(&self.fresh) {
            return;
        }
        if self.observed > 0 && t_us < self.newest_us() {
            for plane in &mut self.counter {
                plane.clear_all();
            }
            self.counting_rows.fill(false);
            self.observed = 0;
        }
        self.remember_time(t_us);
        let [c0, c1, c2, c3] = &mut self.counter;
        for (y, counting) in self.counting_rows.iter_mut().enumerate() {
            // A row dark now and dark before has nothing to count or reset: most of a frame.
            let lit = bright.row(y).iter().any(|&w| w != 0);
            if !lit && !*counting {
                continue;
            }
            *counting = lit;
            let rows = (c0.row_mut(y), c1.row_mut(y), c2.row_mut(y), c3.row_mut(y));
            let (r0, r1, r2, r3) = rows;
            let words = r0.iter_mut().zip(r1).zip(r2).zip(r3).zip(bright.row(y));
            for ((((b0, b1), b2), b3), &on) in words {
                let full = *b0 & *b1 & *b2 & *b3;
                // Ripple-carry increment where bright and not full; zero where dark.
                let mut carry = on & !full;
                for bit in [&mut *b0, &mut *b1, &mut *b2, &mut *b3] {
                    let old = *bit;
                    *bit = (old ^ carry) & on;
                    carry &= old;
                }
            }
        }
    }

    /// Works out the fresh pixels inside `window`: bright in the last frame observed, not
    /// steady, and opened by a 3×3 square; none when nothing inside the window is steady.
    /// `scratch` (of the counters' size) is overwritten inside the window grown by a row and
    /// a word. Read them with [`SteadyPixels::is_fresh`], inside the window.
    pub fn find_fresh(&mut self, window: Window, scratch: &mut BitImage) {
        if !scratch.same_shape(&self.fresh) || window.is_empty() {
            return;
        }
        // The erosion reads a pixel's neighbours, one row and one word past the window.
        let grown = Window {
            y0: window.y0.saturating_sub(1),
            y1: (window.y1 + 1).min(self.fresh.height()),
            k0: window.k0.saturating_sub(1),
            k1: (window.k1 + 1).min(self.fresh.words_per_row()),
        };
        self.raw_fresh(grown, false);
        if !self.holds_steady(window) {
            // Nothing in it has stood: all of it is new (a light switched on, the first
            // frames), and no part is fresher than the rest.
            self.fresh.clear_window(grown);
            return;
        }
        scratch.clear_window(grown);
        morph::erode(&self.fresh, scratch, Kernel::Square, window);
        morph::dilate(scratch, &mut self.fresh, Kernel::Square, window);
        // The dilation's growth is kept inside the fresh pixels: an opening.
        self.raw_fresh(window, true);
    }

    /// Whether any pixel inside `window` is steady.
    fn holds_steady(&self, window: Window) -> bool {
        let steady_count = self.steady_count as u64;
        (window.y0..window.y1).any(|y| {
            (window.k0..window.k1).any(|k| {
                let bits = self
                    .counter
                    .each_ref()
                    .map(|p| p.row(y).get(k).copied().unwrap_or(0));
                at_least(bits, steady_count) != 0
            })
        })
    }

    /// The pixels bright in the last frame and not steady, inside `window`: written into the
    /// fresh plane, or with `and` kept only where the plane already holds them.
    fn raw_fresh(&mut self, window: Window, and: bool) {
        let steady_count = self.steady_count as u64;
        for y in window.y0..window.y1 {
            let planes = [
                self.counter[0].row(y),
                self.counter[1].row(y),
                self.counter[2].row(y),
                self.counter[3].row(y),
            ];
            let out = self.fresh.row_mut(y);
            for k in window.k0..window.k1 {
                let bits = planes.map(|p| p.get(k).copied().unwrap_or(0));
                let bright = bits[0] | bits[1] | bits[2] | bits[3];
                let fresh = bright & !at_least(bits, steady_count);
                if let Some(o) = out.get_mut(k) {
                    *o = if and { *o & fresh } else { fresh };
                }
            }
        }
    }

    /// Whether pixel `(x, y)` is fresh, as last worked out by [`SteadyPixels::find_fresh`]
    /// for a window holding it.
    pub fn is_fresh(&self, x: usize, y: usize) -> bool {
        self.fresh.get(x, y)
    }

    fn newest_us(&self) -> u64 {
        self.times_us[(self.next + MAX_COUNT - 1) % MAX_COUNT]
    }

    /// Stores the frame's time and works out how many frames in a row make a pixel steady:
    /// those taken within the last [`STEADY_US`], and the one before them (so that the run
    /// spans the whole time), at least two and at most [`MAX_COUNT`].
    fn remember_time(&mut self, t_us: u64) {
        self.times_us[self.next] = t_us;
        self.next = (self.next + 1) % MAX_COUNT;
        self.observed = (self.observed + 1).min(MAX_COUNT);
        let within = (0..self.observed)
            .map(|back| self.times_us[(self.next + MAX_COUNT - 1 - back) % MAX_COUNT])
            .take_while(|&t| t_us - t < STEADY_US)
            .count();
        self.steady_count = if within == self.observed && self.observed < MAX_COUNT {
            // The run so far does not reach back far enough to tell: assume the frames to
            // come are as far apart as these.
            MAX_COUNT
        } else {
            (within + 1).clamp(2, MAX_COUNT)
        };
    }
}

/// The pixels whose bit-sliced counters (`bits[k]` is bit `k` of 64 pixels' counters) hold at
/// least `n`.
fn at_least(bits: [u64; COUNTER_BITS], n: u64) -> u64 {
    let (mut greater, mut equal) = (0u64, !0u64);
    for (k, &plane) in bits.iter().enumerate().rev() {
        if (n >> k) & 1 == 1 {
            equal &= plane;
        } else {
            greater |= equal & plane;
            equal &= !plane;
        }
    }
    greater | equal
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Feeds `frames` masks 33 ms apart (30 fps) from `t0_us`; returns the next frame's time.
    fn feed(steady: &mut SteadyPixels, masks: &[&BitImage], t0_us: u64) -> u64 {
        let mut t_us = t0_us;
        for mask in masks {
            steady.observe(mask, t_us);
            t_us += 33_333;
        }
        t_us
    }

    /// The pixels of a `width × height` image for which `set` holds, as `#`.
    fn ascii(width: usize, height: usize, set: impl Fn(usize, usize) -> bool) -> Vec<String> {
        (0..height)
            .map(|y| {
                (0..width)
                    .map(|x| if set(x, y) { '#' } else { '.' })
                    .collect()
            })
            .collect()
    }

    /// The fresh pixels of the whole image.
    fn fresh_ascii(steady: &mut SteadyPixels) -> Vec<String> {
        let (w, h) = (steady.fresh.width(), steady.fresh.height());
        let mut scratch = BitImage::with_dimensions(w, h);
        let window = steady.fresh.full_window();
        steady.find_fresh(window, &mut scratch);
        ascii(w, h, |x, y| steady.is_fresh(x, y))
    }

    #[test]
    fn a_light_that_arrives_beside_a_standing_one_is_fresh_and_the_standing_one_is_not() {
        let window = BitImage::from_ascii(&[
            "#####.......",
            "#####.......",
            "#####.......",
            "#####.......",
            "............",
        ]);
        let with_led = BitImage::from_ascii(&[
            "#####.......",
            "#####.......",
            "########....",
            "########....",
            ".....###....",
        ]);
        let mut steady = SteadyPixels::new(12, 5);
        // 0.3 s of the window alone: steady from 0.25 s on.
        let t_us = feed(&mut steady, &[&window; 9], 0);
        assert!(fresh_ascii(&mut steady).iter().all(|r| !r.contains('#')));
        feed(&mut steady, &[&with_led], t_us);
        assert_eq!(
            fresh_ascii(&mut steady),
            [
                "............",
                "............",
                ".....###....",
                ".....###....",
                ".....###....",
            ]
        );
    }

    /// Which pixels are steady now, read from the counters.
    fn steady_ascii(steady: &SteadyPixels) -> Vec<String> {
        let (w, h) = (steady.fresh.width(), steady.fresh.height());
        ascii(w, h, |x, y| {
            let count = (0..COUNTER_BITS)
                .filter(|&k| steady.counter[k].get(x, y))
                .fold(0, |c, k| c | 1 << k);
            count >= steady.steady_count
        })
    }

    #[test]
    fn nothing_is_steady_before_a_quarter_second_nor_after_a_break() {
        let block = BitImage::from_ascii(&["######", "######", "######", "......"]);
        let mut steady = SteadyPixels::new(6, 4);
        // 0.23 s: nothing steady yet (at 30 fps eight frames span 0.23 s), and nothing
        // fresh either: with nothing standing, no part of a blob is newer than the rest.
        let t_us = feed(&mut steady, &[&block; 8], 0);
        assert_eq!(steady_ascii(&steady)[..3], ["......"; 3]);
        assert!(fresh_ascii(&mut steady).iter().all(|r| !r.contains('#')));
        let t_us = feed(&mut steady, &[&block], t_us);
        assert_eq!(steady_ascii(&steady)[..3], ["######"; 3]);
        // Dark for a frame: counted afresh.
        let dark = BitImage::with_dimensions(6, 4);
        let t_us = feed(&mut steady, &[&dark, &block], t_us);
        assert_eq!(steady_ascii(&steady)[..3], ["......"; 3]);
        // Time going backwards starts every count afresh too.
        feed(&mut steady, &[&block; 9], t_us);
        assert_eq!(steady_ascii(&steady)[..3], ["######"; 3]);
        feed(&mut steady, &[&block], 0);
        assert_eq!(steady_ascii(&steady)[..3], ["......"; 3]);
    }

    #[test]
    fn a_flickering_rim_leaves_no_specks() {
        let block = BitImage::from_ascii(&["######", "######", "######", "......"]);
        let with_rim = BitImage::from_ascii(&["######", "######", "######", "######"]);
        let mut steady = SteadyPixels::new(6, 4);
        let t_us = feed(&mut steady, &[&block; 9], 0);
        // The rim's pixels are bright in every other frame: never steady, never fresh.
        let t_us = feed(&mut steady, &[&with_rim, &block, &with_rim], t_us);
        assert_eq!(steady_ascii(&steady)[3], "......");
        assert!(fresh_ascii(&mut steady).iter().all(|r| !r.contains('#')));
        // Three rows of it are a light, and fresh.
        let wide =
            BitImage::from_ascii(&["######", "######", "######", "######", "######", "######"]);
        let mut steady = SteadyPixels::new(6, 6);
        let tall_block =
            BitImage::from_ascii(&["######", "######", "######", "......", "......", "......"]);
        let t_us = feed(&mut steady, &[&tall_block; 9], t_us);
        feed(&mut steady, &[&wide], t_us);
        assert_eq!(fresh_ascii(&mut steady)[3..], ["######"; 3]);
    }

    #[test]
    fn steady_is_counted_in_time_not_frames() {
        let lit = BitImage::from_ascii(&["###", "###", "###"]);
        // At 1000 fps, 15 frames (the counter's most) are 15 ms: steady means bright for the
        // last 15 frames, however short they are.
        let mut fast = SteadyPixels::new(3, 3);
        for i in 0..14 {
            fast.observe(&lit, i * 1_000);
        }
        assert_eq!(steady_ascii(&fast), ["..."; 3]);
        fast.observe(&lit, 14_000);
        assert_eq!(steady_ascii(&fast), ["###"; 3]);
        // At 5 fps, two frames 0.2 s apart are not yet a quarter second; three are.
        let mut slow = SteadyPixels::new(3, 3);
        for i in 0..2 {
            slow.observe(&lit, i * 200_000);
        }
        assert_eq!(steady_ascii(&slow), ["..."; 3]);
        slow.observe(&lit, 400_000);
        assert_eq!(steady_ascii(&slow), ["###"; 3]);
    }

    #[test]
    fn at_least_compares_every_count_with_every_bound() {
        for n in 0..16u64 {
            // Pixel `c` holds count `c`.
            let bits: [u64; COUNTER_BITS] = core::array::from_fn(|k| {
                (0..16u64)
                    .filter(|c| (c >> k) & 1 == 1)
                    .fold(0, |w, c| w | 1 << c)
            });
            let expected = (n..16).fold(0u64, |w, c| w | 1 << c);
            assert_eq!(at_least(bits, n) & 0xffff, expected, "n = {n}");
        }
    }
}
