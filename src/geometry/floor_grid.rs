//! The floor's grid as the camera sees it: lines every [`GRID_SPACING_CM`] on the floor, each
//! sampled along its length and projected through the lens and pose to pixels, for the preview
//! to draw over the picture. Where the calibration fits, the grid lies flat and square on the
//! floor in the picture, bent exactly as the lens bends it; where it does not (a wrong lens, a
//! knocked camera not yet refitted), it visibly slides off the markers.
//!
//! Only points are projected, never the image. The output is one flat list of points with a
//! `(NaN, NaN)` between polylines, filled into a buffer allocated once: a refit on the tracking
//! thread redraws it without allocating.

use super::camera::CameraModel;
use super::homography::Point;
use crate::frame::FrameSize;

/// The grid's spacing on the floor, cm (the calibration file's unit).
pub const GRID_SPACING_CM: f64 = 10.0;
/// Points at most in a grid: room for a floor of about 4 × 4 m in view at
/// `SAMPLE_STEP_CM`, and the capacity to allocate for [`floor_grid_px`].
pub const MAX_GRID_POINTS: usize = 8192;
/// Samples along each line, cm: short enough that a straight segment between two follows the
/// lens's curve to well under a pixel at webcam distances.
const SAMPLE_STEP_CM: f64 = 2.5;
/// Pixels between the frame's edge samples when finding the floor area in view.
const EDGE_STEP_PX: f64 = 16.0;
/// Farthest floor distance drawn from the point below the camera, cm: towards the horizon the
/// grid's squares shrink below a pixel and say nothing.
const MAX_REACH_CM: f64 = 2000.0;

/// A point separating two polylines.
pub const BREAK: (f32, f32) = (f32::NAN, f32::NAN);

/// Fills `out` (cleared first; never grown past its capacity) with the floor grid of `camera`
/// for frames of `size`: polylines of the grid's lines, in pixels, separated by [`BREAK`],
/// each cut where it leaves the frame. A grid that does not fit the capacity is cut short.
pub fn floor_grid_px(camera: &CameraModel, size: FrameSize, out: &mut Vec<(f32, f32)>) {
    out.clear();
    let Some((lo, hi)) = floor_in_view(camera, size) else {
        return;
    };
    let (w, h) = (size.width() as f64, size.height() as f64);
    let inside = |p: &Point| (-0.5..=w - 0.5).contains(&p.x) && (-0.5..=h - 0.5).contains(&p.y);
    let first = |a: f64| (a / GRID_SPACING_CM).ceil() as i64;
    let last = |b: f64| (b / GRID_SPACING_CM).floor() as i64;
    // Lines of constant x, then of constant y; each sampled from lo to hi along the other axis.
    for along_y in [true, false] {
        let (from, to) = if along_y { (lo.x, hi.x) } else { (lo.y, hi.y) };
        let (start, end) = if along_y { (lo.y, hi.y) } else { (lo.x, hi.x) };
        let samples = ((end - start) / SAMPLE_STEP_CM).ceil().max(1.0) as i64;
        for k in first(from)..=last(to) {
            let fixed = k as f64 * GRID_SPACING_CM;
            let mut open = false;
            for s in 0..=samples {
                let t = start + (end - start) * s as f64 / samples as f64;
                let floor = if along_y {
                    Point::new(fixed, t)
                } else {
                    Point::new(t, fixed)
                };
                let px = camera.project(&floor, 0.0).ok().filter(inside);
                match px {
                    Some(p) => {
                        if out.len() == out.capacity() {
                            return;
                        }
                        out.push((p.x as f32, p.y as f32));
                        open = true;
                    }
                    None if open => {
                        if out.len() == out.capacity() {
                            return;
                        }
                        out.push(BREAK);
                        open = false;
                    }
                    None => {}
                }
            }
            if open && out.len() < out.capacity() {
                out.push(BREAK);
            }
        }
    }
}

/// The floor rectangle (least and greatest corner, cm) seen inside the frame: the frame's edge
/// mapped to the floor, bounded by [`MAX_REACH_CM`] around the point below the camera.
fn floor_in_view(camera: &CameraModel, size: FrameSize) -> Option<(Point, Point)> {
    let (w, h) = (size.width() as f64 - 0.5, size.height() as f64 - 0.5);
    let foot = camera.pose.centre();
    let (mut lo, mut hi) = (
        Point::new(f64::INFINITY, f64::INFINITY),
        Point::new(f64::NEG_INFINITY, f64::NEG_INFINITY),
    );
    let mut grow = |px: Point| {
        if let Ok(f) = camera.floor_point(&px, 0.0) {
            let f = Point::new(
                f.x.clamp(foot.x - MAX_REACH_CM, foot.x + MAX_REACH_CM),
                f.y.clamp(foot.y - MAX_REACH_CM, foot.y + MAX_REACH_CM),
            );
            lo = Point::new(lo.x.min(f.x), lo.y.min(f.y));
            hi = Point::new(hi.x.max(f.x), hi.y.max(f.y));
        }
    };
    let (nx, ny) = ((w / EDGE_STEP_PX).ceil(), (h / EDGE_STEP_PX).ceil());
    for i in 0..=nx as u32 {
        let x = -0.5 + (w + 0.5) * f64::from(i) / nx;
        grow(Point::new(x, -0.5));
        grow(Point::new(x, h));
    }
    for j in 0..=ny as u32 {
        let y = -0.5 + (h + 0.5) * f64::from(j) / ny;
        grow(Point::new(-0.5, y));
        grow(Point::new(w, y));
    }
    (lo.x.is_finite() && lo.y.is_finite() && hi.x > lo.x && hi.y > lo.y).then_some((lo, hi))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::camera::{Lens, Pose};
    use nalgebra::Vector3;

    /// The wide-angle lens of the accuracy targets (or none) over the reference pose.
    fn camera(wide: bool) -> CameraModel {
        let centre = Vector3::new(10.0, -70.0, -130.0);
        let (k1, k2) = if wide { (-0.3, 0.09) } else { (0.0, 0.0) };
        let lens = Lens {
            k1,
            k2,
            ..Lens::ideal(460.0, 460.0, 319.5, 239.5)
        };
        lens.check(vga()).unwrap();
        CameraModel {
            lens,
            pose: Pose::looking_at(centre, Vector3::new(10.0, -5.0, 0.0)).unwrap(),
        }
    }

    fn vga() -> FrameSize {
        FrameSize::new(640, 480).unwrap()
    }

    #[test]
    fn every_point_lies_on_a_grid_line_inside_the_frame_and_the_buffer_never_grows() {
        let cam = camera(true);
        let mut out = Vec::with_capacity(MAX_GRID_POINTS);
        let before = out.as_ptr();
        floor_grid_px(&cam, vga(), &mut out);
        assert_eq!(out.as_ptr(), before, "no reallocation");
        let points: Vec<_> = out.iter().filter(|p| !p.0.is_nan()).collect();
        assert!(points.len() > 500, "{}", points.len());
        for &&(x, y) in &points {
            assert!((-0.5..=639.5).contains(&x) && (-0.5..=479.5).contains(&y));
            let f = cam
                .floor_point(&Point::new(f64::from(x), f64::from(y)), 0.0)
                .unwrap();
            let off = |v: f64| (v / GRID_SPACING_CM - (v / GRID_SPACING_CM).round()).abs();
            assert!(
                off(f.x).min(off(f.y)) * GRID_SPACING_CM < 0.01,
                "({x}, {y}) is floor {f:?}"
            );
        }
        // A polyline's consecutive points are close (the lens's curve is followed).
        for pair in out.windows(2) {
            if !pair[0].0.is_nan() && !pair[1].0.is_nan() {
                let d = (pair[0].0 - pair[1].0).hypot(pair[0].1 - pair[1].1);
                assert!(d < 20.0, "{pair:?}");
            }
        }
        // A small buffer is filled to its capacity and no further.
        let mut small = Vec::with_capacity(100);
        floor_grid_px(&cam, vga(), &mut small);
        assert_eq!(small.len(), 100);
        assert_eq!(small.capacity(), 100);
    }

    #[test]
    fn the_lens_bends_the_grid() {
        let (mut bent, mut straight) = (Vec::with_capacity(MAX_GRID_POINTS), Vec::new());
        straight.reserve(MAX_GRID_POINTS);
        floor_grid_px(&camera(true), vga(), &mut bent);
        floor_grid_px(&camera(false), vga(), &mut straight);
        assert_ne!(bent.len(), 0);
        // The same floor lines, drawn elsewhere near the corners: more of the floor is in view
        // through the barrel lens.
        assert!(
            bent.len() > straight.len(),
            "{} {}",
            bent.len(),
            straight.len()
        );
    }
}
