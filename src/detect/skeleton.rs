//! Skeletons of a blob: the seed's morphological skeleton, and Guo–Hall thinning.
//!
//! The seed builds its skeleton from erosions and openings after five dilations, then masks it
//! with the input. On a streak a few pixels wide that yields a ragged, often broken line, so the
//! default is a proper thinning (Guo & Hall, 1989), which keeps the skeleton connected and one
//! pixel wide; that is what the walk to the streak's ends needs. Both run inside a window
//! around one blob, so their cost follows the blob, not the frame.

use super::bitimage::{BitImage, Window};
use super::morph::{self, Kernel};

/// Which skeleton the streak stage uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum SkeletonMethod {
    /// Guo–Hall thinning: connected, one pixel wide.
    #[default]
    Thinning,
    /// The seed's morphological skeleton (5 dilations, then erode/open/subtract until empty,
    /// masked by the input).
    Morphological,
}

/// Dilations the seed applies before its skeleton loop, so contours fall outside the blob.
pub const SEED_PRE_DILATIONS: u32 = 5;

/// Scratch images for the skeleton, allocated once at the frame's size.
pub struct SkeletonScratch {
    a: BitImage,
    b: BitImage,
    c: BitImage,
}

impl SkeletonScratch {
    /// Three images of `width × height`.
    pub fn new(width_px: usize, height_px: usize) -> Self {
        SkeletonScratch {
            a: BitImage::with_dimensions(width_px, height_px),
            b: BitImage::with_dimensions(width_px, height_px),
            c: BitImage::with_dimensions(width_px, height_px),
        }
    }
}

/// Writes the skeleton of the blob in `input` (inside `window`) into `skeleton`.
///
/// `window` must leave [`SEED_PRE_DILATIONS`] + 1 pixels of margin around the blob for the
/// morphological method; pixels of `skeleton` and the scratch outside `window` are untouched.
pub fn skeletonize(
    method: SkeletonMethod,
    input: &BitImage,
    skeleton: &mut BitImage,
    scratch: &mut SkeletonScratch,
    window: Window,
) {
    match method {
        SkeletonMethod::Thinning => {
            skeleton.copy_window_from(input, window);
            thin(skeleton, &mut scratch.a, window);
        }
        SkeletonMethod::Morphological => morphological(input, skeleton, scratch, window),
    }
}

fn morphological(
    input: &BitImage,
    skeleton: &mut BitImage,
    s: &mut SkeletonScratch,
    window: Window,
) {
    let SkeletonScratch { a, b, c } = s;
    a.copy_window_from(input, window);
    morph::dilate_n(a, b, Kernel::Square, SEED_PRE_DILATIONS, window);
    skeleton.clear_window(window);
    // Each round erodes once, so the loop ends within half the window's smaller side; the
    // bound guards against a window whose content touches its edge.
    let max_rounds = (window.y1 - window.y0) / 2 + 2;
    for _ in 0..max_rounds {
        morph::erode(a, b, Kernel::Cross, window);
        morph::dilate(b, c, Kernel::Cross, window);
        for y in window.y0..window.y1 {
            let (Some(skel), Some(img), Some(opened)) = (
                skeleton.row_mut(y).get_mut(window.k0..window.k1),
                a.row(y).get(window.k0..window.k1),
                c.row(y).get(window.k0..window.k1),
            ) else {
                continue;
            };
            for ((s, &i), &o) in skel.iter_mut().zip(img).zip(opened) {
                *s |= i & !o;
            }
        }
        a.copy_window_from(b, window);
        if a.window_is_empty(window) {
            break;
        }
    }
    for y in window.y0..window.y1 {
        let (Some(skel), Some(inp)) = (
            skeleton.row_mut(y).get_mut(window.k0..window.k1),
            input.row(y).get(window.k0..window.k1),
        ) else {
            continue;
        };
        for (s, &i) in skel.iter_mut().zip(inp) {
            *s &= i;
        }
    }
}

/// The 8-neighbourhood of `(x, y)` as a byte: bit 0 = north (P2), then clockwise: NE, E, SE,
/// S, SW, W, NW (P3..P9).
#[inline]
pub fn neighbours(image: &BitImage, x: usize, y: usize) -> u8 {
    let at = |dx: isize, dy: isize| -> u8 {
        match (x.checked_add_signed(dx), y.checked_add_signed(dy)) {
            (Some(nx), Some(ny)) => u8::from(image.get(nx, ny)),
            _ => 0,
        }
    };
    at(0, -1)
        | at(1, -1) << 1
        | at(1, 0) << 2
        | at(1, 1) << 3
        | at(0, 1) << 4
        | at(-1, 1) << 5
        | at(-1, 0) << 6
        | at(-1, -1) << 7
}

const fn bit(n: u8, i: u32) -> u8 {
    (n >> i) & 1
}

/// Whether Guo–Hall thinning deletes a pixel with neighbourhood `n` in sub-iteration
/// `second`. Guo & Hall (1989) keep two-pixel-thick diagonal lines, which Zhang–Suen erases
/// completely; a diagonal LED streak is exactly such a line.
const fn deletable(n: u8, second: bool) -> bool {
    let (p2, p3, p4, p5) = (bit(n, 0), bit(n, 1), bit(n, 2), bit(n, 3));
    let (p6, p7, p8, p9) = (bit(n, 4), bit(n, 5), bit(n, 6), bit(n, 7));
    let connectivity = ((1 - p2) & (p3 | p4))
        + ((1 - p4) & (p5 | p6))
        + ((1 - p6) & (p7 | p8))
        + ((1 - p8) & (p9 | p2));
    let n1 = (p9 | p2) + (p3 | p4) + (p5 | p6) + (p7 | p8);
    let n2 = (p2 | p3) + (p4 | p5) + (p6 | p7) + (p8 | p9);
    let neighbours = if n1 < n2 { n1 } else { n2 };
    let m = if second {
        (p2 | p3 | (1 - p5)) & p4
    } else {
        (p6 | p7 | (1 - p9)) & p8
    };
    connectivity == 1 && neighbours >= 2 && neighbours <= 3 && m == 0
}

const fn deletion_table(second: bool) -> [bool; 256] {
    let mut table = [false; 256];
    let mut n = 0;
    while n < 256 {
        table[n] = deletable(n as u8, second);
        n += 1;
    }
    table
}

const DELETE_FIRST: [bool; 256] = deletion_table(false);
const DELETE_SECOND: [bool; 256] = deletion_table(true);

/// Guo–Hall thinning of `image` in place, inside `window`, with `marks` as scratch.
pub fn thin(image: &mut BitImage, marks: &mut BitImage, window: Window) {
    // Each full pass peels at least one layer or stops; a blob is at most this many layers.
    let max_passes = (window.y1 - window.y0).max((window.k1 - window.k0) * 64) / 2 + 2;
    for _ in 0..max_passes {
        let first = thin_subiteration(image, marks, window, &DELETE_FIRST);
        let second = thin_subiteration(image, marks, window, &DELETE_SECOND);
        if !(first || second) {
            break;
        }
    }
}

fn thin_subiteration(
    image: &mut BitImage,
    marks: &mut BitImage,
    window: Window,
    table: &[bool; 256],
) -> bool {
    marks.clear_window(window);
    let mut any = false;
    for y in window.y0..window.y1 {
        for k in window.k0..window.k1 {
            let mut bits = image.row(y).get(k).copied().unwrap_or(0);
            while bits != 0 {
                let x = k * 64 + bits.trailing_zeros() as usize;
                bits &= bits - 1;
                if table[usize::from(neighbours(image, x, y))] {
                    marks.set(x, y);
                    any = true;
                }
            }
        }
    }
    if any {
        for y in window.y0..window.y1 {
            for k in window.k0..window.k1 {
                let m = marks.row(y).get(k).copied().unwrap_or(0);
                if let Some(w) = image.row_mut(y).get_mut(k) {
                    *w &= !m;
                }
            }
        }
    }
    any
}

#[cfg(test)]
mod tests {
    use super::*;

    fn skeleton_of(picture: &[&str], method: SkeletonMethod) -> Vec<String> {
        let input = BitImage::from_ascii(picture);
        let (w, h) = (input.width(), input.height());
        let mut skeleton = BitImage::with_dimensions(w, h);
        let mut scratch = SkeletonScratch::new(w, h);
        skeletonize(
            method,
            &input,
            &mut skeleton,
            &mut scratch,
            input.full_window(),
        );
        skeleton.to_ascii()
    }

    #[test]
    fn thinning_a_bar_leaves_its_centre_line() {
        let bar = [
            "..............",
            ".############.",
            ".############.",
            ".############.",
            "..............",
        ];
        let got = skeleton_of(&bar, SkeletonMethod::Thinning);
        assert_eq!(got[0], "..............");
        assert_eq!(got[1], "..............");
        assert_eq!(got[3], "..............");
        // One connected line along the bar's centre row, shortened at most two pixels per end.
        let line = got[2].trim_matches('.');
        assert!(!line.contains('.') && line.len() >= 8, "{got:#?}");
    }

    #[test]
    fn thinning_keeps_a_diagonal_streak_connected() {
        let streak = [
            "###.......",
            "####......",
            ".####.....",
            "..####....",
            "...####...",
            "....####..",
            ".....####.",
            "......###.",
        ];
        let got = skeleton_of(&streak, SkeletonMethod::Thinning);
        let skeleton = BitImage::from_ascii(&got.iter().map(String::as_str).collect::<Vec<_>>());
        // One pixel wide: no 2x2 block survives.
        for y in 0..7 {
            for x in 0..9 {
                let block = [(x, y), (x + 1, y), (x, y + 1), (x + 1, y + 1)];
                assert!(!block.iter().all(|&(a, b)| skeleton.get(a, b)), "{got:#?}");
            }
        }
        // Connected: one blob.
        let mut labeler = super::super::blobs::Labeler::new();
        labeler.label(&skeleton);
        assert_eq!(labeler.blobs().len(), 1, "{got:#?}");
        assert!(skeleton.count_ones() >= 6, "{got:#?}");
    }

    #[test]
    fn the_seeds_skeleton_stays_inside_the_input() {
        let blob = [
            "...............",
            "...............",
            "...............",
            "......###......",
            ".....#####.....",
            ".....#####.....",
            ".....#####.....",
            "......###......",
            "...............",
            "...............",
            "...............",
        ];
        let got = skeleton_of(&blob, SkeletonMethod::Morphological);
        let input = BitImage::from_ascii(&blob);
        let skeleton = BitImage::from_ascii(&got.iter().map(String::as_str).collect::<Vec<_>>());
        assert!(skeleton.count_ones() > 0);
        for y in 0..input.height() {
            for x in 0..input.width() {
                assert!(!skeleton.get(x, y) || input.get(x, y), "{got:#?}");
            }
        }
        // The blob's centre lies on its skeleton.
        assert!(skeleton.get(7, 5), "{got:#?}");
    }

    #[test]
    fn the_deletion_tables_keep_line_ends_and_bridges() {
        // An end point (one neighbour) and a bridge (two separate neighbours) stay.
        assert!(!DELETE_FIRST[0b0000_0001]);
        assert!(!DELETE_FIRST[0b0001_0001]);
        // A pixel on the west edge of a thick region goes in the first sub-iteration:
        // N, NE, E, SE, S set.
        assert!(DELETE_FIRST[0b0001_1111]);
    }
}
