//! Skeletons of a blob: the seed's morphological skeleton, and Guo–Hall thinning.
//!
//! The seed builds its skeleton from erosions and openings after five dilations, then masks it
//! with the input. On a streak a few pixels wide that yields a ragged, often broken line, so the
//! default is a proper thinning (Guo & Hall, 1989), which keeps the skeleton connected and one
//! pixel wide; that is what the walk to the streak's ends needs. Both run inside a window
//! around one blob, so their cost follows the blob, not the frame.

use super::bitimage::{BitImage, Window};
use super::morph::{self, from_left, from_right, Kernel};

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

#[inline(always)]
fn word_at(row: &[u64], k: usize) -> u64 {
    row.get(k).copied().unwrap_or(0)
}

#[inline(always)]
fn at_least_two(a: u64, b: u64, c: u64, d: u64) -> u64 {
    (a & b) | (a & c) | (a & d) | (b & c) | (b & d) | (c & d)
}

/// Guo–Hall's deletion test for the 64 pixels of word `k` of row `y`, all at once: bit `i`
/// of the result is set when pixel `64 k + i` is set and may be deleted in this
/// sub-iteration. Guo & Hall (1989) keep two-pixel-thick diagonal lines, which Zhang–Suen
/// erases completely; a diagonal LED streak is exactly such a line.
///
/// With the neighbours P2 (north) … P9 (north-west) clockwise, a pixel goes when
/// C = Σ ¬P2∧(P3∨P4), ¬P4∧(P5∨P6), ¬P6∧(P7∨P8), ¬P8∧(P9∨P2) is exactly 1, when
/// min(N1, N2) is 2 or 3 (N1, N2: the neighbour pairs OR-ed two ways and counted), and when
/// the sub-iteration's own term is 0.
#[inline]
fn deletable_word(image: &BitImage, y: usize, k: usize, second: bool) -> u64 {
    let mid = image.row(y);
    let centre = word_at(mid, k);
    if centre == 0 {
        return 0;
    }
    let up = y.checked_sub(1).map_or(&[][..], |u| image.row(u));
    let down = image.row(y + 1);
    let around = |row: &[u64]| {
        let w = word_at(row, k);
        let prev = k.checked_sub(1).map_or(0, |p| word_at(row, p));
        let next = word_at(row, k + 1);
        (from_left(w, prev), w, from_right(w, next))
    };
    let (p9, p2, p3) = around(up);
    let (p8, _, p4) = around(mid);
    let (p7, p6, p5) = around(down);

    let t = [
        !p2 & (p3 | p4),
        !p4 & (p5 | p6),
        !p6 & (p7 | p8),
        !p8 & (p9 | p2),
    ];
    let exactly_one_c = (t[0] | t[1] | t[2] | t[3]) & !at_least_two(t[0], t[1], t[2], t[3]);
    let n1 = [p9 | p2, p3 | p4, p5 | p6, p7 | p8];
    let n2 = [p2 | p3, p4 | p5, p6 | p7, p8 | p9];
    let all_four = |n: [u64; 4]| n[0] & n[1] & n[2] & n[3];
    let min_two_or_three = at_least_two(n1[0], n1[1], n1[2], n1[3])
        & at_least_two(n2[0], n2[1], n2[2], n2[3])
        & !(all_four(n1) & all_four(n2));
    let m = if second {
        (p2 | p3 | !p5) & p4
    } else {
        (p6 | p7 | !p9) & p8
    };
    centre & exactly_one_c & min_two_or_three & !m
}

/// Guo–Hall thinning of `image` in place, inside `window`, with `marks` as scratch.
pub fn thin(image: &mut BitImage, marks: &mut BitImage, window: Window) {
    // Each full pass peels at least one layer or stops; a blob is at most this many layers.
    let max_passes = (window.y1 - window.y0).max((window.k1 - window.k0) * 64) / 2 + 2;
    for _ in 0..max_passes {
        let first = thin_subiteration(image, marks, window, false);
        let second = thin_subiteration(image, marks, window, true);
        if !(first || second) {
            break;
        }
    }
}

fn thin_subiteration(
    image: &mut BitImage,
    marks: &mut BitImage,
    window: Window,
    second: bool,
) -> bool {
    let mut any = false;
    for y in window.y0..window.y1 {
        for k in window.k0..window.k1 {
            let deletions = deletable_word(image, y, k, second);
            any |= deletions != 0;
            if let Some(m) = marks.row_mut(y).get_mut(k) {
                *m = deletions;
            }
        }
    }
    if any {
        for y in window.y0..window.y1 {
            for k in window.k0..window.k1 {
                let m = word_at(marks.row(y), k);
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

    fn bit(n: u8, i: u32) -> u8 {
        (n >> i) & 1
    }

    /// Guo–Hall's rule for one pixel, written the way the paper states it: the reference the
    /// bit-parallel version is held to.
    fn deletable(n: u8, second: bool) -> bool {
        let (p2, p3, p4, p5) = (bit(n, 0), bit(n, 1), bit(n, 2), bit(n, 3));
        let (p6, p7, p8, p9) = (bit(n, 4), bit(n, 5), bit(n, 6), bit(n, 7));
        let c = ((1 - p2) & (p3 | p4))
            + ((1 - p4) & (p5 | p6))
            + ((1 - p6) & (p7 | p8))
            + ((1 - p8) & (p9 | p2));
        let n1 = (p9 | p2) + (p3 | p4) + (p5 | p6) + (p7 | p8);
        let n2 = (p2 | p3) + (p4 | p5) + (p6 | p7) + (p8 | p9);
        let m = if second {
            (p2 | p3 | (1 - p5)) & p4
        } else {
            (p6 | p7 | (1 - p9)) & p8
        };
        c == 1 && (2..=3).contains(&n1.min(n2)) && m == 0
    }

    #[test]
    fn the_word_rule_matches_the_papers_rule_for_every_neighbourhood() {
        // Ring order P2..P9 as (dx, dy) offsets from the centre.
        let ring = super::super::bitimage::NEIGHBOURS_8;
        // Centres on both sides of a word boundary, so the carries are exercised too.
        for cx in [1usize, 63, 64, 100] {
            for n in 0..=255u8 {
                let mut image = BitImage::with_dimensions(130, 3);
                image.set(cx, 1);
                for (i, (dx, dy)) in ring.iter().enumerate() {
                    if bit(n, i as u32) == 1 {
                        image.set(cx.wrapping_add_signed(*dx), 1usize.wrapping_add_signed(*dy));
                    }
                }
                for second in [false, true] {
                    let word = deletable_word(&image, 1, cx / 64, second);
                    let got = (word >> (cx % 64)) & 1 == 1;
                    assert_eq!(
                        got,
                        deletable(n, second),
                        "neighbours {n:08b}, x {cx}, second {second}"
                    );
                }
            }
        }
    }

    #[test]
    fn line_ends_and_bridges_stay() {
        // An end point (one neighbour) and a bridge (two separate neighbours) stay.
        assert!(!deletable(0b0000_0001, false));
        assert!(!deletable(0b0001_0001, false));
        // A pixel on the west edge of a thick region goes in the first sub-iteration:
        // N, NE, E, SE, S set.
        assert!(deletable(0b0001_1111, false));
    }
}
