//! A lens's squeeze of the LED's spot: a wide-angle lens images a round spot near the picture's
//! edge as an ellipse, shorter along one axis (radially, down to about two thirds of the round
//! extent in a wide webcam lens's corners).
//!
//! Over a spot the lens is linear: [`Squeeze::image_to_round`] maps a displacement from the
//! spot's centre in image pixels to one in the round spot's frame (stretching the squeezed axis
//! back by `1 / ratio`). The spot is drawn squeezed about its centre, while its centre follows
//! the path in image pixels as before, so the truth does not change. The lens gathers the same
//! light onto a smaller area: the squeezed spot holds the round spot's total light, and its
//! radiance is `1 / ratio` the round one's (the change of variables' area element,
//! `|det image_to_round|`).
//!
//! Each kernel keeps its own way of sampling: the disk's coverage of a pixel is exact (the
//! pixel's square mapped into the round frame is a parallelogram, whose overlap with the disk
//! is a sum of triangle–circle areas), the Gaussian is integrated over each pixel's square
//! (exactly across, through the error function as the round one; along `y` by Gauss–Legendre
//! quadrature, since the rotated ellipse does not factor), and the glow is sampled at pixel
//! centres as the round glow is.

use super::optics::{glow_profile, normal_cdf, Patch, GAUSSIAN_REACH_SIGMAS};
use super::trajectory::Point;

/// Gauss–Legendre nodes on `[-1/2, 1/2]` and their weights (summing to 1), for the
/// squeezed Gaussian's integral along a pixel's height: exact for polynomials of degree 9.
const LEGENDRE_NODES: [(f64, f64); 5] = [
    (-0.453_089_922_969_332_2, 0.118_463_442_528_094_5),
    (-0.269_234_655_052_841_4, 0.239_314_335_249_683_2),
    (0.0, 0.284_444_444_444_444_4),
    (0.269_234_655_052_841_4, 0.239_314_335_249_683_2),
    (0.453_089_922_969_332_2, 0.118_463_442_528_094_5),
];

/// How a lens squeezes the LED's spot where it is imaged.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Squeeze {
    /// The spot's extent along [`Squeeze::axis_rad`] in the image over its round extent: 1 for
    /// no lens (or the picture's centre), in `(0, 1]`.
    pub ratio: f64,
    /// The squeezed axis's direction in the image, from +x towards +y.
    pub axis_rad: f64,
}

impl Squeeze {
    /// No squeeze: the spot stays round.
    pub const NONE: Squeeze = Squeeze {
        ratio: 1.0,
        axis_rad: 0.0,
    };

    /// Whether the spot stays round (then it is drawn exactly as without a lens).
    pub fn is_none(self) -> bool {
        self.ratio == 1.0
    }

    /// Whether the squeeze is one this renderer draws: a finite axis and a ratio in `(0, 1]`.
    pub(crate) fn is_valid(self) -> bool {
        self.ratio > 0.0 && self.ratio <= 1.0 && self.axis_rad.is_finite()
    }

    /// The lens's local map from image pixels to the round spot's frame (rows): `R diag(1 /
    /// ratio, 1) Rᵀ`, with `R` turning +x onto the squeezed axis.
    pub fn image_to_round(self) -> [[f64; 2]; 2] {
        let (s, c) = self.axis_rad.sin_cos();
        let k = 1.0 / self.ratio - 1.0;
        [[1.0 + k * c * c, k * c * s], [k * c * s, 1.0 + k * s * s]]
    }

    /// The image displacement `d` in the round spot's frame.
    fn to_round(self, d: Point) -> Point {
        let [[a, b], [c, e]] = self.image_to_round();
        Point::new(a * d.x + b * d.y, c * d.x + e * d.y)
    }

    /// The covariance (xx, xy, yy) in image pixels of a round Gaussian of σ `sigma_px`,
    /// squeezed: `σ² R diag(ratio², 1) Rᵀ`.
    fn covariance(self, sigma_px: f64) -> (f64, f64, f64) {
        let (s, c) = self.axis_rad.sin_cos();
        let k = self.ratio * self.ratio - 1.0;
        let v = sigma_px * sigma_px;
        (v * (1.0 + k * c * c), v * k * c * s, v * (1.0 + k * s * s))
    }
}

/// Signed area of the intersection of the disk of radius `r` about the origin with the
/// triangle (origin, `p`, `q`): positive when `p` to `q` turns anticlockwise. The segment is
/// cut where it crosses the circle; a piece inside the disk adds its triangle, a piece outside
/// the disk's sector between its ends.
fn disk_triangle_area(r: f64, p: Point, q: Point) -> f64 {
    let d = Point::new(q.x - p.x, q.y - p.y);
    let a = d.x * d.x + d.y * d.y;
    let b = p.x * d.x + p.y * d.y;
    let c = p.x * p.x + p.y * p.y - r * r;
    let mut cuts = [0.0, 1.0, 1.0, 1.0];
    let mut count = 1;
    let disc = b * b - a * c;
    if a > 0.0 && disc > 0.0 {
        let root = disc.sqrt();
        for t in [(-b - root) / a, (-b + root) / a] {
            if t > 0.0 && t < 1.0 {
                cuts[count] = t;
                count += 1;
            }
        }
    }
    cuts[count] = 1.0;
    let at = |t: f64| Point::new(p.x + t * d.x, p.y + t * d.y);
    cuts[..=count]
        .windows(2)
        .map(|w| {
            let (u, v) = (at(w[0]), at(w[1]));
            let cross = u.x * v.y - u.y * v.x;
            let mid = at(0.5 * (w[0] + w[1]));
            if mid.x * mid.x + mid.y * mid.y <= r * r {
                0.5 * cross
            } else {
                0.5 * r * r * cross.atan2(u.x * v.x + u.y * v.y)
            }
        })
        .sum()
}

/// Area of the disk of radius `r` about the origin inside the convex polygon `corners`
/// (in order, either way round).
fn disk_polygon_area(r: f64, corners: &[Point; 4]) -> f64 {
    let signed: f64 = (0..4)
        .map(|i| disk_triangle_area(r, corners[i], corners[(i + 1) % 4]))
        .sum();
    signed.abs()
}

impl Patch {
    /// Adds `weight ×` the disk of `radius_px` at `centre`, squeezed by `squeeze`: each pixel
    /// gets the round frame's area of the disk inside the pixel's square mapped there (its
    /// image area times `1 / ratio`, the squeezed spot's radiance), so the disk's total light
    /// is the round one's, `π R² · weight`. Without a squeeze, [`Patch::add_disk`].
    pub(crate) fn add_squeezed_disk(
        &mut self,
        centre: Point,
        radius_px: f64,
        squeeze: Squeeze,
        weight: f64,
    ) {
        if squeeze.is_none() {
            return self.add_disk(centre, radius_px, weight);
        }
        // A mapped pixel reaches at most this far from its mapped centre (half the diagonal,
        // stretched by at most 1 / ratio).
        let half_reach = std::f64::consts::FRAC_1_SQRT_2 / squeeze.ratio;
        // The squeezed disk lies inside the round one.
        self.add_kernel(centre, radius_px + 0.5, |px, py| {
            let m = squeeze.to_round(Point::new(px - centre.x, py - centre.y));
            let from_centre = m.x.hypot(m.y);
            if from_centre - half_reach >= radius_px {
                return 0.0;
            }
            let corners = [(-0.5, -0.5), (0.5, -0.5), (0.5, 0.5), (-0.5, 0.5)].map(|(dx, dy)| {
                squeeze.to_round(Point::new(px + dx - centre.x, py + dy - centre.y))
            });
            weight * disk_polygon_area(radius_px, &corners)
        });
    }

    /// Adds a Gaussian of σ `sigma_px` (in the round frame) and round centre radiance `peak`
    /// at `centre`, squeezed by `squeeze`: the pixel gets `peak · 2πσ²` (the round spot's
    /// total light) times the squeezed Gaussian's probability mass inside its square. Across
    /// (in `x`) that mass is exact given `y`; along `y` it is Gauss–Legendre quadrature.
    /// Without a squeeze, [`Patch::add_gaussian`].
    pub(crate) fn add_squeezed_gaussian(
        &mut self,
        centre: Point,
        sigma_px: f64,
        squeeze: Squeeze,
        peak: f64,
    ) {
        if squeeze.is_none() {
            return self.add_gaussian(centre, sigma_px, peak);
        }
        let (xx, xy, yy) = squeeze.covariance(sigma_px);
        // x given y: mean `slope · y`, σ `across`.
        let slope = xy / yy;
        let across = ((xx * yy - xy * xy) / yy).sqrt();
        let sigma_y = yy.sqrt();
        let reach_x = GAUSSIAN_REACH_SIGMAS * xx.sqrt() + 0.5;
        let reach_y = GAUSSIAN_REACH_SIGMAS * sigma_y + 0.5;
        let scale = peak * std::f64::consts::TAU * sigma_px * sigma_px;
        let density_y =
            |y: f64| (-0.5 * y * y / yy).exp() / (sigma_y * (std::f64::consts::TAU).sqrt());
        let cols = self.index_range(
            centre.x - reach_x,
            centre.x + reach_x,
            self.left,
            self.width,
        );
        let rows = self.index_range(
            centre.y - reach_y,
            centre.y + reach_y,
            self.top,
            self.height,
        );
        let width = self.width;
        for row in rows {
            let py = (self.top + row) as f64 - centre.y;
            // Each node's weight × density, and the x-mean there.
            let nodes = LEGENDRE_NODES.map(|(node, w)| {
                let y = py + node;
                (w * density_y(y), slope * y)
            });
            let Some(line) = self.values.get_mut(row * width..(row + 1) * width) else {
                continue;
            };
            for col in cols.clone() {
                let px = (self.left + col) as f64 - centre.x;
                let mass: f64 = nodes
                    .iter()
                    .map(|&(wd, mean)| {
                        wd * (normal_cdf((px + 0.5 - mean) / across)
                            - normal_cdf((px - 0.5 - mean) / across))
                    })
                    .sum();
                if let Some(value) = line.get_mut(col) {
                    *value += (scale * mass) as f32;
                }
            }
        }
    }

    /// Adds `weight ×` the glow profile around `centre`, squeezed by `squeeze` and sampled at
    /// pixel centres as the round glow, times the area element `1 / ratio` (the same light
    /// as the round glow's). Without a squeeze, [`Patch::add_glow`].
    pub(crate) fn add_squeezed_glow(
        &mut self,
        centre: Point,
        glow_radius_px: f64,
        squeeze: Squeeze,
        weight: f64,
    ) {
        if squeeze.is_none() {
            return self.add_glow(centre, glow_radius_px, weight);
        }
        let weight = weight / squeeze.ratio;
        self.add_kernel(centre, glow_radius_px + 1.0, |px, py| {
            let m = squeeze.to_round(Point::new(px - centre.x, py - centre.y));
            weight * glow_profile(m.x * m.x + m.y * m.y, glow_radius_px)
        });
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::{FRAC_PI_2, PI};

    /// Light's total and its second central moments along and across the axis.
    fn moments(patch: &Patch, axis_rad: f64) -> (f64, f64, f64) {
        let (s, c) = axis_rad.sin_cos();
        let mut total = 0.0;
        let (mut sx, mut sy) = (0.0, 0.0);
        let pixels = |f: &mut dyn FnMut(f64, f64, f64)| {
            for row in 0..patch.height {
                for col in 0..patch.width {
                    let v = f64::from(patch.values[row * patch.width + col]);
                    f((patch.left + col) as f64, (patch.top + row) as f64, v);
                }
            }
        };
        pixels(&mut |x, y, v| {
            total += v;
            sx += v * x;
            sy += v * y;
        });
        let (cx, cy) = (sx / total, sy / total);
        let (mut along, mut across) = (0.0, 0.0);
        pixels(&mut |x, y, v| {
            let (dx, dy) = (x - cx, y - cy);
            along += v * (dx * c + dy * s).powi(2);
            across += v * (-dx * s + dy * c).powi(2);
        });
        (total, along / total, across / total)
    }

    const CENTRE: Point = Point { x: 40.37, y: 31.82 };

    fn patch() -> Patch {
        Patch::around(CENTRE, CENTRE, 30.0, 96, 72)
    }

    /// A pixel's own variance (1/12 along any axis through the box) adds to a spot's.
    const PIXEL_VARIANCE: f64 = 1.0 / 12.0;

    #[test]
    fn the_map_stretches_the_squeezed_axis_back() {
        let squeeze = Squeeze {
            ratio: 0.7,
            axis_rad: 0.6,
        };
        let (s, c) = 0.6f64.sin_cos();
        let along = squeeze.to_round(Point::new(c, s));
        let across = squeeze.to_round(Point::new(-s, c));
        assert!((along.x - c / 0.7).abs() < 1e-12 && (along.y - s / 0.7).abs() < 1e-12);
        assert!((across.x + s).abs() < 1e-12 && (across.y - c).abs() < 1e-12);
    }

    #[test]
    fn disk_polygon_area_is_exact() {
        let square = |h: f64| [(-h, -h), (h, -h), (h, h), (-h, h)].map(|(x, y)| Point::new(x, y));
        // The square inside the disk, the disk inside the square, and a quarter disk.
        assert!((disk_polygon_area(5.0, &square(1.0)) - 4.0).abs() < 1e-12);
        assert!((disk_polygon_area(1.0, &square(3.0)) - PI).abs() < 1e-12);
        let quadrant =
            [(0.0, 0.0), (3.0, 0.0), (3.0, 3.0), (0.0, 3.0)].map(|(x, y)| Point::new(x, y));
        assert!((disk_polygon_area(2.0, &quadrant) - PI).abs() < 1e-12);
        // Against the round renderer's disk–rectangle area, for cut pixels.
        for (x0, y0) in [(2.3, -0.2), (1.7, 1.6), (-0.7, 0.4)] {
            let corners = [
                (x0, y0),
                (x0 + 1.0, y0),
                (x0 + 1.0, y0 + 1.0),
                (x0, y0 + 1.0),
            ]
            .map(|(x, y)| Point::new(x, y));
            let exact = super::super::optics::disk_rect_area(3.0, x0, x0 + 1.0, y0, y0 + 1.0);
            assert!((disk_polygon_area(3.0, &corners) - exact).abs() < 1e-12);
        }
    }

    /// The squeezed spot's light per pixel by brute force: `light(round-frame offset)` at
    /// `n × n` points of each pixel's square, times the area element `1 / ratio`.
    fn sampled(squeeze: Squeeze, n: usize, light: impl Fn(Point) -> f64) -> Patch {
        let mut p = patch();
        let step = 1.0 / n as f64;
        p.add_kernel(CENTRE, 30.0, |px, py| {
            let mut sum = 0.0;
            for i in 0..n {
                for j in 0..n {
                    let x = px - 0.5 + (i as f64 + 0.5) * step - CENTRE.x;
                    let y = py - 0.5 + (j as f64 + 0.5) * step - CENTRE.y;
                    sum += light(squeeze.to_round(Point::new(x, y)));
                }
            }
            sum * step * step / squeeze.ratio
        });
        p
    }

    /// The largest difference between two patches over the same pixels.
    fn largest_difference(a: &Patch, b: &Patch) -> f64 {
        a.values
            .iter()
            .zip(&b.values)
            .map(|(x, y)| f64::from((x - y).abs()))
            .fold(0.0, f64::max)
    }

    /// The ellipse's and the squeezed Gaussian's pixels against brute-force sampling, on a
    /// small spot cut by many pixels (the rim's coverage is exact, the sampling is not: it is
    /// off by up to about a sub-sample's share of a pixel).
    #[test]
    fn squeezed_spots_match_sampling_pixel_by_pixel() {
        let squeeze = Squeeze {
            ratio: 0.67,
            axis_rad: 0.5,
        };
        let mut disk = patch();
        disk.add_squeezed_disk(CENTRE, 2.1, squeeze, 1.0);
        let sampled_disk = sampled(squeeze, 128, |m| f64::from(u8::from(m.x.hypot(m.y) <= 2.1)));
        let disk_error = largest_difference(&disk, &sampled_disk);
        assert!(disk_error < 0.02, "disk off by {disk_error}");
        let mut gaussian = patch();
        gaussian.add_squeezed_gaussian(CENTRE, 0.8, squeeze, 1.0);
        let sampled_gaussian = sampled(squeeze, 32, |m| {
            (-0.5 * (m.x * m.x + m.y * m.y) / 0.64).exp()
        });
        let gaussian_error = largest_difference(&gaussian, &sampled_gaussian);
        assert!(gaussian_error < 1e-3, "Gaussian off by {gaussian_error}");
    }

    /// The squeezed disk holds the round disk's light, and its second moments along and across
    /// the axis (less the pixel's own) are in the ratio's square, for axes at several angles.
    /// The disk is wide, so that the pixel grid's aliasing of the moments is small.
    #[test]
    fn a_squeezed_disk_keeps_its_light_and_has_the_ratio() {
        let radius = 9.0;
        for (ratio, axis_rad) in [(0.67, 0.0), (0.8, 0.5), (0.7, FRAC_PI_2), (0.9, 2.4)] {
            let mut p = patch();
            p.add_squeezed_disk(CENTRE, radius, Squeeze { ratio, axis_rad }, 2.0);
            let (total, along, across) = moments(&p, axis_rad);
            let round = 2.0 * PI * radius * radius;
            assert!(
                (total - round).abs() < 1e-4 * round,
                "{ratio}: {total} vs {round}"
            );
            let measured = ((along - PIXEL_VARIANCE) / (across - PIXEL_VARIANCE)).sqrt();
            assert!((measured - ratio).abs() < 2e-3, "{ratio}: {measured}");
            let expected_across = radius * radius / 4.0 + PIXEL_VARIANCE;
            assert!(
                (across - expected_across).abs() < 2e-3 * expected_across,
                "{across}"
            );
        }
    }

    /// The squeezed Gaussian holds the round one's light, and its variances along and across
    /// the axis are `(ratio σ)²` and `σ²` (plus the pixel's own), for spots wide enough that
    /// the pixel grid's aliasing of the moments is small.
    #[test]
    fn a_squeezed_gaussian_keeps_its_light_and_has_the_ratio() {
        for (sigma, ratio, axis_rad) in [
            (1.5, 0.67, 0.3),
            (1.5, 0.8, FRAC_PI_2),
            (2.7, 0.7, 2.0),
            (2.0, 0.9, 0.0),
        ] {
            let mut p = patch();
            p.add_squeezed_gaussian(CENTRE, sigma, Squeeze { ratio, axis_rad }, 3.0);
            let (total, along, across) = moments(&p, axis_rad);
            let round = 3.0 * std::f64::consts::TAU * sigma * sigma;
            assert!(
                (total - round).abs() < 1e-3 * round,
                "{sigma} {ratio}: {total} vs {round}"
            );
            let expected_along = (ratio * sigma).powi(2) + PIXEL_VARIANCE;
            let expected_across = sigma * sigma + PIXEL_VARIANCE;
            assert!(
                (along - expected_along).abs() < 2e-3 * expected_along,
                "{sigma} {ratio}: along {along} vs {expected_along}"
            );
            assert!(
                (across - expected_across).abs() < 2e-3 * expected_across,
                "{sigma} {ratio}: across {across} vs {expected_across}"
            );
        }
    }

    /// The squeezed glow (sampled at pixel centres, as the round one) holds the round glow's
    /// light and is squeezed by the ratio along its axis.
    #[test]
    fn a_squeezed_glow_keeps_its_light_and_has_the_ratio() {
        let (ratio, axis_rad) = (0.7, 1.1);
        let mut round = patch();
        round.add_glow(CENTRE, 12.0, 0.1);
        let mut squeezed = patch();
        squeezed.add_squeezed_glow(CENTRE, 12.0, Squeeze { ratio, axis_rad }, 0.1);
        let (round_total, round_along, _) = moments(&round, axis_rad);
        let (total, along, across) = moments(&squeezed, axis_rad);
        assert!((total - round_total).abs() < 2e-3 * round_total);
        assert!(
            (along / across - ratio * ratio).abs() < 0.01,
            "{along} {across}"
        );
        assert!((across - round_along).abs() < 0.01 * round_along);
    }

    /// Without a squeeze each kernel is the round one, to the bit.
    #[test]
    fn no_squeeze_draws_the_round_spot() {
        let (mut a, mut b) = (patch(), patch());
        a.add_disk(CENTRE, 2.3, 1.5);
        a.add_gaussian(CENTRE, 1.1, 2.0);
        a.add_glow(CENTRE, 9.0, 0.05);
        b.add_squeezed_disk(CENTRE, 2.3, Squeeze::NONE, 1.5);
        b.add_squeezed_gaussian(CENTRE, 1.1, Squeeze::NONE, 2.0);
        b.add_squeezed_glow(CENTRE, 9.0, Squeeze::NONE, 0.05);
        assert_eq!(a.values, b.values);
    }
}
