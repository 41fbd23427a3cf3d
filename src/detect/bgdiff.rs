//! The seed's other detector: background difference, bit-packed like the saturation mask.
//!
//! The background is the per-pixel median luma of the first N frames (or of the frames of a
//! separate dump), so a LED that moves during learning does not stay in it. Afterwards a pixel
//! is set in the mask when its luma differs from the background by at least the difference
//! threshold. Static glare is part of the background and never shows; the price is that a
//! robot standing still through the learning frames becomes background where it stood.

use core::fmt;

use super::bitimage::BitImage;
use crate::frame::{Frame, FrameSize};

/// Most frames the median may be taken over; the learning buffer is this many frames at most.
pub const MAX_BACKGROUND_FRAMES: usize = 63;

/// Why a background could not be built.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum BackgroundError {
    /// Zero frames, or more than [`MAX_BACKGROUND_FRAMES`].
    FrameCount(usize),
    /// A frame of another size.
    Size { expected: FrameSize, got: FrameSize },
}

impl fmt::Display for BackgroundError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            BackgroundError::FrameCount(n) => write!(
                f,
                "a background needs 1 to {MAX_BACKGROUND_FRAMES} frames, not {n}"
            ),
            BackgroundError::Size { expected, got } => {
                write!(f, "background frame is {got}, the video is {expected}")
            }
        }
    }
}

impl std::error::Error for BackgroundError {}

/// A background model: learning, then differencing.
pub struct Background {
    size: FrameSize,
    frames_wanted: usize,
    /// `frames_wanted` luma planes, filled while learning.
    learning: Vec<u8>,
    frames_learned: usize,
    /// The median luma plane, valid once learning is complete.
    median: Vec<u8>,
}

impl Background {
    /// A model that learns from the next `frames` frames of `size`.
    pub fn new(size: FrameSize, frames: usize) -> Result<Self, BackgroundError> {
        if frames == 0 || frames > MAX_BACKGROUND_FRAMES {
            return Err(BackgroundError::FrameCount(frames));
        }
        Ok(Background {
            size,
            frames_wanted: frames,
            learning: vec![0; frames * size.pixels()],
            frames_learned: 0,
            median: vec![0; size.pixels()],
        })
    }

    /// True once the median is available.
    pub fn is_ready(&self) -> bool {
        self.frames_learned >= self.frames_wanted
    }

    /// Adds a frame to the learning set; the median is computed when the set is complete.
    pub fn learn(&mut self, frame: &Frame<'_>) -> Result<(), BackgroundError> {
        if frame.size() != self.size {
            return Err(BackgroundError::Size {
                expected: self.size,
                got: frame.size(),
            });
        }
        if self.is_ready() {
            return Ok(());
        }
        let pixels = self.size.pixels();
        let start = self.frames_learned * pixels;
        let Some(plane) = self.learning.get_mut(start..start + pixels) else {
            return Ok(());
        };
        let step = frame.luma_step();
        for (dst_row, row) in plane
            .chunks_exact_mut(self.size.width())
            .zip(frame.luma_rows())
        {
            for (dst, &luma) in dst_row.iter_mut().zip(row.iter().step_by(step)) {
                *dst = luma;
            }
        }
        self.frames_learned += 1;
        if self.is_ready() {
            self.compute_median();
        }
        Ok(())
    }

    fn compute_median(&mut self) {
        let pixels = self.size.pixels();
        let n = self.frames_wanted;
        let mut values = [0u8; MAX_BACKGROUND_FRAMES];
        for (p, out) in self.median.iter_mut().enumerate() {
            for (f, v) in values.iter_mut().take(n).enumerate() {
                *v = self.learning.get(f * pixels + p).copied().unwrap_or(0);
            }
            let used = &mut values[..n];
            used.sort_unstable();
            *out = used[n / 2];
        }
    }

    /// Writes the difference mask of `frame` into `mask`: set where the luma differs from the
    /// background by at least `diff_luma`. Returns the count of set pixels (0 while learning).
    pub fn difference_into(&self, frame: &Frame<'_>, diff_luma: u8, mask: &mut BitImage) -> usize {
        if !self.is_ready() || frame.size() != self.size {
            mask.clear_all();
            return 0;
        }
        let width = self.size.width();
        let mut count = 0;
        let step = frame.luma_step();
        for (y, (row, background)) in frame
            .luma_rows()
            .zip(self.median.chunks_exact(width))
            .enumerate()
        {
            let words = mask.row_mut(y);
            for (k, word) in words.iter_mut().enumerate() {
                let mut bits = 0u64;
                let pixels = row
                    .iter()
                    .step_by(step)
                    .zip(background)
                    .skip(64 * k)
                    .take(64);
                for (i, (&luma, &b)) in pixels.enumerate() {
                    bits |= u64::from(luma.abs_diff(b) >= diff_luma) << i;
                }
                *word = bits;
                count += bits.count_ones() as usize;
            }
        }
        count
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn frame_bytes(lumas: &[u8]) -> Vec<u8> {
        lumas.iter().flat_map(|&y| [y, 128]).collect()
    }

    #[test]
    fn the_median_ignores_a_light_that_passes_through_learning() {
        let size = FrameSize::new(4, 1).unwrap();
        let mut bg = Background::new(size, 3).unwrap();
        // The bright pixel moves: each position is lit in only one of three frames.
        for lumas in [[250, 50, 50, 60], [50, 250, 50, 60], [50, 50, 250, 60]] {
            let bytes = frame_bytes(&lumas);
            bg.learn(&Frame::new_checked(&bytes, size, 8).unwrap())
                .unwrap();
        }
        assert!(bg.is_ready());
        let bytes = frame_bytes(&[50, 50, 120, 250]);
        let frame = Frame::new_checked(&bytes, size, 8).unwrap();
        let mut mask = BitImage::new(size);
        assert_eq!(bg.difference_into(&frame, 40, &mut mask), 2);
        assert_eq!(mask.to_ascii(), ["..##"]);
    }

    #[test]
    fn nothing_is_found_while_learning_and_bad_sizes_are_refused() {
        let size = FrameSize::new(2, 1).unwrap();
        let mut bg = Background::new(size, 2).unwrap();
        let bytes = frame_bytes(&[0, 255]);
        let frame = Frame::new_checked(&bytes, size, 4).unwrap();
        let mut mask = BitImage::new(size);
        mask.set(0, 0);
        assert_eq!(bg.difference_into(&frame, 10, &mut mask), 0);
        assert_eq!(mask.count_ones(), 0);
        let other = FrameSize::new(4, 1).unwrap();
        let wide = frame_bytes(&[0, 0, 0, 0]);
        let wrong = Frame::new_checked(&wide, other, 8).unwrap();
        assert!(matches!(
            bg.learn(&wrong),
            Err(BackgroundError::Size { .. })
        ));
        assert_eq!(
            Background::new(size, 0).err(),
            Some(BackgroundError::FrameCount(0))
        );
    }
}
