//! Specks beside a much larger blob: pieces of its rim cut apart at a level near its top, or
//! of a floor its glow lights up to the clip, split from it by the floor's dark texture. An
//! LED at rest in a wide clipped glow is surrounded by such specks; they merge and split with
//! the noise, so their mass centres wander by more than a blob that stands still, and one of
//! them would pass for a light that moved. Such a speck is never taken for the LED on its own:
//! the LED is the large blob beside it, taken once that moves.
//!
//! Another LED of the same robot, at the same range, is about as large as the LED; a lamp
//! beside the LED is no satellite of it unless it is far smaller and all but touches it.

use super::blobs::{Blob, BoundingBox};

/// A blob at least this many times the area of a speck beside it makes the speck its
/// satellite: a piece of a rim or a lit floor is a small part of the blob it lies by.
pub const SATELLITE_AREA_RATIO: u32 = 8;

/// How far outside the larger blob's extent a satellite lies at most, px: across a dark line of
/// floor texture a pixel or two wide.
pub const SATELLITE_REACH_PX: usize = 2;

/// True when `blob` lies within [`SATELLITE_REACH_PX`] of the extent of one of `others` at
/// least [`SATELLITE_AREA_RATIO`] times its area and compact: filling half its box or more.
pub fn is_satellite(blob: &Blob, mut others: impl Iterator<Item = Blob>) -> bool {
    others.any(|other| {
        other.area_px >= SATELLITE_AREA_RATIO.saturating_mul(blob.area_px)
            && compact(&other)
            && within_reach(&other.bbox, &blob.bbox)
    })
}

/// Whether `blob` fills at least half its box (a disk fills π/4 of it, a window all of it),
/// so that near its box is near its pixels. A diagonal streak or glare bar fills a sliver of
/// its box, whose empty corners may hold another light.
fn compact(blob: &Blob) -> bool {
    let box_px = blob.bbox.width_px().saturating_mul(blob.bbox.height_px());
    2 * blob.area_px as usize >= box_px
}

/// True when boxes `a` and `b` are at most [`SATELLITE_REACH_PX`] apart on both axes.
fn within_reach(a: &BoundingBox, b: &BoundingBox) -> bool {
    let gap = |a_min: usize, a_max: usize, b_min: usize, b_max: usize| {
        b_min.saturating_sub(a_max).max(a_min.saturating_sub(b_max))
    };
    gap(a.x_min_px, a.x_max_px, b.x_min_px, b.x_max_px) <= SATELLITE_REACH_PX + 1
        && gap(a.y_min_px, a.y_max_px, b.y_min_px, b.y_max_px) <= SATELLITE_REACH_PX + 1
}

#[cfg(test)]
mod tests {
    use super::*;

    fn blob(x_min_px: usize, y_min_px: usize, side_px: usize) -> Blob {
        let half = (side_px - 1) as f32 / 2.0;
        Blob {
            area_px: (side_px * side_px) as u32,
            bbox: BoundingBox {
                x_min_px,
                y_min_px,
                x_max_px: x_min_px + side_px - 1,
                y_max_px: y_min_px + side_px - 1,
            },
            mass_centre_px: (x_min_px as f32 + half, y_min_px as f32 + half),
            elongation: 1.0,
        }
    }

    #[test]
    fn a_speck_across_a_dark_line_from_a_large_glow_is_its_satellite() {
        // A clipped glow 30 px across, rows 10 to 39.
        let glow = blob(10, 10, 30);
        // Below it across a dark row 40 (and 41): a satellite.
        assert!(is_satellite(&blob(20, 41, 2), [glow].into_iter()));
        assert!(is_satellite(&blob(20, 42, 2), [glow].into_iter()));
        // Three rows clear of it: a light of its own.
        assert!(!is_satellite(&blob(20, 43, 2), [glow].into_iter()));
        // Diagonally off its corner, within reach on both axes.
        assert!(is_satellite(&blob(41, 41, 2), [glow].into_iter()));
        assert!(!is_satellite(&blob(41, 43, 2), [glow].into_iter()));
    }

    #[test]
    fn a_speck_in_the_empty_corner_of_a_diagonal_bar_s_box_is_none() {
        // A glare bar 3 px thick along the diagonal of a 40 px box: 120 of its 1600 pixels.
        let bar = Blob {
            area_px: 120,
            ..blob(10, 10, 40)
        };
        assert!(!is_satellite(&blob(45, 12, 2), [bar].into_iter()));
        assert!(!is_satellite(&blob(30, 12, 2), [bar].into_iter()));
    }

    #[test]
    fn a_light_as_large_as_its_neighbour_or_alone_is_none() {
        let led = blob(10, 10, 6);
        // Another LED of the robot, a little smaller, touching: not a satellite.
        assert!(!is_satellite(&blob(16, 10, 4), [led].into_iter()));
        // A blob is never its own satellite.
        assert!(!is_satellite(&led, [led].into_iter()));
        assert!(!is_satellite(&led, core::iter::empty()));
    }
}
