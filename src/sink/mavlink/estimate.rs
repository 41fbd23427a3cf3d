//! From a frame's floor position to the autopilot's messages: the axis convention, the units,
//! and the covariance.
//!
//! # Axes
//!
//! The autopilot's local frame is NED (north, east, down), in metres. glint's floor map has no
//! compass, so the convention is: floor +x is north and floor +y is east, then both are turned
//! clockwise (seen from above) by the yaw offset, the compass bearing of floor +x. For this to be
//! a rotation (and not a mirror), floor +y must be 90° clockwise from +x seen from above, as it
//! is for a map drawn like an image (x right, y down). z is 0: the robot is on the floor, which
//! is the local frame's origin height.
//!
//! # Uncertainty
//!
//! `glint fuse` passes the fused track's own standard deviation ([`Axes::position`]). For one
//! camera, glint has no per-frame fit uncertainty yet; the position's standard deviation is the
//! calibration's largest corner residual combined with a pixel's quantisation (1/√12 px),
//! mapped to the floor through the homography at the robot's position (the larger of the two
//! screen axes' floor lengths). The height is the floor's, as well known as the position: the
//! same variance. Roll, pitch and yaw are not measured: each gets the variance of an angle
//! uniform over the circle, π²/3 rad². Every entry is finite on purpose: MAVLink marks only a
//! wholly unknown matrix (NaN first), and a consumer that combines entries (ArduPilot folds the
//! x, y, z variances into one position error, and roll, pitch, yaw into one angle error) would
//! turn one NaN into a NaN error. The velocity's uncertainty is unknown altogether: its
//! covariance starts with NaN, as MAVLink asks.

use mavlink::dialects::common::{VISION_POSITION_ESTIMATE_DATA, VISION_SPEED_ESTIMATE_DATA};

use crate::geometry::{FloorStage, Point};
use crate::report::{FloorEstimate, FloorUnit};

/// Variance of a position quantised to whole pixels (uniform over one pixel): 1/12 px².
const QUANTISATION_VARIANCE_PX2: f64 = 1.0 / 12.0;

/// Variance of an angle that could be anywhere on the circle (uniform over ±π): π²/3 rad².
const UNMEASURED_ANGLE_VARIANCE_RAD2: f32 = core::f32::consts::PI * core::f32::consts::PI / 3.0;

/// States of the pose that are positions (x, y, z); the rest are angles.
const POSITION_STATES: usize = 3;

/// Entries of the pose covariance's upper triangle (6 states: x, y, z, roll, pitch, yaw).
const POSE_COVARIANCE_LEN: usize = 21;

/// States of the pose, in MAVLink's covariance order.
const POSE_STATES: usize = 6;

/// Metres per floor unit of a calibration.
pub fn metres_per_unit(unit: FloorUnit) -> f64 {
    match unit {
        FloorUnit::Mm => 0.001,
        FloorUnit::Cm => 0.01,
        FloorUnit::M => 1.0,
        FloorUnit::In => 0.0254,
    }
}

/// The floor's axes and unit to the autopilot's local frame (see the module documentation):
/// what every source of floor positions shares, a camera's calibration or `glint fuse`.
#[derive(Debug, Clone, Copy)]
pub struct Axes {
    metres_per_unit: f64,
    cos_yaw: f64,
    sin_yaw: f64,
}

impl Axes {
    /// For floor numbers in `unit` and the compass bearing of floor +x (`yaw_offset_deg`,
    /// clockwise from north).
    pub fn new(unit: FloorUnit, yaw_offset_deg: f64) -> Axes {
        let yaw = yaw_offset_deg.to_radians();
        Axes {
            metres_per_unit: metres_per_unit(unit),
            cos_yaw: yaw.cos(),
            sin_yaw: yaw.sin(),
        }
    }

    /// Floor (x, y) in floor units → (north, east) in metres.
    pub fn north_east_m(&self, x: f64, y: f64) -> (f64, f64) {
        let (x_m, y_m) = (x * self.metres_per_unit, y * self.metres_per_unit);
        (
            x_m * self.cos_yaw - y_m * self.sin_yaw,
            x_m * self.sin_yaw + y_m * self.cos_yaw,
        )
    }

    /// Metres per floor unit.
    pub fn metres_per_unit(&self) -> f64 {
        self.metres_per_unit
    }

    /// The position message for floor point `floor` (floor units) captured at `usec`, with the
    /// position's standard deviation `sigma_m` (metres; `None`: unknown, the covariance NaN).
    pub fn position(
        &self,
        usec: u64,
        floor: Point,
        sigma_m: Option<f64>,
    ) -> VISION_POSITION_ESTIMATE_DATA {
        let (north_m, east_m) = self.north_east_m(floor.x, floor.y);
        let variance_m2 = sigma_m
            .filter(|s| s.is_finite() && *s >= 0.0)
            .map(|s| (s * s) as f32);
        VISION_POSITION_ESTIMATE_DATA {
            usec,
            x: north_m as f32,
            y: east_m as f32,
            z: 0.0,
            roll: 0.0,
            pitch: 0.0,
            yaw: 0.0,
            covariance: pose_covariance(variance_m2),
            reset_counter: 0,
        }
    }

    /// The velocity message for floor velocity `v` (floor units/s); its uncertainty unknown.
    pub fn speed(&self, usec: u64, v: Point) -> VISION_SPEED_ESTIMATE_DATA {
        let (north_m_s, east_m_s) = self.north_east_m(v.x, v.y);
        VISION_SPEED_ESTIMATE_DATA {
            usec,
            x: north_m_s as f32,
            y: east_m_s as f32,
            z: 0.0,
            covariance: [f32::NAN; 9],
            reset_counter: 0,
        }
    }
}

/// Turns one camera's floor positions into the autopilot's local frame, with their uncertainty
/// from the calibration; built once at start-up.
#[derive(Debug, Clone, Copy)]
pub struct ToLocal {
    floor: FloorStage,
    axes: Axes,
    residual_variance_px2: f64,
}

impl ToLocal {
    /// For the calibration's floor stage, the compass bearing of floor +x (`yaw_offset_deg`,
    /// clockwise from north) and the calibration's largest corner residual.
    pub fn new(floor: FloorStage, yaw_offset_deg: f64, max_residual_px: f64) -> ToLocal {
        ToLocal {
            axes: Axes::new(floor.unit(), yaw_offset_deg),
            floor,
            residual_variance_px2: max_residual_px * max_residual_px,
        }
    }

    /// Floor (x, y) in floor units → (north, east) in metres.
    pub fn north_east_m(&self, x: f64, y: f64) -> (f64, f64) {
        self.axes.north_east_m(x, y)
    }

    /// Standard deviation of the floor position in metres, for a robot seen at `screen_px`:
    /// the pixel uncertainty times the longer floor length of a screen pixel step there
    /// (through the lens and the LED's plane when the calibration has them). `None` when a step
    /// crosses the horizon.
    pub fn sigma_m(&self, screen_px: (f32, f32), at: &FloorEstimate) -> Option<f64> {
        let sigma_px = (self.residual_variance_px2 + QUANTISATION_VARIANCE_PX2).sqrt();
        let (sx, sy) = (f64::from(screen_px.0), f64::from(screen_px.1));
        let mut longest: f64 = 0.0;
        for step in [Point::new(sx + sigma_px, sy), Point::new(sx, sy + sigma_px)] {
            let p = self.floor.screen_to_floor(&step)?;
            longest = longest.max((p.x - at.position.x).hypot(p.y - at.position.y));
        }
        let sigma_m = longest * self.axes.metres_per_unit();
        sigma_m.is_finite().then_some(sigma_m)
    }

    /// The position message for a frame whose capture time is `usec`.
    pub fn position(
        &self,
        usec: u64,
        screen_px: (f32, f32),
        at: &FloorEstimate,
    ) -> VISION_POSITION_ESTIMATE_DATA {
        self.axes
            .position(usec, at.position, self.sigma_m(screen_px, at))
    }

    /// The velocity message, when the frame's floor velocity is known.
    pub fn speed(&self, usec: u64, at: &FloorEstimate) -> Option<VISION_SPEED_ESTIMATE_DATA> {
        let v = at.velocity_per_s?;
        Some(self.axes.speed(usec, Point::new(v.x, v.y)))
    }
}

/// The pose covariance's upper triangle, row by row: `variance_m2` on the x, y and z diagonal,
/// `UNMEASURED_ANGLE_VARIANCE_RAD2` on the roll, pitch and yaw diagonal, 0 off the diagonal
/// (the states are taken as independent). Without a variance, all NaN (MAVLink's "unknown").
pub fn pose_covariance(variance_m2: Option<f32>) -> [f32; POSE_COVARIANCE_LEN] {
    let Some(variance_m2) = variance_m2 else {
        return [f32::NAN; POSE_COVARIANCE_LEN];
    };
    let mut covariance = [0.0; POSE_COVARIANCE_LEN];
    let mut entry = covariance.iter_mut();
    for row in 0..POSE_STATES {
        for column in row..POSE_STATES {
            if let Some(e) = entry.next() {
                if row == column {
                    *e = if row < POSITION_STATES {
                        variance_m2
                    } else {
                        UNMEASURED_ANGLE_VARIANCE_RAD2
                    };
                }
            }
        }
    }
    covariance
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::FloorMapping;

    /// A top-down camera: 1 px = 0.5 cm, floor x along screen x, floor y along screen y.
    fn top_down() -> FloorStage {
        let floor =
            [(0.0, 0.0), (100.0, 0.0), (100.0, 100.0), (0.0, 100.0)].map(|(x, y)| Point::new(x, y));
        let screen = floor.map(|p| Point::new(p.x * 2.0, p.y * 2.0));
        FloorStage::new(FloorMapping::fit(&floor, &screen).unwrap(), FloorUnit::Cm).unwrap()
    }

    fn at(x: f64, y: f64) -> FloorEstimate {
        FloorEstimate {
            position: Point::new(x, y),
            velocity_per_s: Some(nalgebra::Vector2::new(10.0, 0.0)),
            heading_deg: None,
            unit: FloorUnit::Cm,
        }
    }

    #[test]
    fn floor_x_is_north_turned_by_the_yaw_offset() {
        let straight = ToLocal::new(top_down(), 0.0, 0.0);
        let (n, e) = straight.north_east_m(150.0, 20.0);
        assert!(
            (n - 1.5).abs() < 1e-12 && (e - 0.2).abs() < 1e-12,
            "{n} {e}"
        );
        // Floor +x bears east (90°): +x becomes east, +y (its right) becomes south.
        let east = ToLocal::new(top_down(), 90.0, 0.0);
        let (n, e) = east.north_east_m(100.0, 0.0);
        assert!(n.abs() < 1e-12 && (e - 1.0).abs() < 1e-12, "{n} {e}");
        let (n, e) = east.north_east_m(0.0, 100.0);
        assert!((n + 1.0).abs() < 1e-12 && e.abs() < 1e-12, "{n} {e}");
    }

    #[test]
    fn sigma_is_the_pixel_uncertainty_at_the_floor_scale() {
        // 0.5 cm per pixel; residual 0.5 px ⇒ σ = √(0.25 + 1/12) px ≈ 0.577 px ≈ 0.289 cm.
        let local = ToLocal::new(top_down(), 0.0, 0.5);
        let sigma_m = local.sigma_m((80.0, 60.0), &at(40.0, 30.0)).unwrap();
        let expected_m = (0.25f64 + 1.0 / 12.0).sqrt() * 0.005;
        assert!(
            (sigma_m - expected_m).abs() < 1e-9,
            "{sigma_m} vs {expected_m}"
        );
    }

    #[test]
    fn covariance_has_the_variance_on_positions_and_a_whole_circle_on_angles() {
        let c = pose_covariance(Some(4.0));
        // The diagonal of the 6×6 upper triangle, row by row: x 0, y 6, z 11, roll 15,
        // pitch 18, yaw 20.
        let diagonal = [0, 6, 11, 15, 18, 20];
        for (state, &i) in diagonal.iter().enumerate() {
            let expected = if state < 3 { 4.0 } else { 3.289_868 };
            assert!((c[i] - expected).abs() < 1e-6, "entry {i}: {}", c[i]);
        }
        let off: Vec<f32> = (0..21)
            .filter(|i| !diagonal.contains(i))
            .map(|i| c[i])
            .collect();
        assert!(off.iter().all(|&v| v == 0.0), "{c:?}");
        assert!(pose_covariance(None).iter().all(|v| v.is_nan()));
    }

    #[test]
    fn messages_carry_metres_and_the_capture_time() {
        let local = ToLocal::new(top_down(), 0.0, 0.0);
        let p = local.position(1_234_567, (80.0, 60.0), &at(40.0, 30.0));
        assert_eq!(p.usec, 1_234_567);
        assert!((p.x - 0.4).abs() < 1e-6 && (p.y - 0.3).abs() < 1e-6);
        assert_eq!(p.z, 0.0);
        let s = local.speed(1_234_567, &at(40.0, 30.0)).unwrap();
        assert!((s.x - 0.1).abs() < 1e-6 && s.y.abs() < 1e-6);
        assert!(s.covariance[0].is_nan());
        let still = FloorEstimate {
            velocity_per_s: None,
            ..at(40.0, 30.0)
        };
        assert!(local.speed(1, &still).is_none());
    }
}
