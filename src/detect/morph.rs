//! Bit-packed erosion and dilation with 3×3 structuring elements.
//!
//! Each output word is computed from at most nine input words with shifts, ANDs and ORs, so a
//! 64-pixel stretch costs a handful of instructions. Pixels outside the image count as
//! background for both operations: an erosion therefore always shrinks a blob, which is what
//! guarantees that the skeleton's erode-until-empty loop ends, even on an all-white frame.

use super::bitimage::{BitImage, Window};

/// A 3×3 structuring element.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Kernel {
    /// All nine pixels (OpenCV's `np.ones((3,3))`).
    Square,
    /// The centre and its four edge neighbours (OpenCV's `MORPH_CROSS`).
    Cross,
}

/// Which operation a pass applies.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Op {
    Erode,
    Dilate,
}

/// Pixel `x` receives pixel `x - 1` (`prev` is the word to the left).
#[inline(always)]
pub(crate) fn from_left(word: u64, prev: u64) -> u64 {
    (word << 1) | (prev >> 63)
}

/// Pixel `x` receives pixel `x + 1` (`next` is the word to the right).
#[inline(always)]
pub(crate) fn from_right(word: u64, next: u64) -> u64 {
    (word >> 1) | (next << 63)
}

/// The horizontal 1×3 combination of word `k` of `row`, AND for erosion and OR for dilation.
#[inline(always)]
fn horizontal(row: &[u64], k: usize, op: Op) -> u64 {
    let word = row.get(k).copied().unwrap_or(0);
    let prev = k
        .checked_sub(1)
        .and_then(|p| row.get(p))
        .copied()
        .unwrap_or(0);
    let next = row.get(k + 1).copied().unwrap_or(0);
    let (l, r) = (from_left(word, prev), from_right(word, next));
    match op {
        Op::Erode => word & l & r,
        Op::Dilate => word | l | r,
    }
}

fn apply(src: &BitImage, dst: &mut BitImage, kernel: Kernel, op: Op, window: Window) {
    debug_assert!(src.same_shape(dst));
    let last_k = src.words_per_row().saturating_sub(1);
    let last_mask = src.last_word_mask();
    let height = src.height();
    for y in window.y0..window.y1.min(height) {
        let mid = src.row(y);
        let up = y.checked_sub(1).map_or(&[][..], |u| src.row(u));
        let down = src.row(y + 1);
        let out = dst.row_mut(y);
        for k in window.k0..window.k1.min(mid.len()) {
            let v_up = up.get(k).copied().unwrap_or(0);
            let v_down = down.get(k).copied().unwrap_or(0);
            let word = match (kernel, op) {
                (Kernel::Square, Op::Erode) => {
                    horizontal(up, k, op) & horizontal(mid, k, op) & horizontal(down, k, op)
                }
                (Kernel::Square, Op::Dilate) => {
                    horizontal(up, k, op) | horizontal(mid, k, op) | horizontal(down, k, op)
                }
                (Kernel::Cross, Op::Erode) => horizontal(mid, k, op) & v_up & v_down,
                (Kernel::Cross, Op::Dilate) => horizontal(mid, k, op) | v_up | v_down,
            };
            let masked = if k == last_k { word & last_mask } else { word };
            if let Some(o) = out.get_mut(k) {
                *o = masked;
            }
        }
    }
}

/// One erosion of `src` into `dst`, inside `window` only.
pub fn erode(src: &BitImage, dst: &mut BitImage, kernel: Kernel, window: Window) {
    apply(src, dst, kernel, Op::Erode, window);
}

/// One dilation of `src` into `dst`, inside `window` only. The caller leaves a margin of one
/// pixel per dilation around the content, or the growth past the window is cut off.
pub fn dilate(src: &BitImage, dst: &mut BitImage, kernel: Kernel, window: Window) {
    apply(src, dst, kernel, Op::Dilate, window);
}

/// `iterations` erosions of `image` in place, using `scratch` (same dimensions) as the
/// ping-pong buffer.
pub fn erode_n(
    image: &mut BitImage,
    scratch: &mut BitImage,
    kernel: Kernel,
    iterations: u32,
    window: Window,
) {
    repeat(image, scratch, kernel, Op::Erode, iterations, window);
}

/// `iterations` dilations of `image` in place, using `scratch` as the ping-pong buffer.
pub fn dilate_n(
    image: &mut BitImage,
    scratch: &mut BitImage,
    kernel: Kernel,
    iterations: u32,
    window: Window,
) {
    repeat(image, scratch, kernel, Op::Dilate, iterations, window);
}

fn repeat(
    image: &mut BitImage,
    scratch: &mut BitImage,
    kernel: Kernel,
    op: Op,
    iterations: u32,
    window: Window,
) {
    for _ in 0..iterations {
        apply(image, scratch, kernel, op, window);
        image.copy_window_from(scratch, window);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(picture: &[&str], kernel: Kernel, op: Op) -> Vec<String> {
        let src = BitImage::from_ascii(picture);
        let mut dst = BitImage::with_dimensions(src.width(), src.height());
        apply(&src, &mut dst, kernel, op, src.full_window());
        dst.to_ascii()
    }

    #[test]
    fn square_erosion_keeps_only_full_neighbourhoods() {
        let picture = [
            ".....", //
            ".###.", ".###.", ".###.", ".....",
        ];
        let expected = [".....", ".....", "..#..", ".....", "....."];
        assert_eq!(run(&picture, Kernel::Square, Op::Erode), expected);
    }

    #[test]
    fn cross_erosion_ignores_corners() {
        let picture = [
            "..#..", //
            ".###.", "..#..",
        ];
        assert_eq!(
            run(&picture, Kernel::Cross, Op::Erode),
            [".....", "..#..", "....."]
        );
        assert_eq!(
            run(&picture, Kernel::Square, Op::Erode)
                .concat()
                .matches('#')
                .count(),
            0,
            "the square needs the corners too"
        );
    }

    #[test]
    fn dilations_grow_by_their_kernel() {
        let picture = [".....", ".....", "..#..", ".....", "....."];
        assert_eq!(
            run(&picture, Kernel::Square, Op::Dilate),
            [".....", ".###.", ".###.", ".###.", "....."]
        );
        assert_eq!(
            run(&picture, Kernel::Cross, Op::Dilate),
            [".....", "..#..", ".###.", "..#..", "....."]
        );
    }

    #[test]
    fn the_image_border_counts_as_background() {
        // A full image erodes from its border inwards, so repeated erosion empties it.
        let picture = ["####", "####", "####"];
        assert_eq!(
            run(&picture, Kernel::Square, Op::Erode),
            ["....", ".##.", "...."]
        );
        // Dilation does not write past the width into the padding bits.
        let grown = run(&["...#"], Kernel::Square, Op::Dilate);
        assert_eq!(grown, ["..##"]);
    }

    #[test]
    fn shifts_carry_across_word_boundaries() {
        let mut src = BitImage::with_dimensions(130, 3);
        src.set(63, 1);
        let mut dst = BitImage::with_dimensions(130, 3);
        dilate(&src, &mut dst, Kernel::Cross, src.full_window());
        assert!(dst.get(62, 1) && dst.get(64, 1) && dst.get(63, 0) && dst.get(63, 2));
        assert_eq!(dst.count_ones(), 5);
        let mut wide = BitImage::with_dimensions(130, 3);
        for x in 0..130 {
            wide.set(x, 0);
            wide.set(x, 1);
            wide.set(x, 2);
        }
        erode(&wide, &mut dst, Kernel::Square, wide.full_window());
        assert_eq!(
            dst.count_ones(),
            128,
            "row 1 keeps all but its two border pixels"
        );
        assert!(dst.get(63, 1) && dst.get(64, 1) && !dst.get(129, 1) && !dst.get(0, 1));
    }

    #[test]
    fn iterations_compose() {
        let mut image = BitImage::with_dimensions(9, 9);
        image.set(4, 4);
        let mut scratch = BitImage::with_dimensions(9, 9);
        let window = image.full_window();
        dilate_n(&mut image, &mut scratch, Kernel::Square, 3, window);
        assert_eq!(image.count_ones(), 49);
        erode_n(&mut image, &mut scratch, Kernel::Square, 2, window);
        assert_eq!(image.count_ones(), 9);
        erode_n(&mut image, &mut scratch, Kernel::Cross, 1, window);
        assert_eq!(image.to_ascii()[4], "....#....");
        assert_eq!(image.count_ones(), 1);
    }
}
