//! Perspective sampling of a candidate's cell grid into bits.
//!
//! The four corners fix a homography from grid cells to the image, so each cell is sampled where
//! perspective really puts it, at a few points around its centre (away from the blur at its
//! edges). Each cell's brightness is divided by the light falling on it, measured on the white
//! margin around the marker, so a shadow across the marker doesn't turn white cells black; then
//! cells are split into black and white by Otsu's threshold. The border ring must be black; the inner cells become the
//! bits, first cell in the most significant bit, white as 1.

use crate::frame::Frame;
use crate::geometry::{Homography, Point};

/// Largest grid side handled: 7×7 bits plus the border.
pub const MAX_GRID_CELLS: usize = 9;
/// Sample offsets inside a cell, as a share of the cell, either side of its centre.
const SAMPLE_OFFSETS: [f64; 3] = [-0.2, 0.0, 0.2];
/// Least brightness difference between the black and white cells' means.
pub const MIN_CELL_CONTRAST: f64 = 20.0;
/// A white margin is at least this many times brighter than the black border next to it.
const MARGIN_TO_BORDER_RATIO: f64 = 1.5;
/// Share of border cells allowed to read white (OpenCV allows 0.35; a tighter bound rejects
/// more of a textured floor's false candidates).
const MAX_BORDER_ERROR_RATE: f64 = 0.1;

/// Why a candidate's grid is not a marker.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum GridRejection {
    /// Cells could not be sampled (the grid leaves the frame, or degenerate corners).
    Unsampled,
    /// Black and white cells are not distinguishable.
    LowContrast,
    /// The border ring is not black.
    Border,
}

/// Samples an `bits`×`bits` marker (plus border) inside `corners` (clockwise, frame pixels).
pub fn read_bits(
    frame: &Frame<'_>,
    corners: &[Point; 4],
    bits: usize,
) -> Result<u64, GridRejection> {
    let cells = bits + 2;
    if cells > MAX_GRID_CELLS {
        return Err(GridRejection::Unsampled);
    }
    let side = cells as f64;
    let grid = [
        Point::new(0.0, 0.0),
        Point::new(side, 0.0),
        Point::new(side, side),
        Point::new(0.0, side),
    ];
    let to_image = Homography::from_four(&grid, corners).map_err(|_| GridRejection::Unsampled)?;
    // Mean luma of the cell whose top-left grid corner is (col, row); -1 and `cells` reach
    // one cell into the white margin around the marker.
    let cell_mean = |col: f64, row: f64| -> Option<f64> {
        let mut sum = 0.0;
        for dy in SAMPLE_OFFSETS {
            for dx in SAMPLE_OFFSETS {
                let g = Point::new(col + 0.5 + dx, row + 0.5 + dy);
                let p = to_image.apply(&g).ok()?;
                sum += luma_bilinear(frame, p.x, p.y)?;
            }
        }
        Some(sum / (SAMPLE_OFFSETS.len() * SAMPLE_OFFSETS.len()) as f64)
    };
    let mut raw = [0.0f64; MAX_GRID_CELLS * MAX_GRID_CELLS];
    for row in 0..cells {
        for col in 0..cells {
            raw[row * cells + col] =
                cell_mean(col as f64, row as f64).ok_or(GridRejection::Unsampled)?;
        }
    }
    let raw = &raw[..cells * cells];
    // No split of cells this flat can reach the contrast asked for below: stop before sampling
    // the margin (most candidates in a cluttered frame are flat dark shapes).
    let (lo, hi) = raw
        .iter()
        .fold((f64::MAX, f64::MIN), |(lo, hi), &v| (lo.min(v), hi.max(v)));
    if hi - lo < MIN_CELL_CONTRAST {
        return Err(GridRejection::LowContrast);
    }
    let mut normalised = [0.0f64; MAX_GRID_CELLS * MAX_GRID_CELLS];
    let normalised = &mut normalised[..cells * cells];
    if !normalise_by_margin(raw, cells, &cell_mean, normalised) {
        normalised.copy_from_slice(raw);
    }
    let threshold = otsu_threshold(normalised).ok_or(GridRejection::LowContrast)?;

    let (mut dark_sum, mut dark_n, mut light_sum, mut light_n) = (0.0, 0.0, 0.0, 0.0);
    let mut border_white = 0usize;
    let mut code = 0u64;
    for row in 0..cells {
        for col in 0..cells {
            let i = row * cells + col;
            let white = normalised[i] > threshold;
            if white {
                light_sum += raw[i];
                light_n += 1.0;
            } else {
                dark_sum += raw[i];
                dark_n += 1.0;
            }
            let on_border = row == 0 || col == 0 || row == cells - 1 || col == cells - 1;
            if on_border {
                border_white += usize::from(white);
            } else {
                code = code << 1 | u64::from(white);
            }
        }
    }
    if light_n == 0.0
        || dark_n == 0.0
        || light_sum / light_n - dark_sum / dark_n < MIN_CELL_CONTRAST
    {
        return Err(GridRejection::LowContrast);
    }
    let border_cells = 4 * (cells - 1);
    if border_white as f64 > MAX_BORDER_ERROR_RATE * border_cells as f64 {
        return Err(GridRejection::Border);
    }
    Ok(code)
}

/// Divides each cell by the light falling on it, estimated from the white margin just outside
/// the border: the four margin cells in line with it, nearer ones weighing more. A shadow across
/// the marker then no longer makes shadowed white cells look like black ones. Returns false
/// (leaving `out` unspecified) when the margin can't be sampled or is not clearly brighter than
/// the black border, i.e. there is no white margin to measure the light by.
fn normalise_by_margin(
    raw: &[f64],
    cells: usize,
    cell_mean: &impl Fn(f64, f64) -> Option<f64>,
    out: &mut [f64],
) -> bool {
    let mut top = [0.0f64; MAX_GRID_CELLS];
    let mut bottom = [0.0f64; MAX_GRID_CELLS];
    let mut left = [0.0f64; MAX_GRID_CELLS];
    let mut right = [0.0f64; MAX_GRID_CELLS];
    let last = cells - 1;
    let outside = cells as f64;
    for k in 0..cells {
        let kf = k as f64;
        let samples = (
            cell_mean(kf, -1.0),
            cell_mean(kf, outside),
            cell_mean(-1.0, kf),
            cell_mean(outside, kf),
        );
        let (Some(t), Some(b), Some(l), Some(r)) = samples else {
            return false;
        };
        let clearly_brighter = |margin: f64, border: f64| margin > MARGIN_TO_BORDER_RATIO * border;
        if !(clearly_brighter(t, raw[k])
            && clearly_brighter(b, raw[last * cells + k])
            && clearly_brighter(l, raw[k * cells])
            && clearly_brighter(r, raw[k * cells + last]))
        {
            return false;
        }
        (top[k], bottom[k], left[k], right[k]) = (t, b, l, r);
    }
    for row in 0..cells {
        for col in 0..cells {
            let weights = [
                1.0 / (row + 1) as f64,
                1.0 / (cells - row) as f64,
                1.0 / (col + 1) as f64,
                1.0 / (cells - col) as f64,
            ];
            let light = weights[0] * top[col]
                + weights[1] * bottom[col]
                + weights[2] * left[row]
                + weights[3] * right[row];
            out[row * cells + col] = raw[row * cells + col] * weights.iter().sum::<f64>() / light;
        }
    }
    true
}

/// Otsu's threshold: the split of the sorted values that maximises the between-class variance.
fn otsu_threshold(values: &[f64]) -> Option<f64> {
    let mut sorted = [0.0f64; MAX_GRID_CELLS * MAX_GRID_CELLS];
    let sorted = sorted.get_mut(..values.len())?;
    sorted.copy_from_slice(values);
    sorted.sort_unstable_by(f64::total_cmp);
    let n = sorted.len();
    let total: f64 = sorted.iter().sum();
    let mut best = (0.0, None);
    let mut below = 0.0;
    for k in 1..n {
        below += sorted[k - 1];
        let (n0, n1) = (k as f64, (n - k) as f64);
        let (m0, m1) = (below / n0, (total - below) / n1);
        let score = n0 * n1 * (m1 - m0) * (m1 - m0);
        if score > best.0 {
            best = (score, Some(k));
        }
    }
    let k = best.1?;
    Some(0.5 * (sorted[k - 1] + sorted[k]))
}

/// Luma at a sub-pixel position (pixel centres at integer coordinates), bilinear; `None` if any
/// of the four neighbours is outside the frame.
pub fn luma_bilinear(frame: &Frame<'_>, x: f64, y: f64) -> Option<f64> {
    if !(x >= 0.0 && y >= 0.0) {
        return None;
    }
    let (x0, y0) = (x as usize, y as usize);
    let (fx, fy) = (x - x0 as f64, y - y0 as f64);
    let l = |xi: usize, yi: usize| frame.luma(xi, yi).map(f64::from);
    let (a, b) = (l(x0, y0)?, l(x0 + 1, y0)?);
    let (c, d) = (l(x0, y0 + 1)?, l(x0 + 1, y0 + 1)?);
    Some((a + (b - a) * fx) * (1.0 - fy) + (c + (d - c) * fx) * fy)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::FrameSize;

    /// A frame with `pattern` drawn square, `cell_px` per cell, `margin_px` of white around.
    fn frame_bytes(
        pattern: &[&str],
        cell_px: usize,
        margin_px: usize,
        dark: u8,
        light: u8,
    ) -> (Vec<u8>, usize) {
        let cells = pattern.len();
        let side = cells * cell_px + 2 * margin_px;
        let mut out = Vec::new();
        for y in 0..side {
            for x in 0..side {
                let inside = margin_px..margin_px + cells * cell_px;
                let l = if inside.contains(&x) && inside.contains(&y) {
                    let c =
                        pattern[(y - margin_px) / cell_px].as_bytes()[(x - margin_px) / cell_px];
                    if c == b'#' {
                        dark
                    } else {
                        light
                    }
                } else {
                    light
                };
                out.extend([l, 128]);
            }
        }
        (out, side)
    }

    const MARKER: [&str; 6] = ["######", "#.#..#", "##.#.#", "#...##", "#.####", "######"];

    #[test]
    fn reads_the_bits_of_a_low_contrast_studio_range_marker() {
        let (bytes, side) = frame_bytes(&MARKER, 8, 8, 40, 90);
        let frame = Frame::new_checked(
            &bytes,
            FrameSize::new(side as u32, side as u32).unwrap(),
            2 * side,
        )
        .unwrap();
        let (a, b) = (7.5, 7.5 + 48.0);
        let corners = [
            Point::new(a, a),
            Point::new(b, a),
            Point::new(b, b),
            Point::new(a, b),
        ];
        // Inner rows .#.. / #.#. / ...# / .### with white = 1: 1011 0101 1110 1000.
        assert_eq!(read_bits(&frame, &corners, 4), Ok(0b1011_0101_1110_1000));
    }

    #[test]
    fn refuses_a_white_border_and_a_flat_patch() {
        let mut broken = MARKER;
        broken[0] = "#..###";
        broken[5] = "##..##";
        let (bytes, side) = frame_bytes(&broken, 8, 8, 20, 200);
        let size = FrameSize::new(side as u32, side as u32).unwrap();
        let frame = Frame::new_checked(&bytes, size, 2 * side).unwrap();
        let (a, b) = (7.5, 7.5 + 48.0);
        let corners = [
            Point::new(a, a),
            Point::new(b, a),
            Point::new(b, b),
            Point::new(a, b),
        ];
        assert_eq!(read_bits(&frame, &corners, 4), Err(GridRejection::Border));
        let (flat, _) = frame_bytes(&["######"; 6], 8, 8, 100, 110);
        let frame = Frame::new_checked(&flat, size, 2 * side).unwrap();
        assert_eq!(
            read_bits(&frame, &corners, 4),
            Err(GridRejection::LowContrast)
        );
    }
}
