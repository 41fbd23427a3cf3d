//! Outer borders of dark regions in the threshold mask, by Moore-neighbour tracing.
//!
//! The raster scan starts a trace at every dark pixel with light on its left that no earlier
//! trace has visited. Each trace walks the region's border clockwise (on screen, y down) and
//! marks the pixels it visits, so each border is followed once. Borders of holes run the other
//! way round; the caller drops them by the sign of their area. The contour buffer is allocated
//! once; a border longer than it is still walked to its end (so that none of its pixels starts
//! another trace) but not kept, since no marker the detector accepts is that long.
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

/// Index in [`STEPS`] of a unit step, or `None` for `(0, 0)` and longer steps.
fn step_index(dx: i32, dy: i32) -> Option<usize> {
    STEPS.iter().position(|&s| s == (dx, dy))
}

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
/// the budget ran out (some borders were not traced).
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
    if mask.len() < width * height {
        return true;
    }
    for y in 0..height {
        let mut x = 0;
        while x < width {
            // Most of the mask is light: skip it eight pixels at a time.
            let i = y * width + x;
            if x + SKIP_BYTES <= width {
                if let Some(chunk) = mask.get(i..i + SKIP_BYTES) {
                    let mut word = [0u8; SKIP_BYTES];
                    word.copy_from_slice(chunk);
                    if u64::from_ne_bytes(word) == 0 {
                        x += SKIP_BYTES;
                        continue;
                    }
                }
            }
            let starts_border =
                mask.get(i) == Some(&DARK) && (x == 0 || mask.get(i - 1) == Some(&LIGHT));
            if starts_border {
                contour.clear();
                let start = (x as i32, y as i32);
                match follow(mask, width, height, start, contour, max_len, steps_left) {
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

/// Whether `(x, y)` is a dark (possibly visited) pixel inside the mask.
fn is_dark(mask: &[u8], width: usize, height: usize, x: i32, y: i32) -> bool {
    x >= 0
        && y >= 0
        && (x as usize) < width
        && (y as usize) < height
        && mask
            .get(y as usize * width + x as usize)
            .is_some_and(|&m| m != LIGHT)
}

/// Follows the border through `start` (whose west neighbour is light), marking it visited, and
/// keeps its first `max_len` pixels in `contour`.
fn follow(
    mask: &mut [u8],
    width: usize,
    height: usize,
    start: (i32, i32),
    contour: &mut Vec<(i32, i32)>,
    max_len: usize,
    steps_left: &mut usize,
) -> Trace {
    let mark = |mask: &mut [u8], (x, y): (i32, i32)| {
        if let Some(m) = mask.get_mut(y as usize * width + x as usize) {
            *m = VISITED;
        }
    };
    mark(mask, start);
    contour.push(start);
    let mut cur = start;
    // Direction from `cur` to the light neighbour the search starts after.
    let mut back = WEST;
    let mut first_move: Option<(i32, i32)> = None;
    let mut len = 1usize;
    loop {
        if *steps_left == 0 {
            return Trace::OutOfBudget;
        }
        *steps_left -= 1;
        let mut next = None;
        for k in 1..=8 {
            let d = (back + k) % 8;
            let (dx, dy) = STEPS[d];
            if is_dark(mask, width, height, cur.0 + dx, cur.1 + dy) {
                let n = (cur.0 + dx, cur.1 + dy);
                // The neighbour checked just before `d` was light: it is the new backtrack.
                let (px, py) = STEPS[(d + 7) % 8];
                back = step_index(cur.0 + px - n.0, cur.1 + py - n.1).unwrap_or(WEST);
                next = Some(n);
                break;
            }
        }
        let Some(n) = next else {
            return Trace::Closed; // an isolated pixel
        };
        if cur == start {
            match first_move {
                None => first_move = Some(n),
                Some(f) if f == n => {
                    if len > max_len {
                        return Trace::TooLong;
                    }
                    contour.pop(); // `start` was pushed again on arrival
                    return Trace::Closed;
                }
                Some(_) => {}
            }
        }
        mark(mask, n);
        len += 1;
        if contour.len() < max_len {
            contour.push(n);
        }
        cur = n;
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
        let found = outer_borders(&["##....#", "##...#.", "......#", "...#..."]);
        // The 2x2 block only: the one-pixel-wide diagonal chain and the single pixel enclose
        // no area, so they are no polygons.
        assert_eq!(found, [vec![(0, 0), (1, 0), (1, 1), (0, 1)]]);
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
