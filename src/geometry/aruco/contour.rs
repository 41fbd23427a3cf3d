//! Outer borders of dark regions in the threshold mask, by Moore-neighbour tracing.
//!
//! The raster scan starts a trace at every dark pixel with light on its left that no earlier
//! trace has visited. Each trace walks the region's border clockwise (on screen, y down) and
//! marks the pixels it visits, so each border is followed once. Borders of holes run the other
//! way round; the caller drops them by the sign of their area. The contour buffer is allocated
//! once; a border longer than it is abandoned, since no marker the detector accepts is that long.

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

/// Traces every border of the mask, calling `on_contour` with each outer border's pixels
/// (clockwise on screen) that has between `min_len` and `max_len` pixels.
pub fn trace_borders(
    mask: &mut [u8],
    width: usize,
    height: usize,
    min_len: usize,
    contour: &mut Vec<(i32, i32)>,
    mut on_contour: impl FnMut(&[(i32, i32)]),
) {
    let max_len = contour.capacity();
    if mask.len() < width * height {
        return;
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
                let complete = follow(mask, width, height, (x as i32, y as i32), contour, max_len);
                if complete && contour.len() >= min_len && signed_area2(contour) > 0 {
                    on_contour(contour);
                }
            }
            x += 1;
        }
    }
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

/// Follows the border through `start` (whose west neighbour is light), marking it visited.
/// Returns false if the border is longer than `max_len`.
fn follow(
    mask: &mut [u8],
    width: usize,
    height: usize,
    start: (i32, i32),
    contour: &mut Vec<(i32, i32)>,
    max_len: usize,
) -> bool {
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
    loop {
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
            return true; // an isolated pixel
        };
        if cur == start {
            match first_move {
                None => first_move = Some(n),
                Some(f) if f == n => {
                    contour.pop(); // `start` was pushed again on arrival
                    return true;
                }
                Some(_) => {}
            }
        }
        if contour.len() >= max_len {
            return false;
        }
        mark(mask, n);
        contour.push(n);
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
        trace_borders(&mut m, w, h, 1, &mut buf, |c| out.push(c.to_vec()));
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
    fn borders_longer_than_the_buffer_are_dropped() {
        let (mut m, w, h) = mask(&["........", ".######.", ".######.", "........"]);
        let mut buf = Vec::with_capacity(8);
        let mut n = 0;
        trace_borders(&mut m, w, h, 1, &mut buf, |_| n += 1);
        assert_eq!(n, 0);
    }
}
