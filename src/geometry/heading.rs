//! The heading of a marker from its four corners, on the screen or (corners mapped) on the
//! floor: geometry of four points, shared by the marker tracker and the floor stage.

use super::Point;

/// Heading of a marker in degrees, in (−180, 180]: the direction from the midpoint of its
/// bottom edge (bottom-left to bottom-right corner) to the midpoint of its top edge (top-left
/// to top-right), as the angle from the +x axis towards the +y axis of the corners' own
/// coordinates. On the screen (x right, y down) 0° points right and 90° points down the
/// picture; on the floor map (x right, y down the map, as `glint calibrate` lays it out) 0° is
/// +x and 90° is +y. Corners are in OpenCV's order: top-left, top-right, bottom-right,
/// bottom-left.
pub fn marker_heading_deg(corners: &[Point; 4]) -> f64 {
    let [tl, tr, br, bl] = *corners;
    let top = (tl.coords + tr.coords) * 0.5;
    let bottom = (bl.coords + br.coords) * 0.5;
    let d = top - bottom;
    d.y.atan2(d.x).to_degrees()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn square(rotation_deg: f64) -> [Point; 4] {
        // Printed upright (top edge up the picture, i.e. towards −y), then turned.
        let upright = [(-1.0, -1.0), (1.0, -1.0), (1.0, 1.0), (-1.0, 1.0)];
        let (s, c) = rotation_deg.to_radians().sin_cos();
        upright.map(|(x, y)| Point::new(100.0 + c * x - s * y, 50.0 + s * x + c * y))
    }

    #[test]
    fn heading_is_bottom_to_top_from_plus_x_towards_plus_y() {
        // Upright on the screen: the top points up the picture, −y, which is −90°.
        assert!((marker_heading_deg(&square(0.0)) + 90.0).abs() < 1e-9);
        // Turned 90° clockwise on the screen (towards +y from +x): the top points right, 0°.
        assert!(marker_heading_deg(&square(90.0)).abs() < 1e-9);
        assert!((marker_heading_deg(&square(180.0)) - 90.0).abs() < 1e-9);
        assert!((marker_heading_deg(&square(-45.0)) + 135.0).abs() < 1e-9);
    }
}
