//! A learned map of the picture's static bright pixels (a window, a lamp, a bright wall), so
//! that the automatic level is measured on the rest of the picture.
//!
//! A window that clips at 244+ is not a flat 255: its noise straddles the level it is cut at,
//! so cut blob by blob it breaks into specks that come and go every frame, and a speck that
//! appears where none stood looks like something that moved. Learned as static, the window's
//! pixels are taken out of the mask before any blob is found: it sets no level, is never a
//! candidate, and an LED dimmer than it (beside it, not on it) is cut at its own level.
//!
//! Each pixel holds a 4-bit saturating counter, bit-sliced into four bit planes (bit `k` of 64
//! pixels' counters in one `u64`), so that an update is a few word operations per 64 pixels.
//! Over each period of [`UPDATE_PERIOD_US`] the bright pixels of every frame are
//! OR-ed together (a speck that flickers is bright in nearly every period); at the period's end
//! every counter steps up where the pixel was bright and down where it was not. A pixel
//! becomes static at [`LEARN_AT_COUNT`] and stops being static at [`FORGET_AT_COUNT`], so a
//! pixel at the edge of a window is not forever switching.
//!
//! The time constant: a pixel bright all the time is static after
//! `LEARN_AT_COUNT × UPDATE_PERIOD_US` = 3.2 s (96 frames at 30 fps), and a static pixel gone
//! dark is released after as long. It is counted in frame time, not frames: at 1000 fps a
//! count of frames would learn a robot at rest in a tenth of a second. Slow, because whatever stands that long is learned:
//! the LED of a robot parked before it was ever seen moving would be erased, and a robot that
//! waits a few seconds between moves must not be. The tracked LED itself is never learned
//! (the area around it is kept out of every period), so a tracked robot may park for as long
//! as it likes. A pixel kept out for a whole period keeps its count, neither up nor down: the
//! period says nothing about it. Faster would erase a parked robot's LED; slower leaves a
//! window to the tracker's own rules (it stands still since it appeared, so it is never
//! reported) for longer.
//!
//! A pixel close to being learned (a count of 8 or more) that touches a learned one is learned
//! with it, so that a window is learned whole: its rim beside a robot's path, kept out while the
//! robot passes, lags a few counts behind the rest. The join grows the learned pixels a pixel
//! at a time, a dilation of the frame each, at most 64 of them, and only in a
//! step that has such a pixel (a window's rim once, as it is learned).
//!
//! Memory: six bit planes of the frame (four counter bits, the period's OR and what the period
//! saw outside the kept-out areas), plus the static flag: 7 bits a pixel, 263 KiB at 640×480,
//! allocated once.

use crate::detect::bitimage::{BitImage, Window};
use crate::detect::morph::{self, Kernel};

/// Bits of each pixel's counter.
pub const COUNTER_BITS: usize = 4;

/// Frame time OR-ed into one update of the counters (8 frames at 30 fps).
pub const UPDATE_PERIOD_US: u64 = 8 * 33_333;

/// A counter at or above this marks its pixel static (binary 11xx: bits 3 and 2 set).
pub const LEARN_AT_COUNT: u8 = 12;

/// How far, in pixels, the learned pixels reach into their neighbours at one step at most:
/// a window's rim a robot kept out is a few tens of pixels wide.
const MAX_JOIN_STEPS: usize = 64;

/// A counter at or below this releases its pixel (binary 00xx: bits 3 and 2 clear).
pub const FORGET_AT_COUNT: u8 = 3;

/// The learned static pixels and the counters that learn them.
pub struct StaticMap {
    counter: [BitImage; COUNTER_BITS],
    /// The pixels bright in any frame of the current period (outside the kept-out areas).
    period: BitImage,
    /// The pixels outside the kept-out areas in any frame of the current period: what the
    /// period says anything about.
    seen: BitImage,
    /// Pixels learned as static.
    flag: BitImage,
    /// The time the current period started at; `None` before the first frame.
    period_start_us: Option<u64>,
}

impl StaticMap {
    /// An empty map for masks of `width_px × height_px` (nothing static yet).
    pub fn new(width_px: usize, height_px: usize) -> Self {
        let plane = || BitImage::with_dimensions(width_px, height_px);
        StaticMap {
            counter: [plane(), plane(), plane(), plane()],
            period: plane(),
            seen: plane(),
            flag: plane(),
            period_start_us: None,
        }
    }

    /// The pixels learned as static.
    pub fn flag(&self) -> &BitImage {
        &self.flag
    }

    /// Adds the bright pixels (`bright`, of the map's size) of the frame at `t_us` to the
    /// period, except inside the `keep_out` windows (the tracked LEDs' surroundings), and once the period
    /// has lasted [`UPDATE_PERIOD_US`] steps the counters (once, however long it lasted). A
    /// mask of another size is ignored; time going backwards starts a new period.
    pub fn observe(&mut self, bright: &BitImage, keep_out: &[Window], t_us: u64) {
        if !bright.same_shape(&self.period) {
            return;
        }
        let start_us = match self.period_start_us {
            Some(start) if start <= t_us => start,
            _ => {
                self.period.clear_all();
                self.seen.clear_all();
                self.period_start_us = Some(t_us);
                t_us
            }
        };
        for y in 0..bright.height() {
            let src = bright.row(y);
            let (period, seen) = (self.period.row_mut(y), self.seen.row_mut(y));
            if !keep_out.iter().any(|w| (w.y0..w.y1).contains(&y)) {
                // Most rows: no window is kept out across them, so every word is learned.
                for (dst, &word) in period.iter_mut().zip(src) {
                    *dst |= word;
                }
                seen.fill(!0);
                continue;
            }
            let rows = period.iter_mut().zip(seen.iter_mut());
            for (k, ((dst, seen), &word)) in rows.zip(src).enumerate() {
                let kept = keep_out
                    .iter()
                    .any(|w| (w.y0..w.y1).contains(&y) && (w.k0..w.k1).contains(&k));
                if !kept {
                    *dst |= word;
                    *seen = !0;
                }
            }
        }
        if t_us - start_us >= UPDATE_PERIOD_US {
            self.step();
            self.period.clear_all();
            self.seen.clear_all();
            self.period_start_us = Some(t_us);
        }
    }

    /// One step of every counter: up where the period was bright, down where it was seen and
    /// not bright (saturating at 0 and 15), then the flag's hysteresis. A pixel kept out for
    /// the whole period keeps its count: a window's rim beside a robot that passes it again
    /// and again is learned, only later, with the rest of the window.
    fn step(&mut self) {
        let [c0, c1, c2, c3] = &mut self.counter;
        let last = self.period.last_word_mask();
        let wpr = self.period.words_per_row();
        // Pixels close to being learned and not yet learned, in any word: only then is
        // anything to join.
        let mut close = 0u64;
        for y in 0..self.period.height() {
            let rows = (
                c0.row_mut(y),
                c1.row_mut(y),
                c2.row_mut(y),
                c3.row_mut(y),
                self.period.row(y),
                self.seen.row(y),
                self.flag.row_mut(y),
            );
            let (r0, r1, r2, r3, bright, seen, flag) = rows;
            for k in 0..wpr {
                let valid = if k + 1 == wpr { last } else { !0 };
                let (Some(b0), Some(b1), Some(b2), Some(b3), Some(&on), Some(&seen), Some(f)) = (
                    r0.get_mut(k),
                    r1.get_mut(k),
                    r2.get_mut(k),
                    r3.get_mut(k),
                    bright.get(k),
                    seen.get(k),
                    flag.get_mut(k),
                ) else {
                    continue;
                };
                // Most of a frame: never bright, so no count to step and no flag to clear.
                if on | *b0 | *b1 | *b2 | *b3 | *f == 0 {
                    continue;
                }
                let full = *b0 & *b1 & *b2 & *b3;
                let empty = !(*b0 | *b1 | *b2 | *b3);
                let up = on & !full & valid;
                let down = !on & seen & !empty & valid;
                // Ripple-carry increment by `up`, ripple-borrow decrement by `down`, one bit
                // plane at a time (the two masks never share a pixel).
                let (mut carry, mut borrow) = (up, down);
                for bit in [&mut *b0, &mut *b1, &mut *b2, &mut *b3] {
                    let old = *bit;
                    *bit = old ^ carry ^ borrow;
                    carry &= old;
                    borrow &= !old;
                }
                let high = *b3 & *b2;
                let low = !(*b3 | *b2);
                *f = (*f | high) & !low & valid;
                close |= *b3 & !*f;
            }
        }
        if close != 0 {
            self.join_learned();
        }
    }

    /// Learns the pixels close to being learned (a count of 8 or more: bit 3 set) that
    /// touch learned ones, as far as they reach ([`MAX_JOIN_STEPS`] pixels at most a step):
    /// a window is learned whole. Its rim beside a robot's path, kept out while the robot
    /// passes, lags a few counts behind the rest; left alone for those periods it stood as a
    /// smaller static blob, and the robot passing it merged with it into a blob that was read
    /// as a streak 40 px off. Uses the period's `seen` plane as scratch (it is cleared after).
    fn join_learned(&mut self) {
        let window = self.flag.full_window();
        for _ in 0..MAX_JOIN_STEPS {
            morph::dilate(&self.flag, &mut self.seen, Kernel::Square, window);
            let mut grew = false;
            for y in 0..self.flag.height() {
                let rows = self.flag.row_mut(y).iter_mut().zip(self.seen.row(y));
                for ((f, &near), &count_high) in rows.zip(self.counter[3].row(y)) {
                    let join = near & count_high & !*f;
                    grew |= join != 0;
                    *f |= join;
                }
            }
            if !grew {
                break;
            }
        }
    }

    /// Clears the static pixels from `mask` (of the map's size); returns how many it cleared.
    pub fn clear_static(&self, mask: &mut BitImage) -> usize {
        if !mask.same_shape(&self.flag) {
            return 0;
        }
        let mut cleared = 0;
        for y in 0..mask.height() {
            for (m, &f) in mask.row_mut(y).iter_mut().zip(self.flag.row(y)) {
                cleared += (*m & f).count_ones() as usize;
                *m &= !f;
            }
        }
        cleared
    }

    /// Forgets everything learned (a new scene).
    pub fn reset(&mut self) {
        for plane in &mut self.counter {
            plane.clear_all();
        }
        self.period.clear_all();
        self.seen.clear_all();
        self.flag.clear_all();
        self.period_start_us = None;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A map fed frames at 30 fps: eight frames to a period.
    struct Fed {
        map: StaticMap,
        t_us: u64,
    }

    impl Fed {
        fn new(width: usize, height: usize) -> Self {
            let mut map = StaticMap::new(width, height);
            // The first frame starts the first period.
            map.observe(&BitImage::with_dimensions(width, height), &[], 0);
            Fed { map, t_us: 0 }
        }

        fn frames(&mut self, bright: &BitImage, keep_out: &[Window], n: u64) {
            for _ in 0..n {
                self.t_us += UPDATE_PERIOD_US / 8;
                self.map.observe(bright, keep_out, self.t_us);
            }
        }

        fn periods(&mut self, bright: &BitImage, keep_out: &[Window], n: u8) {
            self.frames(bright, keep_out, 8 * u64::from(n));
        }

        fn flag(&self) -> &BitImage {
            self.map.flag()
        }
    }

    #[test]
    fn a_pixel_bright_for_long_is_learned_and_released_with_hysteresis() {
        let lit = BitImage::from_ascii(&["..##.", "....."]);
        let dark = BitImage::from_ascii(&[".....", "....."]);
        let mut map = Fed::new(5, 2);
        map.periods(&lit, &[], LEARN_AT_COUNT - 1);
        assert_eq!(map.flag().count_ones(), 0, "one period short");
        map.periods(&lit, &[], 1);
        assert_eq!(map.flag().to_ascii(), ["..##.", "....."]);
        // Saturated at 15, it stays static through 11 dark periods and goes at the 12th.
        map.periods(&lit, &[], 10);
        map.periods(&dark, &[], 11);
        assert_eq!(map.flag().count_ones(), 2);
        map.periods(&dark, &[], 1);
        assert_eq!(map.flag().count_ones(), 0);
        // Back from 3 it takes 9 periods, not 12, to be learned again.
        map.periods(&lit, &[], 8);
        assert_eq!(map.flag().count_ones(), 0);
        map.periods(&lit, &[], 1);
        assert_eq!(map.flag().count_ones(), 2);
        // Counted in time, not frames: at 1000 fps a period is 267 frames.
        let mut fast = StaticMap::new(5, 2);
        for t_us in 0..u64::from(LEARN_AT_COUNT) * 260 {
            fast.observe(&lit, &[], t_us * 1_000);
        }
        assert_eq!(fast.flag().count_ones(), 0, "3.1 s at 1000 fps");
    }

    #[test]
    fn a_speck_that_flickers_is_learned_and_a_pass_is_not() {
        let mut map = Fed::new(8, 1);
        let on = BitImage::from_ascii(&["#......."]);
        let off = BitImage::from_ascii(&["........"]);
        // Bright in one frame of every three: bright in every period.
        for i in 0..u64::from(LEARN_AT_COUNT) * 8 {
            map.frames(if i % 3 == 0 { &on } else { &off }, &[], 1);
        }
        assert_eq!(map.flag().to_ascii(), ["#......."]);
        // Something that passes each pixel once is never learned.
        let mut map = Fed::new(200, 1);
        for x in 0..200 {
            let mut pass = BitImage::with_dimensions(200, 1);
            pass.set(x, 0);
            map.frames(&pass, &[], 1);
        }
        assert_eq!(map.flag().count_ones(), 0);
    }

    #[test]
    fn the_kept_out_area_and_the_padding_are_never_learned_and_static_pixels_are_cleared() {
        let width = 70;
        let mut lit = BitImage::with_dimensions(width, 2);
        for x in 0..width {
            lit.set(x, 0);
            lit.set(x, 1);
        }
        let mut map = Fed::new(width, 2);
        // Keep out the first word of row 1.
        let keep_out = Window {
            y0: 1,
            y1: 2,
            k0: 0,
            k1: 1,
        };
        map.periods(&lit, &[keep_out], LEARN_AT_COUNT);
        assert_eq!(map.flag().count_ones(), width + (width - 64));
        assert_eq!(map.flag().row(0)[1], (1 << (width - 64)) - 1, "no padding");
        let mut mask = lit.clone();
        assert_eq!(map.map.clear_static(&mut mask), width + (width - 64));
        assert_eq!(mask.count_ones(), 64);
        assert!(mask.get(10, 1) && !mask.get(10, 0) && !mask.get(65, 1));
        map.map.reset();
        assert_eq!(map.flag().count_ones(), 0);
    }

    #[test]
    fn a_pixel_kept_out_for_whole_periods_keeps_its_count() {
        let lit = BitImage::from_ascii(&["##......"]);
        let dark = BitImage::from_ascii(&["........"]);
        let all = Window {
            y0: 0,
            y1: 1,
            k0: 0,
            k1: 1,
        };
        let mut map = Fed::new(8, 1);
        map.periods(&lit, &[], LEARN_AT_COUNT - 1);
        // Dark but kept out (a robot parked over it): no evidence either way.
        map.periods(&dark, &[all], 5);
        assert_eq!(map.flag().count_ones(), 0);
        map.periods(&lit, &[], 1);
        assert_eq!(map.flag().to_ascii(), ["##......"]);
    }

    #[test]
    fn a_rim_a_few_counts_behind_is_learned_with_the_window_it_touches() {
        let window = BitImage::from_ascii(&["######..", "######..", ".......#"]);
        let without_speck = BitImage::from_ascii(&["######..", "######..", "........"]);
        let rim = Window {
            y0: 1,
            y1: 2,
            k0: 0,
            k1: 1,
        };
        let mut map = Fed::new(8, 3);
        // The second row is kept out in three periods: three counts behind the first.
        map.periods(&without_speck, &[rim], 3);
        map.periods(&window, &[], LEARN_AT_COUNT - 3);
        // The speck, as far behind, touches nothing learned.
        assert_eq!(map.flag().to_ascii(), ["######..", "######..", "........"]);
    }
}
