//! Bilinearly interpolated luma, read along a walk.
//!
//! The ramps ([`super::tips`]), the level falls ([`super::level_falls`]) and the floor beside a
//! streak ([`super::ray_floor`]) read the light between pixel centres thousands of times a frame,
//! mostly in steps of a tenth of a pixel along a ray, so that about ten reads in a row fall in
//! the same cell of four pixels. Fetching a cell's two rows and four bytes (with their bounds
//! checks) cost several times the interpolation itself: on the fast-line scene these reads
//! were a third of the whole replay's instructions. A [`Walk`] keeps the last cell's corners
//! and fetches a cell only when a read leaves it; the interpolation is the same arithmetic as
//! [`luma_at`]'s, so a walk reads exactly the values single reads would.

use crate::frame::Frame;

/// The four pixels around a point: upper left, upper right, lower left, lower right.
type Corners = [f32; 4];

/// Bilinearly interpolated luma at `(x, y)`; `None` outside the frame (or on its last column
/// or row, which has no neighbour to interpolate towards).
pub fn luma_at(frame: &Frame<'_>, x: f32, y: f32) -> Option<f32> {
    let (cell, fraction) = cell_of(frame, x, y)?;
    Some(interpolate(&corners(frame, cell)?, fraction))
}

/// Reads of one frame's luma that reuse the last cell's pixels.
pub struct Walk<'f, 'a> {
    frame: &'f Frame<'a>,
    /// The cell last read: its upper left pixel, and its corners.
    cell_px: (f32, f32),
    corners: Corners,
}

impl<'f, 'a> Walk<'f, 'a> {
    /// A walk over `frame`, with no cell read yet.
    pub fn new(frame: &'f Frame<'a>) -> Self {
        Walk {
            frame,
            // No point lies within a cell at infinity: the first read fetches its cell.
            cell_px: (f32::INFINITY, f32::INFINITY),
            corners: [0.0; 4],
        }
    }

    /// As [`luma_at`]. A point in the last cell is read from its corners (its fractions are
    /// the same differences `luma_at` takes, since the cell's corner is where truncation puts
    /// it), and any other point fetches its cell.
    #[inline]
    pub fn luma_at(&mut self, x: f32, y: f32) -> Option<f32> {
        let fraction = (x - self.cell_px.0, y - self.cell_px.1);
        if (0.0..1.0).contains(&fraction.0) && (0.0..1.0).contains(&fraction.1) {
            return Some(interpolate(&self.corners, fraction));
        }
        self.enter(x, y)
    }

    /// Fetches the cell holding `(x, y)` and reads the point there.
    #[inline(never)]
    fn enter(&mut self, x: f32, y: f32) -> Option<f32> {
        let (cell, fraction) = cell_of(self.frame, x, y)?;
        self.corners = corners(self.frame, cell)?;
        self.cell_px = (cell.0 as f32, cell.1 as f32);
        Some(interpolate(&self.corners, fraction))
    }
}

/// The cell holding `(x, y)` (its upper left pixel) and the point's fractions across it; `None`
/// left of or above the frame, or where the cell's right column would lie outside it. The floor
/// is taken by truncation, the same for the non-negative coordinates read, where `floor` is a
/// library call on baseline x86-64 (no SSE4.1).
fn cell_of(frame: &Frame<'_>, x: f32, y: f32) -> Option<((usize, usize), (f32, f32))> {
    if x < 0.0 || y < 0.0 {
        return None;
    }
    let (x0, y0) = (x as usize, y as usize);
    if x0 >= frame.size().width().saturating_sub(1) {
        return None;
    }
    Some(((x0, y0), (x - x0 as f32, y - y0 as f32)))
}

/// The luma of the cell whose upper left pixel is `(x0, y0)`; `None` when its lower row lies
/// outside the frame.
fn corners(frame: &Frame<'_>, (x0, y0): (usize, usize)) -> Option<Corners> {
    let (upper, lower) = (frame.luma_row(y0)?, frame.luma_row(y0.checked_add(1)?)?);
    let (left, right) = (x0 * frame.luma_step(), (x0 + 1) * frame.luma_step());
    let p = |row: &[u8], i: usize| row.get(i).copied().map(f32::from);
    Some([
        p(upper, left)?,
        p(upper, right)?,
        p(lower, left)?,
        p(lower, right)?,
    ])
}

/// The light at `(fx, fy)` across a cell of `corners`: along the rows, then between them.
#[inline]
fn interpolate(
    &[upper_left, upper_right, lower_left, lower_right]: &Corners,
    (fx, fy): (f32, f32),
) -> f32 {
    let top = upper_left * (1.0 - fx) + upper_right * fx;
    let bottom = lower_left * (1.0 - fx) + lower_right * fx;
    top * (1.0 - fy) + bottom * fy
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::FrameSize;

    /// A walk reads exactly what single reads do, in any order, across cells and rows, and
    /// refuses the same points outside the frame.
    #[test]
    fn a_walk_reads_what_single_reads_do() {
        let (w, h) = (24u32, 17u32);
        // YUYV: luma in every other byte, chroma between.
        let bytes: Vec<u8> = (0..2 * w * h)
            .map(|i| {
                if i % 2 == 0 {
                    ((i * 97 + i / 7) % 251) as u8
                } else {
                    128
                }
            })
            .collect();
        let size = FrameSize::new(w, h).unwrap();
        let frame = Frame::new_checked(&bytes, size, size.row_bytes()).unwrap();
        let mut walk = Walk::new(&frame);
        let mut state = 12345u32;
        let mut outside = 0;
        for _ in 0..20_000 {
            state = state.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            // A point anywhere (some off the frame), then a short step from it, mostly within
            // the same cell.
            let x = (state >> 8) % 2600;
            let y = (state >> 20) % 1900;
            let (x, y) = (x as f32 / 100.0 - 1.0, y as f32 / 100.0 - 1.0);
            let single = luma_at(&frame, x, y);
            assert_eq!(walk.luma_at(x, y), single, "({x}, {y})");
            assert_eq!(walk.luma_at(x + 0.05, y), luma_at(&frame, x + 0.05, y));
            outside += usize::from(single.is_none());
        }
        assert!(
            outside > 1000,
            "{outside} reads outside: the test covers the edges"
        );
        // At a pixel centre the read is the pixel.
        assert_eq!(
            luma_at(&frame, 4.0, 3.0),
            Some(f32::from(bytes[2 * (3 * 24 + 4)]))
        );
    }
}
