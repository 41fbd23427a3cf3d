//! Occluders (opaque rectangles drawn over the LED) and the visibility of the LED disk.

use super::trajectory::Point;
use super::truth::Visibility;

/// An opaque rectangle aligned to whole pixels: columns `left..left + width`, rows
/// `top..top + height`. In OpenCV coordinates it spans `[left - 0.5, left + width - 0.5]`
/// horizontally (and likewise vertically), so every pixel is either hidden or not.
#[derive(Clone, Debug, PartialEq)]
pub struct Occluder {
    /// First covered column.
    pub left: u32,
    /// First covered row.
    pub top: u32,
    /// Number of covered columns.
    pub width: u32,
    /// Number of covered rows.
    pub height: u32,
    /// Radiance of the occluder's surface (dark, e.g. 0.05).
    pub radiance: f64,
}

/// An axis-aligned rectangle in continuous pixel coordinates.
#[derive(Clone, Copy, Debug)]
struct Area {
    x0: f64,
    x1: f64,
    y0: f64,
    y1: f64,
}

impl Area {
    fn of_pixels(left: u32, top: u32, width: u32, height: u32) -> Self {
        Self {
            x0: f64::from(left) - 0.5,
            x1: f64::from(left) + f64::from(width) - 0.5,
            y0: f64::from(top) - 0.5,
            y1: f64::from(top) + f64::from(height) - 0.5,
        }
    }

    /// The whole disk lies inside the rectangle.
    fn contains_disk(self, c: Point, r: f64) -> bool {
        c.x - r >= self.x0 && c.x + r <= self.x1 && c.y - r >= self.y0 && c.y + r <= self.y1
    }

    /// The disk and the rectangle share no area.
    fn misses_disk(self, c: Point, r: f64) -> bool {
        let dx = (self.x0 - c.x).max(c.x - self.x1).max(0.0);
        let dy = (self.y0 - c.y).max(c.y - self.y1).max(0.0);
        dx * dx + dy * dy >= r * r
    }
}

impl Occluder {
    fn area(&self) -> Area {
        Area::of_pixels(self.left, self.top, self.width, self.height)
    }

    /// Whether pixel `(x, y)` is hidden.
    pub(crate) fn covers(&self, x: usize, y: usize) -> bool {
        let (left, top) = (self.left as usize, self.top as usize);
        x >= left && x < left + self.width as usize && y >= top && y < top + self.height as usize
    }
}

/// Classifies the LED disk over an exposure from its positions at the exposure's time samples
/// (which must be dense: at most a small fraction of the radius apart).
///
/// `Visible` when every sample's disk lies wholly inside the frame and touches no occluder;
/// `Hidden` when every sample's disk is wholly outside the frame or wholly inside one
/// occluder; `Partial` otherwise (including a disk half off-screen and half under an
/// occluder, which is hidden too but rare enough to leave to `Partial`).
pub(crate) fn classify(
    positions: impl IntoIterator<Item = Point>,
    radius_px: f64,
    width_px: u32,
    height_px: u32,
    occluders: &[Occluder],
) -> Visibility {
    let frame = Area::of_pixels(0, 0, width_px, height_px);
    let (mut all_visible, mut all_hidden) = (true, true);
    for c in positions {
        let visible = frame.contains_disk(c, radius_px)
            && occluders.iter().all(|o| o.area().misses_disk(c, radius_px));
        let hidden = frame.misses_disk(c, radius_px)
            || occluders
                .iter()
                .any(|o| o.area().contains_disk(c, radius_px));
        all_visible &= visible;
        all_hidden &= hidden;
    }
    match (all_visible, all_hidden) {
        (true, _) => Visibility::Visible,
        (false, true) => Visibility::Hidden,
        (false, false) => Visibility::Partial,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const W: u32 = 100;
    const H: u32 = 80;

    fn box_at(left: u32, top: u32) -> Occluder {
        Occluder {
            left,
            top,
            width: 20,
            height: 20,
            radiance: 0.05,
        }
    }

    #[test]
    fn disk_touching_the_frame_edge_is_visible_only_when_inside() {
        // The frame's area starts at x = -0.5: a radius-3 disk at x = 2.5 just fits.
        let at = |x: f64| classify([Point::new(x, 40.0)], 3.0, W, H, &[]);
        assert_eq!(at(2.5), Visibility::Visible);
        assert_eq!(at(2.4), Visibility::Partial);
        assert_eq!(at(-3.5), Visibility::Hidden);
        assert_eq!(at(-3.4), Visibility::Partial);
        assert_eq!(at(96.5), Visibility::Visible);
        assert_eq!(at(102.5), Visibility::Hidden);
    }

    #[test]
    fn occluder_hides_a_disk_wholly_inside_it() {
        let occluders = [box_at(40, 30)]; // spans x 39.5..59.5, y 29.5..49.5
        let at = |x: f64| classify([Point::new(x, 40.0)], 3.0, W, H, &occluders);
        assert_eq!(at(50.0), Visibility::Hidden);
        assert_eq!(at(42.5), Visibility::Hidden);
        assert_eq!(at(42.4), Visibility::Partial);
        assert_eq!(at(36.5), Visibility::Visible);
        assert_eq!(at(36.6), Visibility::Partial);
    }

    #[test]
    fn one_partial_sample_makes_the_exposure_partial() {
        let samples = [Point::new(20.0, 40.0), Point::new(1.0, 40.0)];
        assert_eq!(classify(samples, 3.0, W, H, &[]), Visibility::Partial);
        let samples = [Point::new(-10.0, 40.0), Point::new(20.0, 40.0)];
        assert_eq!(classify(samples, 3.0, W, H, &[]), Visibility::Partial);
        // Off-screen, then under the occluder: never seen.
        let samples = [Point::new(-10.0, 40.0), Point::new(50.0, 40.0)];
        assert_eq!(
            classify(samples, 3.0, W, H, &[box_at(40, 30)]),
            Visibility::Hidden
        );
    }

    #[test]
    fn covers_matches_the_pixel_range() {
        let o = box_at(40, 30);
        assert!(o.covers(40, 30) && o.covers(59, 49));
        assert!(!o.covers(39, 30) && !o.covers(60, 49) && !o.covers(45, 50));
    }
}
