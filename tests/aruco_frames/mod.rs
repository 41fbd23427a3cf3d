//! Adversarial frames for the marker detector's cost bound (issue 13): shapes that make a naive
//! contour tracer or candidate decoder explode. Shared by `tests/aruco_bounded.rs` and
//! `benches/aruco.rs`; every frame is luma, `width × height`, row-major.

#![allow(dead_code)] // each user takes its own subset

use glint::detect::aruco::Dictionary;

/// One dark arm winding out from the centre: a single border as long as the frame allows.
pub fn spiral(width: usize, height: usize, period_px: f64) -> Vec<u8> {
    let (cx, cy) = (width as f64 / 2.0, height as f64 / 2.0);
    (0..width * height)
        .map(|i| {
            let (x, y) = ((i % width) as f64 - cx, (i / width) as f64 - cy);
            let turns = y.atan2(x) / std::f64::consts::TAU;
            let phase = (x.hypot(y) / period_px - turns).rem_euclid(1.0);
            if phase < 0.5 {
                30
            } else {
                220
            }
        })
        .collect()
}

/// Independent uniform luma in every pixel (seeded xorshift): countless tiny regions.
pub fn speckle(width: usize, height: usize, seed: u64) -> Vec<u8> {
    let mut s = seed | 1;
    (0..width * height)
        .map(|_| {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 56) as u8
        })
        .collect()
}

/// Speckle in `block_px` squares: blotches that join into a maze of long, winding borders.
pub fn blotches(width: usize, height: usize, block_px: usize, seed: u64) -> Vec<u8> {
    let (bw, bh) = (width.div_ceil(block_px), height.div_ceil(block_px));
    let blocks = speckle(bw, bh, seed);
    (0..width * height)
        .map(|i| blocks[(i / width / block_px) * bw + i % width / block_px])
        .collect()
}

/// A checkerboard of `cell_px` squares: dark squares touch at their corners.
pub fn checkerboard(width: usize, height: usize, cell_px: usize) -> Vec<u8> {
    (0..width * height)
        .map(|i| {
            let (x, y) = (i % width / cell_px, i / width / cell_px);
            if (x + y) % 2 == 0 {
                30
            } else {
                220
            }
        })
        .collect()
}

/// Separate dark squares of `side_px` on a `pitch_px` grid: every one a quadrilateral candidate.
pub fn squares(width: usize, height: usize, side_px: usize, pitch_px: usize) -> Vec<u8> {
    (0..width * height)
        .map(|i| {
            let (x, y) = (i % width % pitch_px, i / width % pitch_px);
            if x < side_px && y < side_px {
                30
            } else {
                220
            }
        })
        .collect()
}

/// Draws marker `id` upright with `cell_px` cells and its top-left outer corner at `(x0, y0)`,
/// on a white margin one cell wide.
pub fn paste_marker(
    luma: &mut [u8],
    width: usize,
    dict: Dictionary,
    id: u16,
    (x0, y0): (usize, usize),
    cell_px: usize,
) {
    let n = dict.marker_bits();
    let cells = n + 2;
    for gy in 0..cells + 2 {
        for gx in 0..cells + 2 {
            // Grid cells −1 and `cells` are the white margin; 0 and `cells − 1` the black border.
            let (row, col) = (gy as isize - 1, gx as isize - 1);
            let inner = |v: isize| (1..=n as isize).contains(&v);
            let white = if row < 0 || col < 0 || row >= cells as isize || col >= cells as isize {
                true
            } else if inner(row) && inner(col) {
                dict.is_white(id, row as usize - 1, col as usize - 1)
                    .unwrap_or(false)
            } else {
                false
            };
            let value = if white { 220 } else { 30 };
            for py in 0..cell_px {
                for px in 0..cell_px {
                    let x = (x0 + gx * cell_px + px).checked_sub(cell_px);
                    let y = (y0 + gy * cell_px + py).checked_sub(cell_px);
                    if let (Some(x), Some(y)) = (x, y) {
                        if let Some(p) = luma.get_mut(y * width + x).filter(|_| x < width) {
                            *p = value;
                        }
                    }
                }
            }
        }
    }
}

/// Luma as YUYV bytes (grey chroma).
pub fn to_yuyv(luma: &[u8]) -> Vec<u8> {
    luma.iter().flat_map(|&l| [l, 128]).collect()
}
