//! The floor stage: the tracker's screen position, velocity and heading mapped onto the floor.
//!
//! With a camera model (lens and pose, from a version-2 calibration), a screen point is
//! undistorted to its ray, and the ray is met with the plane the LED moves in (`led_height`
//! above the floor); the floor point under that is the answer. Only points are undistorted,
//! never the image, and nothing allocates. A calibration from an older glint holds only a
//! homography: an ideal lens, an LED on the floor.
//!
//! Points on or beyond the plane's horizon are refused (they have no floor position; a number
//! there would be a mirror image). Velocities are mapped by the mapping's Jacobian at the
//! position, not by a pixel scale: one pixel covers far more floor at the back of the picture
//! than at the front, and the Jacobian is exactly how screen motion at that point becomes floor
//! motion. Headings are measured between the marker's edge midpoints after its corners are
//! mapped to the floor.

use core::fmt;
use core::str::FromStr;

use nalgebra::{Matrix2, Matrix3, Vector2};

use super::camera::CameraModel;
use super::heading::marker_heading_deg;
use super::homography::{FloorMapping, HomographyError, Point};

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

/// Half the step of the central differences giving the camera model's Jacobian, pixels: the
/// mapping is smooth over a pixel, and this is far above rounding.
const JACOBIAN_HALF_STEP_PX: f64 = 0.5;

/// How screen points become floor points.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Model {
    /// An ideal lens and the LED on the floor: one homography.
    Homography {
        mapping: FloorMapping,
        /// Screen→floor matrix, for the Jacobian (the mapping keeps its own for positions).
        screen_to_floor: Matrix3<f64>,
    },
    /// A lens and a pose: rays met with the plane `led_height` above the floor.
    Camera {
        camera: CameraModel,
        led_height: f64,
    },
}

/// A height for the LED was asked of a calibration that has no camera pose.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct NeedsCameraPose;

impl fmt::Display for NeedsCameraPose {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "an LED height needs the camera's pose, which this calibration (from an older \
             glint, a homography only) does not hold; run glint calibrate again"
        )
    }
}

impl core::error::Error for NeedsCameraPose {}

/// Maps the tracker's estimates to the floor. Built once at start-up; mapping allocates nothing.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FloorStage {
    model: Model,
    unit: FloorUnit,
}

impl FloorStage {
    /// A stage for a validated mapping whose floor coordinates are in `unit`.
    pub fn new(mapping: FloorMapping, unit: FloorUnit) -> Result<Self, HomographyError> {
        let inverse = mapping.floor_to_screen_homography().inverse()?;
        Ok(FloorStage {
            model: Model::Homography {
                mapping,
                screen_to_floor: *inverse.matrix(),
            },
            unit,
        })
    }

    /// A stage for a camera model whose floor coordinates are in `unit`, the LED on the floor.
    pub fn from_camera(camera: CameraModel, unit: FloorUnit) -> Self {
        FloorStage {
            model: Model::Camera {
                camera,
                led_height: 0.0,
            },
            unit,
        }
    }

    /// The same stage for an LED `height` (floor units) above the floor: the floor point
    /// under the LED is reported. Needs a camera model.
    pub fn with_led_height(self, height: f64) -> Result<Self, NeedsCameraPose> {
        match self.model {
            Model::Camera { camera, .. } => Ok(FloorStage {
                model: Model::Camera {
                    camera,
                    led_height: height,
                },
                unit: self.unit,
            }),
            Model::Homography { .. } if height == 0.0 => Ok(self),
            Model::Homography { .. } => Err(NeedsCameraPose),
        }
    }

    /// The screen ↔ floor homography, for a calibration without a camera model.
    pub fn mapping(&self) -> Option<&FloorMapping> {
        match &self.model {
            Model::Homography { mapping, .. } => Some(mapping),
            Model::Camera { .. } => None,
        }
    }

    /// The camera model, when the calibration holds one.
    pub fn camera(&self) -> Option<&CameraModel> {
        match &self.model {
            Model::Camera { camera, .. } => Some(camera),
            Model::Homography { .. } => None,
        }
    }

    /// The LED's height above the floor (0 without a camera model).
    pub fn led_height(&self) -> f64 {
        match self.model {
            Model::Camera { led_height, .. } => led_height,
            Model::Homography { .. } => 0.0,
        }
    }

    /// The floor point (under the LED's plane) seen at a screen point, if there is one.
    pub fn screen_to_floor(&self, screen: &Point) -> Option<Point> {
        match &self.model {
            Model::Homography { mapping, .. } => mapping.screen_to_floor(screen).ok(),
            Model::Camera { camera, led_height } => camera.floor_point(screen, *led_height).ok(),
        }
    }

    /// The unit of floor coordinates.
    pub fn unit(&self) -> FloorUnit {
        self.unit
    }

    /// Floor position, velocity and (given a marker's corners) heading for a screen position
    /// and velocity (px/s, when known).
    pub fn map(
        &self,
        position_px: (f32, f32),
        velocity_px_s: Option<(f32, f32)>,
        marker_corners_px: Option<&[Point; 4]>,
    ) -> FloorFix {
        let screen = Point::new(f64::from(position_px.0), f64::from(position_px.1));
        let Some(position) = self.screen_to_floor(&screen) else {
            return FloorFix::BeyondHorizon;
        };
        let velocity_per_s = velocity_px_s.and_then(|(vx, vy)| {
            let jacobian = self.jacobian(&screen, &position)?;
            let v = jacobian * Vector2::new(f64::from(vx), f64::from(vy));
            (v.x.is_finite() && v.y.is_finite()).then_some(v)
        });
        let heading_deg = marker_corners_px.and_then(|corners| {
            let mut floor = [Point::origin(); 4];
            for (f, c) in floor.iter_mut().zip(corners) {
                *f = self.screen_to_floor(c)?;
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
    /// units per pixel.
    fn jacobian(&self, screen: &Point, floor: &Point) -> Option<Matrix2<f64>> {
        match &self.model {
            Model::Homography {
                screen_to_floor, ..
            } => homography_jacobian(screen_to_floor, screen, floor),
            Model::Camera { .. } => {
                let d = JACOBIAN_HALF_STEP_PX;
                let at = |dx: f64, dy: f64| {
                    self.screen_to_floor(&Point::new(screen.x + dx, screen.y + dy))
                };
                let ddx = (at(d, 0.0)? - at(-d, 0.0)?) / (2.0 * d);
                let ddy = (at(0.0, d)? - at(0.0, -d)?) / (2.0 * d);
                Some(Matrix2::new(ddx.x, ddy.x, ddx.y, ddy.y))
            }
        }
    }
}

/// For `X = (h₀·p)/w`, `Y = (h₁·p)/w`, `w = h₂·p`, the row of X is
/// `(h₀₀ − X h₂₀, h₀₁ − X h₂₁) / w`, and likewise for Y; independent of the matrix's scale.
fn homography_jacobian(h: &Matrix3<f64>, screen: &Point, floor: &Point) -> Option<Matrix2<f64>> {
    {
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

    /// `stage.map` of a screen point `p` moving at `v` px/s.
    fn map(
        stage: &FloorStage,
        p: Point,
        v: Option<(f32, f32)>,
        corners: Option<&[Point; 4]>,
    ) -> FloorFix {
        stage.map((p.x as f32, p.y as f32), v, corners)
    }

    #[test]
    fn velocity_follows_the_floor_motion_not_a_pixel_scale() {
        let s = stage();
        let h = *s.mapping().unwrap().floor_to_screen_homography();
        // A robot at floor (40, 90) cm moving at (30, -20) cm/s: its screen velocity is the
        // difference of two screen positions a short time apart.
        let (p0, v) = (Point::new(40.0, 90.0), Vector2::new(30.0, -20.0));
        let dt = 1e-4;
        let a = h.apply(&p0).unwrap();
        let b = h.apply(&(p0 + v * dt)).unwrap();
        let v_px = (b - a) / dt;
        let screen = Point::new(f64::from(a.x as f32), f64::from(a.y as f32));
        let fix = map(&s, screen, Some((v_px.x as f32, v_px.y as f32)), None);
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
    fn through_a_lens_the_led_above_the_floor_maps_to_the_point_under_it() {
        use crate::geometry::camera::{Lens, Pose};
        use nalgebra::Vector3;
        let centre = Vector3::new(10.0, -70.0, -130.0);
        let forward = Vector3::new(0.0, 0.5f64.cos(), 0.5f64.sin());
        let camera = CameraModel {
            lens: Lens {
                k1: -0.3,
                k2: 0.09,
                ..Lens::ideal(460.0, 460.0, 319.5, 239.5)
            },
            pose: Pose::looking_at(centre, centre + forward).unwrap(),
        };
        let s = FloorStage::from_camera(camera, FloorUnit::Cm)
            .with_led_height(12.0)
            .unwrap();
        let (p0, v) = (Point::new(40.0, 90.0), Vector2::new(30.0, -20.0));
        let dt = 1e-4;
        let a = camera.project(&p0, 12.0).unwrap();
        let b = camera.project(&(p0 + v * dt), 12.0).unwrap();
        let v_px = (b - a) / dt;
        let fix = map(&s, a, Some((v_px.x as f32, v_px.y as f32)), None);
        let FloorFix::Mapped(e) = fix else {
            panic!("{fix:?}")
        };
        assert!((e.position - p0).norm() < 1e-2, "{:?}", e.position);
        let got = e.velocity_per_s.unwrap();
        assert!((got - v).norm() < 1e-2 * v.norm(), "{got:?} vs {v:?}");
        // Read on the floor, the same pixel is far off: the height matters.
        let flat = FloorStage::from_camera(camera, FloorUnit::Cm);
        let FloorFix::Mapped(e) = map(&flat, a, None, None) else {
            panic!()
        };
        assert!((e.position - p0).norm() > 5.0);
        // A homography has no pose to put the LED at a height.
        assert_eq!(stage().with_led_height(12.0), Err(NeedsCameraPose));
    }

    #[test]
    fn beyond_the_horizon_there_is_no_floor_position() {
        let s = stage();
        let Model::Homography {
            screen_to_floor: inv,
            ..
        } = s.model
        else {
            panic!("a homography stage")
        };
        // On the screen, the horizon is where the inverse's w vanishes; beyond it, the sky.
        let y_horizon = -inv[(2, 2)] / inv[(2, 1)];
        let visible_below = y_horizon < 240.0;
        let beyond = if visible_below {
            y_horizon - 20.0
        } else {
            y_horizon + 20.0
        };
        let fix = map(&s, Point::new(0.0, beyond), Some((5.0, 5.0)), None);
        assert_eq!(fix, FloorFix::BeyondHorizon);
    }

    #[test]
    fn heading_is_measured_on_the_floor() {
        let s = stage();
        let h = *s.mapping().unwrap().floor_to_screen_homography();
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
        let fix = map(&s, h.apply(&c).unwrap(), None, Some(&screen));
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
