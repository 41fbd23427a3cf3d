//! The floor stage: the tracker's screen position, velocity and heading mapped onto the floor.
//!
//! Positions go through the calibration's screen→floor homography, refusing points on or beyond
//! the floor's horizon (they have no floor position; a number there would be a mirror image).
//! Velocities are mapped by the homography's Jacobian at the position, not by a pixel scale:
//! one pixel covers far more floor at the back of the picture than at the front, and the
//! Jacobian is exactly how screen motion at that point becomes floor motion. Headings are
//! measured between the marker's edge midpoints after its corners are mapped to the floor.

use core::fmt;
use core::str::FromStr;

use nalgebra::{Matrix2, Matrix3, Vector2};

use super::homography::{FloorMapping, HomographyError, Point};
use crate::track::{marker_heading_deg, Estimate};

/// The unit of floor coordinates, as the calibration file names it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum FloorUnit {
    /// Millimetres.
    Mm,
    /// Centimetres (what `glint calibrate` writes: marker sizes are given in cm).
    Cm,
    /// Metres.
    M,
    /// Inches.
    In,
}

impl FloorUnit {
    /// The short name used in the calibration file and the output.
    pub fn name(self) -> &'static str {
        match self {
            FloorUnit::Mm => "mm",
            FloorUnit::Cm => "cm",
            FloorUnit::M => "m",
            FloorUnit::In => "in",
        }
    }
}

/// A unit name that is not one of `mm`, `cm`, `m`, `in`.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct UnknownFloorUnit;

impl fmt::Display for UnknownFloorUnit {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "floor units must be one of mm, cm, m, in")
    }
}

impl core::error::Error for UnknownFloorUnit {}

impl FromStr for FloorUnit {
    type Err = UnknownFloorUnit;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "mm" => Ok(FloorUnit::Mm),
            "cm" => Ok(FloorUnit::Cm),
            "m" => Ok(FloorUnit::M),
            "in" => Ok(FloorUnit::In),
            _ => Err(UnknownFloorUnit),
        }
    }
}

impl fmt::Display for FloorUnit {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// The floor stage's answer for a frame in which the robot was found.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum FloorFix {
    /// The position maps to the floor.
    Mapped(FloorEstimate),
    /// The screen position is on or beyond the floor's horizon: it has no floor position.
    BeyondHorizon,
}

/// Floor position, velocity and heading of one frame, in the calibration's [`FloorUnit`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FloorEstimate {
    /// Floor position of the tracker's `x, y`.
    pub position: Point,
    /// Floor velocity, in units per second, when the screen velocity is known.
    pub velocity_per_s: Option<Vector2<f64>>,
    /// Heading on the floor map in degrees (see [`marker_heading_deg`]), when a marker's
    /// corners are known and all map to the floor.
    pub heading_deg: Option<f64>,
    /// The unit of `position` and `velocity_per_s`.
    pub unit: FloorUnit,
}

/// Maps the tracker's estimates to the floor. Built once at start-up; mapping allocates nothing.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FloorStage {
    mapping: FloorMapping,
    /// Screen→floor matrix, for the Jacobian (the mapping keeps its own for positions).
    screen_to_floor: Matrix3<f64>,
    unit: FloorUnit,
}

impl FloorStage {
    /// A stage for a validated mapping whose floor coordinates are in `unit`.
    pub fn new(mapping: FloorMapping, unit: FloorUnit) -> Result<Self, HomographyError> {
        let inverse = mapping.floor_to_screen_homography().inverse()?;
        Ok(FloorStage {
            mapping,
            screen_to_floor: *inverse.matrix(),
            unit,
        })
    }

    /// The screen ↔ floor mapping.
    pub fn mapping(&self) -> &FloorMapping {
        &self.mapping
    }

    /// The unit of floor coordinates.
    pub fn unit(&self) -> FloorUnit {
        self.unit
    }

    /// Floor position, velocity and (given a marker's corners) heading for an estimate.
    pub fn map(&self, estimate: &Estimate, marker_corners_px: Option<&[Point; 4]>) -> FloorFix {
        let screen = Point::new(
            f64::from(estimate.position_px.0),
            f64::from(estimate.position_px.1),
        );
        let Ok(position) = self.mapping.screen_to_floor(&screen) else {
            return FloorFix::BeyondHorizon;
        };
        let velocity_per_s = estimate.velocity_px_s.and_then(|((vx, vy), _)| {
            let jacobian = self.jacobian(&screen, &position)?;
            let v = jacobian * Vector2::new(f64::from(vx), f64::from(vy));
            (v.x.is_finite() && v.y.is_finite()).then_some(v)
        });
        let heading_deg = marker_corners_px.and_then(|corners| {
            let mut floor = [Point::origin(); 4];
            for (f, c) in floor.iter_mut().zip(corners) {
                *f = self.mapping.screen_to_floor(c).ok()?;
            }
            Some(marker_heading_deg(&floor))
        });
        FloorFix::Mapped(FloorEstimate {
            position,
            velocity_per_s,
            heading_deg,
            unit: self.unit,
        })
    }

    /// The derivative of the screen→floor mapping at `screen` (which maps to `floor`): floor
    /// units per pixel. For `X = (h₀·p)/w`, `Y = (h₁·p)/w`, `w = h₂·p`, the row of X is
    /// `(h₀₀ − X h₂₀, h₀₁ − X h₂₁) / w`, and likewise for Y; independent of the matrix's scale.
    fn jacobian(&self, screen: &Point, floor: &Point) -> Option<Matrix2<f64>> {
        let h = &self.screen_to_floor;
        let w = h[(2, 0)] * screen.x + h[(2, 1)] * screen.y + h[(2, 2)];
        if w == 0.0 || !w.is_finite() {
            return None;
        }
        Some(
            Matrix2::new(
                h[(0, 0)] - floor.x * h[(2, 0)],
                h[(0, 1)] - floor.x * h[(2, 1)],
                h[(1, 0)] - floor.y * h[(2, 0)],
                h[(1, 1)] - floor.y * h[(2, 1)],
            ) / w,
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::homography::Homography;
    use crate::track::{PositionMethod, VelocityMethod};

    /// An oblique view: floor cm → screen px.
    fn stage() -> FloorStage {
        let floor_to_screen = Homography::from_matrix(Matrix3::new(
            2.1, 0.3, 320.0, -0.2, 1.4, 240.0, 0.0004, 0.0021, 1.0,
        ))
        .unwrap();
        let samples = [Point::new(320.0, 240.0)];
        let mapping = FloorMapping::from_floor_to_screen(floor_to_screen, &samples).unwrap();
        FloorStage::new(mapping, FloorUnit::Cm).unwrap()
    }

    fn estimate(p: Point, v: Option<(f32, f32)>) -> Estimate {
        Estimate {
            position_px: (p.x as f32, p.y as f32),
            position_method: PositionMethod::Head,
            mid_px: (p.x as f32, p.y as f32),
            velocity_px_s: v.map(|v| (v, VelocityMethod::Streak)),
        }
    }

    #[test]
    fn velocity_follows_the_floor_motion_not_a_pixel_scale() {
        let s = stage();
        let h = *s.mapping().floor_to_screen_homography();
        // A robot at floor (40, 90) cm moving at (30, -20) cm/s: its screen velocity is the
        // difference of two screen positions a short time apart.
        let (p0, v) = (Point::new(40.0, 90.0), Vector2::new(30.0, -20.0));
        let dt = 1e-4;
        let a = h.apply(&p0).unwrap();
        let b = h.apply(&(p0 + v * dt)).unwrap();
        let v_px = (b - a) / dt;
        let screen = Point::new(f64::from(a.x as f32), f64::from(a.y as f32));
        let fix = s.map(
            &estimate(screen, Some((v_px.x as f32, v_px.y as f32))),
            None,
        );
        let FloorFix::Mapped(e) = fix else {
            panic!("{fix:?}")
        };
        assert!((e.position - p0).norm() < 1e-3, "{:?}", e.position);
        let got = e.velocity_per_s.unwrap();
        assert!((got - v).norm() < 1e-2 * v.norm(), "{got:?} vs {v:?}");
        assert_eq!(e.unit, FloorUnit::Cm);
        assert_eq!(e.heading_deg, None);
    }

    #[test]
    fn beyond_the_horizon_there_is_no_floor_position() {
        let s = stage();
        let inv = s.screen_to_floor;
        // On the screen, the horizon is where the inverse's w vanishes; beyond it, the sky.
        let y_horizon = -inv[(2, 2)] / inv[(2, 1)];
        let visible_below = y_horizon < 240.0;
        let beyond = if visible_below {
            y_horizon - 20.0
        } else {
            y_horizon + 20.0
        };
        let fix = s.map(&estimate(Point::new(0.0, beyond), Some((5.0, 5.0))), None);
        assert_eq!(fix, FloorFix::BeyondHorizon);
    }

    #[test]
    fn heading_is_measured_on_the_floor() {
        let s = stage();
        let h = *s.mapping().floor_to_screen_homography();
        // A 20 cm marker turned so that its top points along floor +y (90°).
        let c = Point::new(50.0, 60.0);
        let floor = [
            Point::new(c.x + 10.0, c.y + 10.0),
            Point::new(c.x + 10.0, c.y - 10.0),
            Point::new(c.x - 10.0, c.y - 10.0),
            Point::new(c.x - 10.0, c.y + 10.0),
        ];
        assert!((marker_heading_deg(&floor) - 0.0).abs() < 1e-9);
        let rotated = floor.map(|p| Point::new(c.x - (p.y - c.y), c.y + (p.x - c.x)));
        let screen = rotated.map(|p| h.apply(&p).unwrap());
        let fix = s.map(&estimate(h.apply(&c).unwrap(), None), Some(&screen));
        let FloorFix::Mapped(e) = fix else {
            panic!("{fix:?}")
        };
        let heading = e.heading_deg.unwrap();
        assert!((heading - 90.0).abs() < 1e-6, "{heading}");
        // The screen heading differs: the view is oblique.
        assert!((marker_heading_deg(&screen) - 90.0).abs() > 1.0);
        assert_eq!(e.velocity_per_s, None);
    }

    #[test]
    fn units_parse_by_name_only() {
        for u in [FloorUnit::Mm, FloorUnit::Cm, FloorUnit::M, FloorUnit::In] {
            assert_eq!(u.name().parse::<FloorUnit>(), Ok(u));
        }
        assert_eq!("CM".parse::<FloorUnit>(), Err(UnknownFloorUnit));
        assert_eq!("".parse::<FloorUnit>(), Err(UnknownFloorUnit));
    }
}
