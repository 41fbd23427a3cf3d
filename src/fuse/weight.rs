//! How much each camera's sighting counts where views overlap.
//!
//! A sighting's weight is `edge / σ²`:
//!
//! - `σ` is the position's standard deviation on the floor: in pixels, a pixel's quantisation
//!   (1/√12 px), the calibration's marker residual (`calib.residual_px`) and the streak fit's own
//!   deviation (`fit_px`, with `--streak-model fit`) added in quadrature, plus half the streak
//!   when the position is only its middle (`pos_method: mid`, the head unknown); times the
//!   camera's floor length of a pixel there, measured as the ratio of the floor speed to the
//!   picture speed of the same report (a far camera's pixel covers more floor). While a camera
//!   has not measured it, every camera's pixel counts as one unit, so that the weights stay
//!   comparable. A sighting extrapolated by its age (see [`super::Fuser`]) has `σ²` grown by
//!   `(1 + (age / frame interval)²)`: one a whole frame old counts half.
//! - `edge` falls from 1 to 0 as the light nears the picture's edge, where its spot is cut and
//!   its position pulled inwards: 1 while the nearer of head and middle is at least two spot
//!   radii from the edge, 0 at one radius, linear between. The radius is measured from the
//!   report (the blob's area over a streak of its skeleton length: `2 r L + π r² = area`).
//!   Without `--size` the picture's edges are unknown and `edge` is 1.

use super::line::Sighting;
use crate::geometry::Point;

/// A pixel's quantisation as a standard deviation, px (a uniform error over one pixel).
const QUANTISATION_PX: f64 = 0.288_675_134_594_812_9;
/// Below this picture speed the floor-per-pixel ratio of a report is mostly noise, px/s.
const MIN_SCALE_SPEED_PX_S: f64 = 20.0;

/// The position's standard deviation in pixels, from what the report says about itself.
pub fn sigma_px(s: &Sighting) -> f64 {
    let residual = s.calib_residual_px.unwrap_or(0.0);
    let fit = s.fit_px.unwrap_or(0.0);
    let lag = if s.head {
        0.0
    } else {
        0.5 * s.len_px.unwrap_or(0.0)
    };
    (QUANTISATION_PX.powi(2) + residual.powi(2) + fit.powi(2) + lag.powi(2)).sqrt()
}

/// Floor units per pixel at the report's position: floor speed over picture speed, when the
/// light moves fast enough for the ratio to mean something.
pub fn floor_per_px(s: &Sighting) -> Option<f64> {
    let (v_floor, v_px) = (s.floor_velocity?, s.velocity_px_s?);
    let speed_px = v_px.coords.norm();
    let ratio = v_floor.coords.norm() / speed_px;
    (speed_px >= MIN_SCALE_SPEED_PX_S && ratio.is_finite() && ratio > 0.0).then_some(ratio)
}

/// The spot's radius measured from the report, px: `r` of a streak of skeleton length `L`
/// whose blob has `area` pixels, `2 r L + π r² = area`.
pub fn spot_radius_px(s: &Sighting) -> Option<f64> {
    let area = s.area_px.filter(|a| *a > 0.0)?;
    let length = s.len_px.unwrap_or(0.0);
    let pi = core::f64::consts::PI;
    Some((-length + (length * length + pi * area).sqrt()) / pi)
}

/// 1 away from the picture's edges, falling to 0 where the spot touches one (see the module).
pub fn edge_weight(s: &Sighting, picture_px: Option<(u32, u32)>) -> f64 {
    let Some((width, height)) = picture_px else {
        return 1.0;
    };
    let Some(radius) = spot_radius_px(s) else {
        return 1.0;
    };
    let (w, h) = (f64::from(width) - 1.0, f64::from(height) - 1.0);
    let inside = |p: Point| p.x.min(p.y).min(w - p.x).min(h - p.y);
    let d = [s.position_px, s.mid_px]
        .into_iter()
        .flatten()
        .map(inside)
        .fold(f64::INFINITY, f64::min);
    if !d.is_finite() || radius <= 0.0 {
        return 1.0;
    }
    ((d - radius) / radius).clamp(0.0, 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn seen(x: f64, area: f64, len: f64) -> Sighting {
        Sighting {
            id: 1,
            found: true,
            position_px: Some(Point::new(x, 100.0)),
            mid_px: Some(Point::new(x, 100.0)),
            head: true,
            floor: Some(Point::new(0.0, 0.0)),
            unit: None,
            floor_velocity: None,
            velocity_px_s: None,
            area_px: Some(area),
            len_px: Some(len),
            fit_px: None,
            calib_residual_px: None,
            floor_stale: false,
            beyond_horizon: false,
        }
    }

    #[test]
    fn a_disk_radius_comes_back_from_its_area() {
        let r = spot_radius_px(&seen(0.0, core::f64::consts::PI * 16.0, 0.0)).unwrap();
        assert!((r - 4.0).abs() < 1e-12);
        // A 10 px streak of a 3 px spot: 2·3·10 + 9π.
        let r = spot_radius_px(&seen(0.0, 60.0 + 9.0 * core::f64::consts::PI, 10.0)).unwrap();
        assert!((r - 3.0).abs() < 1e-12);
    }

    #[test]
    fn the_weight_falls_to_zero_where_the_spot_meets_the_edge() {
        let area = core::f64::consts::PI * 16.0; // radius 4 px
        let at = |x| edge_weight(&seen(x, area, 0.0), Some((640, 480)));
        assert_eq!(at(320.0), 1.0);
        assert_eq!(at(8.0), 1.0);
        assert!((at(6.0) - 0.5).abs() < 1e-12);
        assert_eq!(at(4.0), 0.0);
        assert_eq!(at(637.0), 0.0);
        assert_eq!(edge_weight(&seen(2.0, area, 0.0), None), 1.0);
    }

    #[test]
    fn a_middle_only_position_is_less_certain_by_half_its_streak() {
        let mut s = seen(100.0, 50.0, 10.0);
        let head = sigma_px(&s);
        s.head = false;
        assert!((sigma_px(&s).powi(2) - head.powi(2) - 25.0).abs() < 1e-9);
    }
}
