//! Outer borders of dark regions in the threshold mask, by Moore-neighbour tracing.
//!
//! The raster scan starts a trace at every dark pixel with light on its left that no earlier
//! trace has visited. Each trace walks the region's border clockwise (on screen, y down) and
//! marks the pixels it visits, so each border is followed once. Borders of holes run the other
//! way round; the caller drops them by the sign of their area. The contour buffer is allocated
//! once; a border longer than it is still walked to its end (so that none of its pixels starts
//! another trace) but not kept, since no marker the detector accepts is that long.
//!
//! The mask's outermost ring is cleared first: a region reaching the frame's edge may be cut
//! off, so it is no marker anyway, and with the ring light every neighbour of a dark pixel lies
//! inside the mask, so a step is an index offset with no coordinate checks.
//!
//! The cost is bounded: every step of every trace is taken from a budget, and tracing stops when
//! it runs out (a frame of speckle or a maze has borders everywhere).

use super::threshold::{DARK, LIGHT};

/// A mask pixel already on a traced border.
const VISITED: u8 = 2;

/// The eight neighbours, clockwise on screen starting east.
const STEPS: [(i32, i32); 8] = [
    (1, 0),
    (1, 1),
    (0, 1),
    (-1, 1),
    (-1, 0),
    (-1, -1),
    (0, -1),
    (1, -1),
];
/// Mask bytes tested at once while scanning for dark pixels.
const SKIP_BYTES: usize = 8;
/// Index in [`STEPS`] of the west neighbour.
const WEST: usize = 4;

/// How one trace ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Trace {
    /// Back at its start: the border is in the contour buffer.
    Closed,
    /// Longer than the buffer: walked to its end, not kept.
    TooLong,
    /// The step budget ran out during the trace.
    OutOfBudget,
}

/// Traces every border of the mask, calling `on_contour` with each outer border's pixels
/// (clockwise on screen) that has between `min_len` and the contour buffer's capacity of pixels.
/// Each step of a trace takes one from `steps_left`; returns false if tracing stopped because
/// the budget ran out (some borders were not traced). Clears the mask's outermost ring.
pub fn trace_borders(
    mask: &mut [u8],
    width: usize,
    height: usize,
    min_len: usize,
    contour: &mut Vec<(i32, i32)>,
    steps_left: &mut usize,
    mut on_contour: impl FnMut(&[(i32, i32)]),
) -> bool {
    let max_len = contour.capacity();
    let Some(mask) = mask.get_mut(..width * height) else {
        return true;
    };
    if width < 3 || height < 3 {
        return true; // nothing inside the ring
    }
    clear_ring(mask, width, height);
    for y in 1..height - 1 {
        let mut x = 1;
        while x < width - 1 {
            // Most of the mask is light: skip it eight pixels at a time.
            let i = y * width + x;
            if let Some(chunk) = mask.get(i..i + SKIP_BYTES) {
                let mut word = [0u8; SKIP_BYTES];
                word.copy_from_slice(chunk);
                if u64::from_ne_bytes(word) == 0 {
                    x += SKIP_BYTES;
                    continue;
                }
            }
            let starts_border = mask.get(i) == Some(&DARK) && mask.get(i - 1) == Some(&LIGHT);
            if starts_border {
                contour.clear();
                let start = (x as i32, y as i32);
                match follow(mask, width, start, contour, max_len, steps_left) {
                    Trace::Closed if contour.len() >= min_len && signed_area2(contour) > 0 => {
                        on_contour(contour)
                    }
                    Trace::OutOfBudget => return false,
                    _ => {}
                }
            }
            x += 1;
        }
    }
    true
}

/// Sets the first and last row and column light.
fn clear_ring(mask: &mut [u8], width: usize, height: usize) {
    let last = (height - 1) * width;
    for i in (0..width).chain(last..last + width) {
        if let Some(m) = mask.get_mut(i) {
            *m = LIGHT;
        }
    }
    for y in 1..height - 1 {
        for i in [y * width, y * width + width - 1] {
            if let Some(m) = mask.get_mut(i) {
                *m = LIGHT;
            }
        }
    }
}

/// Follows the border through `start` (dark, not on the mask's light outer ring, with a light
/// west neighbour), marking it visited, and keeps its first `max_len` pixels in `contour`.
fn follow(
    mask: &mut [u8],
    width: usize,
    start: (i32, i32),
    contour: &mut Vec<(i32, i32)>,
    max_len: usize,
    steps_left: &mut usize,
) -> Trace {
    let w = width as isize;
    // Index offset of each of the eight steps.
    let offsets: [isize; 8] = [1, w + 1, w, w - 1, -1, -w - 1, -w, -w + 1];
    let index = |(x, y): (i32, i32)| y as usize * width + x as usize;
    let start_index = index(start);
    if let Some(m) = mask.get_mut(start_index) {
        *m = VISITED;
    }
    contour.push(start);
    let (mut cur, mut cur_index) = (start, start_index);
    // Direction from `cur` to the light neighbour the search starts after.
    let mut back = WEST;
    let mut first_move: Option<usize> = None;
    let mut len = 1usize;
    loop {
        if *steps_left == 0 {
            return Trace::OutOfBudget;
        }
        *steps_left -= 1;
        let mut next = None;
        for k in 1..=8 {
            let d = (back + k) % 8;
            let j = cur_index.wrapping_add_signed(offsets[d]);
            if matches!(mask.get(j), Some(&m) if m != LIGHT) {
                next = Some((d, j));
                break;
            }
        }
        let Some((d, n_index)) = next else {
            return Trace::Closed; // an isolated pixel
        };
        // The neighbour checked just before `d` was light: it is the new backtrack, seen
        // from the new pixel two (after a straight step) or three (after a diagonal) steps
        // back round from the direction of travel.
        back = if d % 2 == 0 { (d + 6) % 8 } else { (d + 5) % 8 };
        if cur_index == start_index {
            match first_move {
                None => first_move = Some(n_index),
                Some(f) if f == n_index => {
                    if len > max_len {
                        return Trace::TooLong;
                    }
                    contour.pop(); // `start` was pushed again on arrival
                    return Trace::Closed;
                }
                Some(_) => {}
            }
        }
        if let Some(m) = mask.get_mut(n_index) {
            *m = VISITED;
        }
        let (dx, dy) = STEPS[d];
        cur = (cur.0 + dx, cur.1 + dy);
        cur_index = n_index;
        len += 1;
        if contour.len() < max_len {
            contour.push(cur);
        }
    }
}

/// Twice the signed area of a closed polygon: positive when clockwise on screen (y down).
pub fn signed_area2(points: &[(i32, i32)]) -> i64 {
    let Some(&last) = points.last() else {
        return 0;
    };
    let mut prev = last;
    let mut sum = 0i64;
    for &p in points {
        sum += i64::from(prev.0) * i64::from(p.1) - i64::from(p.0) * i64::from(prev.1);
        prev = p;
    }
    sum
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mask(rows: &[&str]) -> (Vec<u8>, usize, usize) {
        let w = rows[0].len();
        let m = rows
            .iter()
            .flat_map(|r| r.chars().map(|c| if c == '#' { DARK } else { LIGHT }))
            .collect();
        (m, w, rows.len())
    }

    fn outer_borders(rows: &[&str]) -> Vec<Vec<(i32, i32)>> {
        let (mut m, w, h) = mask(rows);
        let mut buf = Vec::with_capacity(64);
        let mut out = Vec::new();
        let mut steps = usize::MAX;
        assert!(trace_borders(&mut m, w, h, 1, &mut buf, &mut steps, |c| {
            out.push(c.to_vec())
        }));
        out
    }

    #[test]
    fn a_ring_gives_its_outer_border_once_and_no_hole_border() {
        let found = outer_borders(&["......", ".####.", ".#..#.", ".####.", "......"]);
        assert_eq!(
            found,
            [vec![
                (1, 1),
                (2, 1),
                (3, 1),
                (4, 1),
                (4, 2),
                (4, 3),
                (3, 3),
                (2, 3),
                (1, 3),
                (1, 2)
            ]]
        );
    }

    #[test]
    fn separate_regions_and_diagonal_links() {
        let found = outer_borders(&[
            ".........",
            ".##....#.",
            ".##...#..",
            "......#..",
            "...#.....",
            ".........",
        ]);
        // The 2x2 block only: the one-pixel-wide diagonal chain and the single pixel enclose
        // no area, so they are no polygons.
        assert_eq!(found, [vec![(1, 1), (2, 1), (2, 2), (1, 2)]]);
    }

    #[test]
    fn regions_on_the_outer_ring_are_cut_to_their_inside() {
        // The block touching the top-left corner keeps only the pixels off the outer ring.
        let found = outer_borders(&["###...", "###...", "###...", "......"]);
        assert_eq!(found, [vec![(1, 1), (2, 1), (2, 2), (1, 2)]]);
    }

    #[test]
    fn borders_longer_than_the_buffer_are_dropped_and_walked_once() {
        let (mut m, w, h) = mask(&["........", ".######.", ".######.", "........"]);
        let mut buf = Vec::with_capacity(8);
        let mut n = 0;
        let mut steps = usize::MAX;
        assert!(trace_borders(&mut m, w, h, 1, &mut buf, &mut steps, |_| {
            n += 1
        }));
        assert_eq!(n, 0);
        // The whole border (12 pixels) was walked once and marked: no second trace started on it.
        assert_eq!(usize::MAX - steps, 13);
        assert_eq!(m.iter().filter(|&&p| p == VISITED).count(), 12);
    }

    #[test]
    fn tracing_stops_when_the_step_budget_runs_out() {
        let rows = ["........", ".##..##.", ".##..##.", "........"];
        let (mut m, w, h) = mask(&rows);
        let mut buf = Vec::with_capacity(64);
        let mut found = 0;
        let mut steps = 6; // the first square's border takes 5 steps
        assert!(!trace_borders(
            &mut m,
            w,
            h,
            1,
            &mut buf,
            &mut steps,
            |_| found += 1
        ));
        assert_eq!((found, steps), (1, 0));
        let (mut m, ..) = mask(&rows);
        let mut steps = 10;
        assert!(trace_borders(&mut m, w, h, 1, &mut buf, &mut steps, |_| {
            found += 1
        }));
        assert_eq!(found, 3);
    }
}
