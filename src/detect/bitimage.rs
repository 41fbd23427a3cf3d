//! A bit-packed binary image: one bit per pixel, 64 pixels per `u64` word.
//!
//! Bit `i` of word `k` in a row is pixel `x = 64 k + i`. Bits past the image width are always
//! zero, so whole-word operations (AND, OR, popcount) never see phantom pixels. Rows are
//! padded to whole words, which lets morphology work a word at a time.

use core::fmt;

use crate::frame::FrameSize;

/// Pixels per storage word.
pub const WORD_BITS: usize = 64;

/// The eight neighbours of a pixel as `(dx, dy)`, clockwise from north (y grows downwards):
/// the order thinning's rule names them in, P2 to P9.
pub const NEIGHBOURS_8: [(isize, isize); 8] = [
    (0, -1),
    (1, -1),
    (1, 0),
    (1, 1),
    (0, 1),
    (-1, 1),
    (-1, 0),
    (-1, -1),
];

/// A rectangle of whole words and rows that an operation is restricted to.
///
/// Restricting morphology to the neighbourhood of one blob keeps its cost proportional to the
/// blob, not to the frame: the LED covers a few hundred of a frame's 300 000 pixels.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Window {
    /// First row.
    pub y0: usize,
    /// One past the last row.
    pub y1: usize,
    /// First word of each row.
    pub k0: usize,
    /// One past the last word of each row.
    pub k1: usize,
}

impl Window {
    /// True when the window holds no pixels.
    pub fn is_empty(&self) -> bool {
        self.y0 >= self.y1 || self.k0 >= self.k1
    }
}

/// A binary image of fixed size, allocated once.
#[derive(Clone, PartialEq, Eq)]
pub struct BitImage {
    width_px: usize,
    height_px: usize,
    words_per_row: usize,
    words: Vec<u64>,
}

impl BitImage {
    /// An all-zero image; the only allocation it ever makes.
    pub fn new(size: FrameSize) -> Self {
        Self::with_dimensions(size.width(), size.height())
    }

    /// An all-zero image of any size, including odd widths (masks need not come from YUYV).
    pub fn with_dimensions(width_px: usize, height_px: usize) -> Self {
        let words_per_row = width_px.div_ceil(WORD_BITS);
        BitImage {
            width_px,
            height_px,
            words_per_row,
            words: vec![0; words_per_row * height_px],
        }
    }

    /// Builds an image from an ASCII picture, `#` for set and anything else for clear.
    /// Meant for tests and documentation, where a picture says more than coordinates.
    pub fn from_ascii(rows: &[&str]) -> Self {
        let width = rows.iter().map(|r| r.chars().count()).max().unwrap_or(0);
        let mut image = Self::with_dimensions(width, rows.len());
        for (y, row) in rows.iter().enumerate() {
            for (x, c) in row.chars().enumerate() {
                if c == '#' {
                    image.set(x, y);
                }
            }
        }
        image
    }

    /// The image as ASCII rows, `#` for set and `.` for clear.
    pub fn to_ascii(&self) -> Vec<String> {
        (0..self.height_px)
            .map(|y| {
                (0..self.width_px)
                    .map(|x| if self.get(x, y) { '#' } else { '.' })
                    .collect()
            })
            .collect()
    }

    /// Width in pixels.
    pub fn width(&self) -> usize {
        self.width_px
    }

    /// Height in pixels.
    pub fn height(&self) -> usize {
        self.height_px
    }

    /// Words in each row.
    pub fn words_per_row(&self) -> usize {
        self.words_per_row
    }

    /// The mask of valid bits in the last word of a row.
    pub fn last_word_mask(&self) -> u64 {
        match self.width_px % WORD_BITS {
            0 => !0,
            bits => (1u64 << bits) - 1,
        }
    }

    /// The whole image as one window.
    pub fn full_window(&self) -> Window {
        Window {
            y0: 0,
            y1: self.height_px,
            k0: 0,
            k1: self.words_per_row,
        }
    }

    /// The smallest window holding the pixel rectangle `[x0, x1] × [y0, y1]` grown by
    /// `margin_px` on every side, clipped to the image.
    pub fn window_around(
        &self,
        x0: usize,
        y0: usize,
        x1: usize,
        y1: usize,
        margin_px: usize,
    ) -> Window {
        let x_lo = x0.saturating_sub(margin_px);
        let x_hi = (x1 + margin_px).min(self.width_px.saturating_sub(1));
        Window {
            y0: y0.saturating_sub(margin_px),
            y1: (y1 + margin_px + 1).min(self.height_px),
            k0: x_lo / WORD_BITS,
            k1: (x_hi / WORD_BITS + 1).min(self.words_per_row),
        }
    }

    /// Pixel `(x, y)`; false outside the image.
    #[inline]
    pub fn get(&self, x: usize, y: usize) -> bool {
        if x >= self.width_px || y >= self.height_px {
            return false;
        }
        let word = self.words[y * self.words_per_row + x / WORD_BITS];
        (word >> (x % WORD_BITS)) & 1 == 1
    }

    /// Sets pixel `(x, y)`; ignored outside the image.
    #[inline]
    pub fn set(&mut self, x: usize, y: usize) {
        if x < self.width_px && y < self.height_px {
            self.words[y * self.words_per_row + x / WORD_BITS] |= 1 << (x % WORD_BITS);
        }
    }

    /// Clears pixel `(x, y)`; ignored outside the image.
    #[inline]
    pub fn clear(&mut self, x: usize, y: usize) {
        if x < self.width_px && y < self.height_px {
            self.words[y * self.words_per_row + x / WORD_BITS] &= !(1 << (x % WORD_BITS));
        }
    }

    /// The words of row `y`, or an empty slice past the last row.
    #[inline]
    pub fn row(&self, y: usize) -> &[u64] {
        let start = y * self.words_per_row;
        self.words
            .get(start..start + self.words_per_row)
            .unwrap_or(&[])
    }

    /// The words of row `y`, mutable; empty past the last row.
    #[inline]
    pub fn row_mut(&mut self, y: usize) -> &mut [u64] {
        let start = y * self.words_per_row;
        self.words
            .get_mut(start..start + self.words_per_row)
            .unwrap_or(&mut [])
    }

    /// Sets pixels `x0..=x1` of row `y`, clipped to the image.
    pub fn set_run(&mut self, y: usize, x0: usize, x1: usize) {
        let x1 = x1.min(self.width_px.saturating_sub(1));
        if y >= self.height_px || x0 > x1 {
            return;
        }
        let row = self.row_mut(y);
        let (k0, k1) = (x0 / WORD_BITS, x1 / WORD_BITS);
        for k in k0..=k1 {
            let lo = if k == k0 { x0 % WORD_BITS } else { 0 };
            let hi = if k == k1 {
                x1 % WORD_BITS
            } else {
                WORD_BITS - 1
            };
            let bits = (!0u64 >> (WORD_BITS - 1 - hi)) & (!0u64 << lo);
            if let Some(word) = row.get_mut(k) {
                *word |= bits;
            }
        }
    }

    /// Clears every pixel.
    pub fn clear_all(&mut self) {
        self.words.fill(0);
    }

    /// Clears the pixels inside `window`.
    pub fn clear_window(&mut self, window: Window) {
        for y in window.y0..window.y1.min(self.height_px) {
            if let Some(words) = self.row_mut(y).get_mut(window.k0..window.k1) {
                words.fill(0);
            }
        }
    }

    /// Copies the pixels inside `window` from `src`, which must have the same dimensions.
    pub fn copy_window_from(&mut self, src: &BitImage, window: Window) {
        for y in window.y0..window.y1.min(self.height_px) {
            let (Some(dst), Some(s)) = (
                self.row_mut(y).get_mut(window.k0..window.k1),
                src.row(y).get(window.k0..window.k1),
            ) else {
                continue;
            };
            dst.copy_from_slice(s);
        }
    }

    /// The set pixels inside `window`, row by row, as `(x, y)`: a word at a time, so empty
    /// stretches cost little.
    pub fn ones_in(&self, window: Window) -> OnesIn<'_> {
        let window = Window {
            y1: window.y1.min(self.height_px),
            k1: window.k1.min(self.words_per_row),
            ..window
        };
        OnesIn {
            image: self,
            window,
            y: window.y0,
            k: window.k0,
            word: 0,
            started: false,
        }
    }

    /// Number of set pixels.
    pub fn count_ones(&self) -> usize {
        self.words.iter().map(|w| w.count_ones() as usize).sum()
    }

    /// True when no pixel inside `window` is set.
    pub fn window_is_empty(&self, window: Window) -> bool {
        (window.y0..window.y1.min(self.height_px)).all(|y| {
            self.row(y)
                .get(window.k0..window.k1)
                .is_none_or(|ws| ws.iter().all(|&w| w == 0))
        })
    }

    /// True when both images have the same dimensions.
    pub fn same_shape(&self, other: &BitImage) -> bool {
        self.width_px == other.width_px && self.height_px == other.height_px
    }
}

/// The set pixels of a window of a [`BitImage`]; see [`BitImage::ones_in`].
pub struct OnesIn<'a> {
    image: &'a BitImage,
    window: Window,
    y: usize,
    k: usize,
    word: u64,
    started: bool,
}

impl Iterator for OnesIn<'_> {
    type Item = (usize, usize);

    #[inline]
    fn next(&mut self) -> Option<(usize, usize)> {
        loop {
            if self.word != 0 {
                let bit = self.word.trailing_zeros() as usize;
                self.word &= self.word - 1;
                return Some((self.k * WORD_BITS + bit, self.y));
            }
            // Step to the next word of the window, row by row.
            if self.started {
                self.k += 1;
                if self.k >= self.window.k1 {
                    self.k = self.window.k0;
                    self.y += 1;
                }
            }
            self.started = true;
            if self.y >= self.window.y1 || self.window.k0 >= self.window.k1 {
                return None;
            }
            self.word = self.image.row(self.y).get(self.k).copied().unwrap_or(0);
        }
    }
}

impl fmt::Debug for BitImage {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "BitImage {}x{}", self.width_px, self.height_px)?;
        for row in self.to_ascii() {
            writeln!(f, "{row}")?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ascii_round_trip_and_padding_stays_clear() {
        let picture = ["#..#", ".##.", "...."];
        let image = BitImage::from_ascii(&picture);
        assert_eq!(image.to_ascii(), picture);
        assert_eq!(image.count_ones(), 4);
        assert!(!image.get(4, 0), "past the width reads clear");
        assert_eq!(image.row(0), &[0b1001]);
    }

    #[test]
    fn pixels_past_64_land_in_the_next_word() {
        let mut image = BitImage::with_dimensions(130, 2);
        image.set(64, 1);
        image.set(129, 1);
        assert_eq!(image.words_per_row(), 3);
        assert_eq!(image.row(1), &[0, 1, 0b10]);
        image.clear(64, 1);
        assert_eq!(image.count_ones(), 1);
        let ones: Vec<_> = image.ones_in(image.full_window()).collect();
        assert_eq!(ones, [(129, 1)]);
        image.set_run(0, 60, 70);
        image.set_run(0, 125, 500);
        assert_eq!(image.row(0), &[0xF << 60, 0x7F | 0x7 << 61, 0b11]);
        let window = Window {
            y0: 0,
            y1: 1,
            k0: 1,
            k1: 2,
        };
        let ones: Vec<_> = image.ones_in(window).map(|(x, _)| x).collect();
        assert_eq!(ones, [64, 65, 66, 67, 68, 69, 70, 125, 126, 127]);
        assert_eq!(image.last_word_mask(), 0b11);
    }
}
