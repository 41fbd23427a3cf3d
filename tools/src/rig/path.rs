//! The planned path of the rig: the figure-eight `x = a sin φ, y = b sin 2φ` the firmware's
//! path follower drives (board/firmware/src/pursuit.rs holds the same formula in mm, in the
//! firmware's own crate), and the distance from a point to it: the path error.

use std::f64::consts::{FRAC_PI_4, TAU};

/// Straight segments the path is measured against: 4000 segments of a 3.7 m path are under a
/// millimetre long and depart from the curve by well under a micrometre.
const SEGMENTS: usize = 4_000;

/// A figure-eight centred on the floor origin.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FigureEight {
    /// Half the width (`a`), m.
    pub half_width_m: f64,
    /// Half the height (`b`), m.
    pub half_height_m: f64,
}

impl FigureEight {
    /// The rig's figure-eight: 1.2 m × 0.6 m.
    pub const RIG: FigureEight = FigureEight {
        half_width_m: 0.6,
        half_height_m: 0.3,
    };

    /// The point at phase `phi_rad`, m.
    pub fn point(&self, phi_rad: f64) -> (f64, f64) {
        (
            self.half_width_m * phi_rad.sin(),
            self.half_height_m * (2.0 * phi_rad).sin(),
        )
    }

    /// The direction of travel at phase `phi_rad` (φ increasing), radians from +x.
    pub fn heading_rad(&self, phi_rad: f64) -> f64 {
        let dx = self.half_width_m * phi_rad.cos();
        let dy = 2.0 * self.half_height_m * (2.0 * phi_rad).cos();
        dy.atan2(dx)
    }

    /// Where the robot starts: on the path at φ = 0 (the crossing, the origin), facing along.
    pub fn start(&self) -> ((f64, f64), f64) {
        (self.point(0.0), self.heading_rad(0.0))
    }

    /// The path as a closed polyline.
    pub fn polyline(&self) -> Vec<(f64, f64)> {
        (0..=SEGMENTS)
            .map(|k| self.point(TAU * k as f64 / SEGMENTS as f64))
            .collect()
    }
}

/// Distances to a path.
#[derive(Debug, Clone)]
pub struct PathError {
    polyline: Vec<(f64, f64)>,
}

impl PathError {
    /// Measures against `path`.
    pub fn new(path: &FigureEight) -> Self {
        PathError {
            polyline: path.polyline(),
        }
    }

    /// Distance from `p` to the nearest point of the path, m.
    pub fn distance_m(&self, p: (f64, f64)) -> f64 {
        self.polyline
            .windows(2)
            .map(|w| segment_distance(p, w[0], w[1]))
            .fold(f64::INFINITY, f64::min)
    }
}

/// Distance from `p` to the segment `a`–`b`.
fn segment_distance(p: (f64, f64), a: (f64, f64), b: (f64, f64)) -> f64 {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let len2 = dx * dx + dy * dy;
    let t = if len2 > 0.0 {
        (((p.0 - a.0) * dx + (p.1 - a.1) * dy) / len2).clamp(0.0, 1.0)
    } else {
        0.0
    };
    (p.0 - a.0 - t * dx).hypot(p.1 - a.1 - t * dy)
}

/// The start heading is 45° off +x when the figure is twice as wide as high (`dy/dx = 2b/a`).
pub const RIG_START_HEADING_RAD: f64 = FRAC_PI_4;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_rig_figure_is_1_2_by_0_6_m_and_starts_at_its_crossing_at_45_degrees() {
        let path = FigureEight::RIG;
        let points = path.polyline();
        let span = |f: fn(&(f64, f64)) -> f64| {
            let v: Vec<f64> = points.iter().map(f).collect();
            v.iter().cloned().fold(f64::MIN, f64::max) - v.iter().cloned().fold(f64::MAX, f64::min)
        };
        assert!((span(|p| p.0) - 1.2).abs() < 1e-6);
        assert!((span(|p| p.1) - 0.6).abs() < 1e-6);
        let (at, heading) = path.start();
        assert_eq!(at, (0.0, 0.0));
        assert!((heading - RIG_START_HEADING_RAD).abs() < 1e-12);
    }

    #[test]
    fn distances_to_the_path() {
        let e = PathError::new(&FigureEight::RIG);
        // On the path anywhere, including between the polyline's vertices.
        for phi in [0.0, 0.1234, 1.0, 2.5, 4.0, 5.9] {
            assert!(e.distance_m(FigureEight::RIG.point(phi)) < 1e-6, "{phi}");
        }
        // The tip of the right lobe is (0.6, 0): 5 cm beyond it is 5 cm off.
        assert!((e.distance_m((0.65, 0.0)) - 0.05).abs() < 1e-6);
        // The centre of a lobe is far from everything.
        assert!(e.distance_m((0.4, 0.0)) > 0.15);
    }
}
