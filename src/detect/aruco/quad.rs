//! Quadrilateral candidates: four corners that a traced border follows closely.
//!
//! Instead of a general polygon simplification, the four corners of a convex quadrilateral are
//! found directly: the border point farthest from any point is a corner, the point farthest
//! from that one is another, and the points farthest from the line through them on either side
//! are the other two. The border must then stay within a tolerance (OpenCV's
//! `polygonalApproxAccuracyRate` of the perimeter) of the four sides, and the quadrilateral must
//! be convex, large enough, and clear of the region's edge (a marker cut off there has no
//! trustworthy corners).

use crate::geometry::Point;

/// Allowed distance of border pixels from the fitted sides, as a share of the perimeter.
pub const APPROX_ACCURACY_RATE: f64 = 0.03;
/// Lower bound of that tolerance, in pixels: a pixel grid can't follow a line more closely.
const MIN_TOLERANCE_PX: f64 = 1.5;
/// Least sine of the turn at a corner: a flatter "corner" is a point on a straight side.
const MIN_TURN_SINE: f64 = 0.2;
/// Shortest side, as a share of the traced border's length (OpenCV's `minCornerDistanceRate`).
pub const MIN_SIDE_RATE: f64 = 0.05;
/// Shortest side in pixels, whatever the border's length: a grid of cells needs a few pixels.
pub const MIN_SIDE_PX: f64 = 4.0;

/// Limits a candidate must satisfy.
#[derive(Debug, Clone, Copy)]
pub struct QuadLimits {
    /// Closest a border pixel may come to the region's edge, in pixels.
    pub min_edge_distance_px: i32,
    /// Region size, in pixels.
    pub width_px: i32,
    pub height_px: i32,
}

/// Why a border is not a quadrilateral candidate.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Rejection {
    /// Not four straight sides (a blob, a triangle, a curve).
    NotQuad,
    /// Too small or too thin.
    TooSmall,
    /// Touches the frame or region edge, so it may be cut off.
    TouchesEdge,
}

/// Fits four corners to a clockwise border; corners come clockwise on screen.
pub fn fit_quad(border: &[(i32, i32)], limits: &QuadLimits) -> Result<[Point; 4], Rejection> {
    let n = border.len();
    let first = *border.first().ok_or(Rejection::NotQuad)?;
    let pt = |i: usize| {
        // Indices run at most one lap past the end; a subtraction is cheaper than a division.
        let i = if i < n {
            i
        } else if i < 2 * n {
            i - n
        } else {
            i % n
        };
        let (x, y) = border.get(i).copied().unwrap_or(first);
        Point::new(f64::from(x), f64::from(y))
    };
    let m = limits.min_edge_distance_px;
    if border
        .iter()
        .any(|&(x, y)| x < m || y < m || x >= limits.width_px - m || y >= limits.height_px - m)
    {
        return Err(Rejection::TouchesEdge);
    }
    let tolerance_px = (APPROX_ACCURACY_RATE * n as f64).max(MIN_TOLERANCE_PX);

    let farthest_from = |p: Point| {
        (0..n)
            .map(|i| (i, (pt(i) - p).norm_squared()))
            .fold((0, -1.0), |a, b| if b.1 > a.1 { b } else { a })
            .0
    };
    let a = farthest_from(Point::new(f64::from(first.0), f64::from(first.1)));
    let b = farthest_from(pt(a));
    let (lo, hi) = (a.min(b), a.max(b));
    // The two chains between `lo` and `hi`, and the point of each farthest from their chord.
    let (c, dc) = farthest_from_chord(&pt, lo, hi - lo);
    let (d, dd) = farthest_from_chord(&pt, hi, n - (hi - lo));
    let mut corners = match (dc > tolerance_px, dd > tolerance_px) {
        (true, true) => [lo, c, hi, d % n],
        // `lo` and `hi` are neighbours: both other corners lie on one chain.
        (true, false) => split_chain(&pt, lo, c, hi, n),
        (false, true) => split_chain(&pt, hi, d, lo + n, n),
        (false, false) => return Err(Rejection::NotQuad),
    };
    corners.sort_unstable();

    let mut out = [Point::origin(); 4];
    for (k, o) in out.iter_mut().enumerate() {
        *o = pt(corners[k]);
    }
    for k in 0..4 {
        let (from, to) = (corners[k], corners[(k + 1) % 4]);
        let len = (to + n - from) % n;
        let (_, dev) = farthest_from_chord(&pt, from, len);
        if dev > tolerance_px {
            return Err(Rejection::NotQuad);
        }
        let side = out[(k + 1) % 4] - out[k];
        let next = out[(k + 2) % 4] - out[(k + 1) % 4];
        // A corner must turn clockwise, and by more than a straight side's pixel jitter.
        if side.perp(&next) <= MIN_TURN_SINE * side.norm() * next.norm() {
            return Err(Rejection::NotQuad);
        }
    }
    let min_side_px = (MIN_SIDE_RATE * n as f64).max(MIN_SIDE_PX);
    if (0..4).any(|k| (out[(k + 1) % 4] - out[k]).norm() < min_side_px) {
        return Err(Rejection::TooSmall);
    }
    Ok(out)
}

/// The point of the chain `from ..= from + len` (indices modulo the border length) farthest
/// from the chord between its ends, and that distance in pixels.
fn farthest_from_chord(pt: &impl Fn(usize) -> Point, from: usize, len: usize) -> (usize, f64) {
    let (p, q) = (pt(from), pt(from + len));
    let dir = q - p;
    let norm = dir.norm();
    let mut best = (from, 0.0);
    for i in from..=from + len {
        let v = pt(i) - p;
        let dist = if norm > 0.0 {
            (dir.perp(&v) / norm).abs()
        } else {
            v.norm()
        };
        if dist > best.1 {
            best = (i, dist);
        }
    }
    best
}

/// Corners when `from` and `to` are adjacent corners and `mid` a corner on the chain between:
/// the fourth is the farther of the two sub-chains' farthest points.
fn split_chain(
    pt: &impl Fn(usize) -> Point,
    from: usize,
    mid: usize,
    to: usize,
    n: usize,
) -> [usize; 4] {
    let (e, de) = farthest_from_chord(pt, from, mid - from);
    let (f, df) = farthest_from_chord(pt, mid, to - mid);
    let fourth = if de >= df { e } else { f };
    [from % n, mid % n, to % n, fourth % n]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn limits() -> QuadLimits {
        QuadLimits {
            min_edge_distance_px: 2,
            width_px: 100,
            height_px: 100,
        }
    }

    /// The clockwise pixel border of a polygon, by walking its sides.
    fn border(corners: &[(i32, i32)]) -> Vec<(i32, i32)> {
        let mut out = Vec::new();
        for k in 0..corners.len() {
            let (a, b) = (corners[k], corners[(k + 1) % corners.len()]);
            let steps = (b.0 - a.0).abs().max((b.1 - a.1).abs());
            for s in 0..steps {
                let t = f64::from(s) / f64::from(steps);
                out.push((
                    (f64::from(a.0) + t * f64::from(b.0 - a.0)).round() as i32,
                    (f64::from(a.1) + t * f64::from(b.1 - a.1)).round() as i32,
                ));
            }
        }
        out
    }

    #[test]
    fn finds_the_corners_of_a_perspective_quad_from_any_start() {
        let corners = [(20, 10), (70, 18), (64, 60), (15, 50)];
        let b = border(&corners);
        for shift in [0, 13, 77] {
            let mut rotated = b.clone();
            rotated.rotate_left(shift);
            let q = fit_quad(&rotated, &limits()).unwrap();
            let mut got: Vec<(i32, i32)> = q.iter().map(|p| (p.x as i32, p.y as i32)).collect();
            let start = got.iter().position(|&c| c == corners[0]).unwrap();
            got.rotate_left(start);
            assert_eq!(got, corners);
        }
    }

    #[test]
    fn refuses_triangles_pentagons_edges_and_specks() {
        let tri = border(&[(20, 10), (70, 18), (40, 60)]);
        assert_eq!(fit_quad(&tri, &limits()), Err(Rejection::NotQuad));
        let penta = border(&[(40, 5), (75, 30), (62, 75), (18, 75), (5, 30)]);
        assert_eq!(fit_quad(&penta, &limits()), Err(Rejection::NotQuad));
        let cut = border(&[(0, 10), (40, 10), (40, 50), (0, 50)]);
        assert_eq!(fit_quad(&cut, &limits()), Err(Rejection::TouchesEdge));
        let speck = border(&[(10, 10), (13, 10), (13, 13), (10, 13)]);
        assert_eq!(fit_quad(&speck, &limits()), Err(Rejection::TooSmall));
    }
}
