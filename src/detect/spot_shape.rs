//! A round spot seen through a lens: where the tips of a streak are, and whether it moved, when
//! the lens squeezes the LED's spot.
//!
//! Barrel distortion shrinks the picture more radially than around its centre, so near the
//! picture's edge a round spot is imaged as an ellipse squeezed towards the centre (up to a
//! third, in the corners of a wide webcam lens). [`tips`](super::tips) measures a streak's width
//! across its middle and takes it for the spot's extent along the streak too, which holds for a
//! round spot only: through the lens, the tips of a short streak land up to a pixel off, and a
//! still spot squeezed along its long axis reads as a streak of 1–2 px whose head is half of
//! that off the middle. Its caps' own extents are measured, but only to a few tenths of a pixel,
//! not well enough to tell a squeezed spot from a slow one.
//!
//! The lens is known, though (fitted by `glint calibrate` or read with `--lens`), and near the
//! blob it is linear: its local Jacobian maps a displacement in the ideal camera's picture to
//! one in the image. Through its inverse `A` (image pixels to ideal pixels), the LED's footprint
//! is a round spot of radius `R` swept along a straight path. A line from the path's end along
//! the image direction `d` leaves the footprint's cap after `R / |A d|` image pixels, and a line
//! from the middle across it, along `n ⊥ d`, leaves its side after `R |A d| / |det A|` (the
//! part of `A n` across `A d` is `|det A| / |A d|`). So the spot's extent along the streak is
//! the width measured across it times `|det A| / |A d|²`; the tips are placed with that extent,
//! and the footprint's length less the spot's, in ideal pixels, is the path the still rule
//! judges (with the caps' measured scatter as its uncertainty, as without a lens). A blob the
//! caps' own rule already calls still stays still: taking a slow LED for a still one costs
//! little (the tracker carries the middle by the frames' motion, a fraction of a pixel here),
//! while tips read off a path shorter than a pixel are off by about as much as the path. With
//! an ideal lens (or none) the factor is 1: [`SpotShape::identity`] places the tips where the
//! round reading put them, and the path the still rule judges is the footprint less the spot's
//! width across.
//!
//! The guard in [`through_lens`] (a tip no farther from its skeleton end than the spot's extent)
//! holds with or without a lens: a ramp that runs on into a white square beside the LED is no
//! lens's doing (`tests/bright_beside.rs`).

use super::tips::Tips;

/// A path within this many of the caps' standard deviations of nothing is still (as the rule
/// without a lens in [`tips`](super::tips)).
const STILL_UNCERTAINTIES: f32 = 2.0;

/// A skeleton end is a pixel's centre: where the thinning actually stopped is anywhere in that
/// pixel, up to half its diagonal away.
const SKELETON_END_SLACK_PX: f32 = core::f32::consts::FRAC_1_SQRT_2;

/// The lens's local linear map at one pixel: image pixels to the pixels of an ideal camera
/// with the same focal lengths (the inverse of the distortion's Jacobian there).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpotShape {
    image_to_ideal: [[f32; 2]; 2],
    /// `|det image_to_ideal|`, positive.
    det: f32,
}

impl SpotShape {
    /// The shape of `image_to_ideal` (rows); `None` unless it is finite and one-to-one.
    pub fn new(image_to_ideal: [[f32; 2]; 2]) -> Option<SpotShape> {
        let [[a, b], [c, d]] = image_to_ideal;
        let det = (a * d - b * c).abs();
        let finite = [a, b, c, d].iter().all(|v| v.is_finite());
        (finite && det.is_normal()).then_some(SpotShape {
            image_to_ideal,
            det,
        })
    }

    /// No lens: image pixels are ideal pixels, and a round spot stays round.
    pub fn identity() -> SpotShape {
        SpotShape {
            image_to_ideal: [[1.0, 0.0], [0.0, 1.0]],
            det: 1.0,
        }
    }

    /// Ideal pixels per image pixel along the unit image direction `d`: `|A d|`.
    pub fn ideal_per_image_px(&self, d: (f32, f32)) -> f32 {
        let [[a, b], [c, e]] = self.image_to_ideal;
        (a * d.0 + b * d.1).hypot(c * d.0 + e * d.1)
    }

    /// The displacement `d` in image pixels, in ideal pixels: `A d`.
    pub fn to_ideal(self, d: (f32, f32)) -> (f32, f32) {
        let [[a, b], [c, e]] = self.image_to_ideal;
        (a * d.0 + b * d.1, c * d.0 + e * d.1)
    }

    /// The displacement `d` in ideal pixels, in image pixels: `A⁻¹ d` (`A` is one-to-one).
    pub fn to_image(self, d: (f32, f32)) -> (f32, f32) {
        let [[a, b], [c, e]] = self.image_to_ideal;
        let det = a * e - b * c;
        ((e * d.0 - b * d.1) / det, (a * d.1 - c * d.0) / det)
    }

    /// This shape seen through a further linear map `first` of the image, applied before it
    /// (image pixels to the pixels this shape takes): `A · first`. `None` unless one-to-one.
    pub fn after(self, first: [[f32; 2]; 2]) -> Option<SpotShape> {
        let [[a, b], [c, e]] = self.image_to_ideal;
        let [[p, q], [r, t]] = first;
        SpotShape::new([
            [a * p + b * r, a * q + b * t],
            [c * p + e * r, c * q + e * t],
        ])
    }

    /// A round spot's extent along the unit image direction `d` over its extent across it,
    /// both in image pixels: `|det A| / |A d|²`.
    pub fn along_over_across(&self, d: (f32, f32)) -> f32 {
        let s = self.ideal_per_image_px(d);
        self.det / (s * s)
    }
}

/// Where the lens is known: the local shape of a round spot at an image pixel.
pub trait SpotOptics: Send + Sync {
    /// The lens's local map at image pixel `px`; `None` where it cannot be had (beyond where
    /// the lens folds over).
    fn spot_shape_at(&self, px: (f32, f32)) -> Option<SpotShape>;
}

/// The lens's spot (a round one without a lens) seen through a rolling shutter that skews the
/// picture of a moving LED: `unskew` maps the skewed picture back to the one a global shutter
/// would have taken (see [`RollingShutter::unskew`](crate::track::shutter::RollingShutter)).
pub struct Skewed<'a> {
    /// The lens, when one is known.
    pub lens: Option<&'a dyn SpotOptics>,
    /// Skewed picture pixels to a global shutter's picture pixels.
    pub unskew: [[f32; 2]; 2],
}

impl SpotOptics for Skewed<'_> {
    fn spot_shape_at(&self, px: (f32, f32)) -> Option<SpotShape> {
        let lens = match self.lens {
            Some(lens) => lens.spot_shape_at(px)?,
            None => SpotShape::identity(),
        };
        lens.after(self.unskew)
    }
}

/// `tips`, measured as for a round spot, placed again for the spot `shape` the lens makes of a
/// round spot there (or none: [`SpotShape::identity`]), and judged still by the path's length
/// in ideal pixels (or still as they were already). `None` when a tip lands farther from its
/// skeleton end (`ends_px`, in the same order) than the spot's own extent along the streak
/// (and half a pixel's diagonal): the LED's centre at the end of its path is inside the
/// saturated blob, whose skeleton ends within that extent of it, so such a tip was read from a
/// ramp that ran on into something bright beside the LED (a marker's white square).
pub fn through_lens(
    tips: Tips,
    ends_px: [(f32, f32); 2],
    mid_px: (f32, f32),
    shape: SpotShape,
) -> Option<Tips> {
    let [o0, o1] = tips.outward;
    // The streak's axis, from end 0 to end 1: both ends' outward directions, averaged.
    let (ax, ay) = (o1.0 - o0.0, o1.1 - o0.1);
    let len = ax.hypot(ay);
    if len <= f32::EPSILON {
        return None;
    }
    let axis = (ax / len, ay / len);
    let along_px = tips.radius_px * shape.along_over_across(axis);
    // Each tip was placed one across-radius back from its footprint's edge; the cap's extent
    // along the streak is `along_px`.
    let shift = tips.radius_px - along_px;
    let place = |tip: (f32, f32), o: (f32, f32)| (tip.0 + shift * o.0, tip.1 + shift * o.1);
    let tips_px = [place(tips.tips_px[0], o0), place(tips.tips_px[1], o1)];
    if tips_px
        .iter()
        .zip(&ends_px)
        .any(|(&tip, &end)| dist(tip, end) > along_px + SKELETON_END_SLACK_PX)
    {
        return None;
    }
    let ideal = shape.ideal_per_image_px(axis);
    let path_ideal_px = (tips.footprint_px - 2.0 * along_px) * ideal;
    let still = tips.still || path_ideal_px <= STILL_UNCERTAINTIES * tips.spread_px * ideal;
    Some(Tips {
        tips_px,
        path_length_px: dist(tips_px[0], mid_px) + dist(mid_px, tips_px[1]),
        still,
        ..tips
    })
}

fn dist(a: (f32, f32), b: (f32, f32)) -> f32 {
    (a.0 - b.0).hypot(a.1 - b.1)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A horizontal streak centred on the origin, read as round with radius 3 px across.
    fn tips(footprint_px: f32, spread_px: f32) -> Tips {
        let radius_px = 3.0;
        let half = 0.5 * footprint_px - radius_px;
        Tips {
            tips_px: [(-half, 0.0), (half, 0.0)],
            radius_px,
            path_length_px: 2.0 * half,
            still: false,
            outward: [(-1.0, 0.0), (1.0, 0.0)],
            footprint_px,
            spread_px,
        }
    }

    /// `t` through `shape`, its skeleton ending where its round reading put the tips.
    fn seen(t: Tips, shape: SpotShape) -> Option<Tips> {
        through_lens(t, t.tips_px, (0.0, 0.0), shape)
    }

    #[test]
    fn image_and_ideal_displacements_map_back() {
        let shape = SpotShape::new([[1.3, -0.2], [0.1, 0.8]]).unwrap();
        for d in [(1.0, 0.0), (0.0, -2.0), (3.5, 1.25)] {
            let ideal = shape.to_ideal(d);
            let length = d.0.hypot(d.1);
            let unit = (d.0 / length, d.1 / length);
            let expected = shape.ideal_per_image_px(unit) * length;
            assert!(
                (ideal.0.hypot(ideal.1) - expected).abs() < 1e-5,
                "{d:?} {ideal:?}"
            );
            let back = shape.to_image(ideal);
            assert!(
                (back.0 - d.0).abs() < 1e-5 && (back.1 - d.1).abs() < 1e-5,
                "{d:?} {back:?}"
            );
        }
    }

    #[test]
    fn an_ideal_lens_changes_nothing() {
        let shape = SpotShape::new([[1.0, 0.0], [0.0, 1.0]]).unwrap();
        assert_eq!(shape, SpotShape::identity());
        let t = tips(10.0, 0.2);
        let s = seen(t, shape).unwrap();
        assert_eq!(s.tips_px, t.tips_px);
        assert!(!s.still);
        // A uniform scale is no squeeze either.
        let scaled = SpotShape::new([[1.3, 0.0], [0.0, 1.3]]).unwrap();
        assert!((scaled.along_over_across((0.6, 0.8)) - 1.0).abs() < 1e-6);
    }

    #[test]
    fn a_spot_squeezed_along_the_streak_is_still() {
        // The lens squeezes x by 0.7: a still round spot of radius 3 is 4.2 px long, and its
        // width across is 3; read as round it would be a 1.2 px streak.
        let squeeze = SpotShape::new([[1.0 / 0.7, 0.0], [0.0, 1.0]]).unwrap();
        let t = tips(4.2, 0.1);
        assert!(!t.still);
        let s = seen(t, squeeze).unwrap();
        assert!(s.still, "{s:?}");
        // The same footprint, 2 px longer, moved: its tips are 1 px either side of the middle.
        let moving = seen(tips(6.2, 0.1), squeeze).unwrap();
        assert!(!moving.still);
        assert!((moving.tips_px[1].0 - 1.0).abs() < 1e-5, "{moving:?}");
        assert!((moving.tips_px[0].0 + 1.0).abs() < 1e-5, "{moving:?}");
        assert!((moving.path_length_px - 2.0).abs() < 1e-5);
    }

    #[test]
    fn a_spot_stretched_along_the_streak_has_its_tips_moved_in() {
        // Squeezed across (y by 0.8): the cap is 3 / 0.8 = 3.75 px long along x.
        let squeeze = SpotShape::new([[1.0, 0.0], [0.0, 1.25]]).unwrap();
        let s = seen(tips(11.5, 0.1), squeeze).unwrap();
        assert!((s.tips_px[1].0 - 2.0).abs() < 1e-5, "{s:?}");
    }

    #[test]
    fn a_tip_beyond_the_spot_from_its_skeleton_end_is_no_tip() {
        // A ramp that ran on into a white square: the tip 6 px past a skeleton end that a
        // spot 3 px in extent cannot be more than 3 px from.
        let shape = SpotShape::new([[1.0, 0.0], [0.0, 1.0]]).unwrap();
        let t = tips(20.0, 0.2);
        let ends = [(-1.0, 0.0), (1.0, 0.0)];
        assert!(through_lens(t, ends, (0.0, 0.0), shape).is_none());
        let near = [(-5.0, 0.0), (5.0, 0.0)];
        assert!(through_lens(t, near, (0.0, 0.0), shape).is_some());
    }

    #[test]
    fn a_singular_or_non_finite_map_is_refused() {
        assert!(SpotShape::new([[1.0, 2.0], [2.0, 4.0]]).is_none());
        assert!(SpotShape::new([[f32::NAN, 0.0], [0.0, 1.0]]).is_none());
    }
}
