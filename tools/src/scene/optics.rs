//! Optics: how much LED (and glare) light lands on each pixel.
//!
//! The LED is a uniformly bright disk. A pixel receives the disk's radiance times the exact
//! fraction of the pixel's square that the disk covers (an analytic disk–rectangle area, not
//! a sub-sample estimate), so the rendered light's centroid is the disk's centre to rounding
//! error and its integral is exactly `π R² · peak`. A faint glow (a smooth compact bump) can
//! surround the LED, as lens flare does on a real webcam.
//!
//! The LED's spot need not be a disk ([`Spot`]): a real LED seen through a cheap lens is closer
//! to a Gaussian, or a narrow Gaussian core inside a wide glow (bloom), and its width changes
//! with focus and distance. Gaussians are integrated exactly over each pixel's square too (a
//! product of error-function differences), so their centroid is exact as well.
//!
//! Radiance is in linear sensor units where 1.0 is the clip level.

use super::squeeze::Squeeze;
use super::trajectory::Point;

/// The moving LED.
#[derive(Clone, Debug, PartialEq)]
pub struct Led {
    /// Radius of the bright disk; for the other spots, the radius within which the LED counts
    /// as visible (about two standard deviations of the core).
    pub radius_px: f64,
    /// The spot's profile.
    pub spot: Spot,
    /// How the lens squeezes the spot where it is imaged ([`Squeeze::NONE`]: round). With a
    /// [`View`](super::View), whose own lens maps the picture, leave it round.
    pub squeeze: Squeeze,
    /// Radiance at the spot's centre, in multiples of the clip level (several times 1.0 for a
    /// strong LED, so even streaks saturate).
    pub peak: f64,
    /// Peak radiance of the glow around the disk (0 disables it). Keep it faint: it adds to
    /// the floor, and floor + glow must stay below clip.
    pub glow_peak: f64,
    /// Radius out to which the glow reaches; its profile is `(1 - (d/ρ)²)²`.
    pub glow_radius_px: f64,
}

/// The LED's blur spot on the sensor: its light at distance `d` from its centre, relative to
/// the centre's.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Spot {
    /// A uniformly bright disk of [`Led::radius_px`].
    Disk,
    /// A Gaussian, `exp(-d² / 2σ²)`.
    Gaussian {
        /// Standard deviation.
        sigma_px: f64,
    },
    /// A narrow Gaussian core inside a wide Gaussian glow (bloom): `exp(-d²/2σ²) + glow_ratio ·
    /// exp(-d²/2σ_g²)`.
    Bloom {
        /// Standard deviation of the core.
        sigma_px: f64,
        /// Standard deviation of the glow.
        glow_sigma_px: f64,
        /// The glow's centre radiance relative to the core's.
        glow_ratio: f64,
    },
}

impl Spot {
    /// The Gaussian components as (σ, relative peak), at most two; none for a disk.
    pub(crate) fn gaussians(self) -> [(f64, f64); 2] {
        match self {
            Spot::Disk => [(0.0, 0.0); 2],
            Spot::Gaussian { sigma_px } => [(sigma_px, 1.0), (0.0, 0.0)],
            Spot::Bloom {
                sigma_px,
                glow_sigma_px,
                glow_ratio,
            } => [(sigma_px, 1.0), (glow_sigma_px, glow_ratio)],
        }
    }

    /// How far from the centre the spot's light reaches (beyond it, under 1e-4 of the peak).
    pub(crate) fn reach_px(self, radius_px: f64) -> f64 {
        match self {
            Spot::Disk => radius_px,
            _ => self
                .gaussians()
                .iter()
                .map(|&(sigma, _)| GAUSSIAN_REACH_SIGMAS * sigma)
                .fold(0.0, f64::max),
        }
    }
}

/// A Gaussian is drawn out to this many standard deviations (exp(-4.3²/2) ≈ 1e-4).
pub(super) const GAUSSIAN_REACH_SIGMAS: f64 = 4.3;

/// The standard normal cumulative distribution, to about 1e-7 (Abramowitz & Stegun 7.1.26 on
/// erf, whose error is at most 1.5e-7).
pub(crate) fn normal_cdf(z: f64) -> f64 {
    let x = z.abs() / std::f64::consts::SQRT_2;
    let t = 1.0 / (1.0 + 0.327_591_1 * x);
    let poly = t
        * (0.254_829_592
            + t * (-0.284_496_736
                + t * (1.421_413_741 + t * (-1.453_152_027 + t * 1.061_405_429))));
    let erf = 1.0 - poly * (-x * x).exp();
    if z >= 0.0 {
        0.5 * (1.0 + erf)
    } else {
        0.5 * (1.0 - erf)
    }
}

/// A static, saturated light (a lamp, a reflection) that never moves.
#[derive(Clone, Debug, PartialEq)]
pub struct Glare {
    /// Centre of the disk.
    pub centre_px: Point,
    /// Radius of the disk.
    pub radius_px: f64,
    /// Radiance inside the disk, in multiples of the clip level.
    pub peak: f64,
}

/// Exact area of the intersection of the disk of radius `r` centred at the origin with the
/// axis-aligned rectangle `[x0, x1] × [y0, y1]`.
///
/// The area is `∫ len([y0, y1] ∩ [-s(x), s(x)]) dx` with `s(x) = sqrt(r² - x²)`. Between the
/// breakpoints where `s(x)` crosses `|y0|` or `|y1|`, the integrand is a fixed combination of
/// constants and `±s(x)`, each of which integrates in closed form.
pub(crate) fn disk_rect_area(r: f64, x0: f64, x1: f64, y0: f64, y1: f64) -> f64 {
    let (x0, x1) = (x0.max(-r), x1.min(r));
    if x0 >= x1 || y0 >= y1 || r <= 0.0 {
        return 0.0;
    }
    let mut breaks = [x0; 6];
    let mut count = 1;
    for yb in [y0, y1] {
        if yb.abs() < r {
            let h = (r * r - yb * yb).sqrt();
            for xb in [-h, h] {
                if xb > x0 && xb < x1 {
                    if let Some(slot) = breaks.get_mut(count) {
                        *slot = xb;
                        count += 1;
                    }
                }
            }
        }
    }
    if let Some(slot) = breaks.get_mut(count) {
        *slot = x1;
        count += 1;
    }
    let breaks = breaks.get_mut(..count).unwrap_or_default();
    breaks.sort_by(f64::total_cmp);

    // Antiderivative of sqrt(r² - x²).
    let g = |x: f64| {
        0.5 * (x * (r * r - x * x).max(0.0).sqrt() + r * r * (x / r).clamp(-1.0, 1.0).asin())
    };
    breaks
        .windows(2)
        .map(|w| {
            let (a, b) = match *w {
                [a, b] => (a, b),
                _ => return 0.0,
            };
            let mid = 0.5 * (a + b);
            let s_mid = (r * r - mid * mid).max(0.0).sqrt();
            let top_is_circle = s_mid < y1;
            let bottom_is_circle = -s_mid > y0;
            let top = if top_is_circle { s_mid } else { y1 };
            let bottom = if bottom_is_circle { -s_mid } else { y0 };
            if top <= bottom {
                return 0.0;
            }
            let arc = g(b) - g(a);
            let top_area = if top_is_circle { arc } else { y1 * (b - a) };
            let bottom_area = if bottom_is_circle { -arc } else { y0 * (b - a) };
            top_area - bottom_area
        })
        .sum()
}

/// Fraction of pixel `(px, py)` covered by the disk; the pixel spans `px ± 0.5`, `py ± 0.5`.
pub(crate) fn pixel_disk_coverage(centre: Point, radius_px: f64, px: f64, py: f64) -> f64 {
    let dx = px - centre.x;
    let dy = py - centre.y;
    // Cheap exits: the nearest point of the square outside the disk, or its farthest corner
    // inside it. Only pixels the rim crosses need the exact integral.
    let near_x = (dx.abs() - 0.5).max(0.0);
    let near_y = (dy.abs() - 0.5).max(0.0);
    let r2 = radius_px * radius_px;
    if near_x * near_x + near_y * near_y >= r2 {
        return 0.0;
    }
    let far_x = dx.abs() + 0.5;
    let far_y = dy.abs() + 0.5;
    if far_x * far_x + far_y * far_y <= r2 {
        return 1.0;
    }
    disk_rect_area(radius_px, dx - 0.5, dx + 0.5, dy - 0.5, dy + 0.5)
}

/// Widest Gaussian (in pixel columns) [`Patch::add_gaussian`] draws, enough for
/// [`MAX_SPOT_SIGMA_PX`].
const MAX_GAUSSIAN_SPAN: usize = 256;

/// Largest accepted spot or glow standard deviation.
pub(crate) const MAX_SPOT_SIGMA_PX: f64 = 25.0;

/// Glow radiance profile at distance² `d2` from the centre: `(1 - d²/ρ²)²` inside ρ.
pub(super) fn glow_profile(d2: f64, glow_radius_px: f64) -> f64 {
    let u = 1.0 - d2 / (glow_radius_px * glow_radius_px);
    if u > 0.0 {
        u * u
    } else {
        0.0
    }
}

/// A rectangle of radiance values over part of the frame, for the light that moves.
///
/// Only the LED's bounding box over the exposure is computed, which keeps a frame cheap.
#[derive(Clone, Debug, Default)]
pub(crate) struct Patch {
    /// Leftmost pixel column covered.
    pub left: usize,
    /// Topmost pixel row covered.
    pub top: usize,
    pub width: usize,
    pub height: usize,
    /// Row-major radiance, `width * height` values.
    pub values: Vec<f32>,
}

impl Patch {
    /// A zeroed patch over the pixels within `margin_px` of the box `[min, max]`, clipped to
    /// a `width_px × height_px` frame (possibly empty).
    pub(crate) fn around(
        min: Point,
        max: Point,
        margin_px: f64,
        width_px: usize,
        height_px: usize,
    ) -> Self {
        let span = |lo: f64, hi: f64, size: usize| -> (usize, usize) {
            // Pixel i covers [i - 0.5, i + 0.5]; keep pixels that touch [lo, hi].
            let first = (lo - margin_px + 0.5).floor().max(0.0);
            let last = (hi + margin_px + 0.5).floor().min(size as f64 - 1.0);
            // NaN bounds (from a non-finite position) give an empty span too.
            if first.is_nan() || last.is_nan() || first > last {
                return (0, 0);
            }
            (first as usize, (last - first) as usize + 1)
        };
        let (left, width) = span(min.x, max.x, width_px);
        let (top, height) = span(min.y, max.y, height_px);
        Self {
            left,
            top,
            width,
            height,
            values: vec![0.0; width * height],
        }
    }

    /// Adds `weight ×` (disk coverage) for a disk at `centre`, visiting in each row only
    /// the pixels the disk's chord across that row's band can reach.
    pub(crate) fn add_disk(&mut self, centre: Point, radius_px: f64, weight: f64) {
        let reach = radius_px + 0.5;
        let rows = self.index_range(centre.y - reach, centre.y + reach, self.top, self.height);
        let width = self.width;
        for row in rows {
            let py = (self.top + row) as f64;
            let near_y = ((py - centre.y).abs() - 0.5).max(0.0);
            if near_y >= radius_px {
                continue;
            }
            let half_chord = (radius_px * radius_px - near_y * near_y).sqrt() + 0.5;
            let cols = self.index_range(
                centre.x - half_chord,
                centre.x + half_chord,
                self.left,
                width,
            );
            let Some(line) = self.values.get_mut(row * width..(row + 1) * width) else {
                continue;
            };
            for col in cols {
                if let Some(value) = line.get_mut(col) {
                    let px = (self.left + col) as f64;
                    *value += (weight * pixel_disk_coverage(centre, radius_px, px, py)) as f32;
                }
            }
        }
    }

    /// Adds a Gaussian of standard deviation `sigma_px` and centre radiance `peak` at
    /// `centre`, integrated exactly over each pixel's square: the pixel gets `peak · 2πσ²`
    /// times the Gaussian's probability mass inside the square.
    pub(crate) fn add_gaussian(&mut self, centre: Point, sigma_px: f64, peak: f64) {
        let reach = GAUSSIAN_REACH_SIGMAS * sigma_px + 0.5;
        let cols = self.index_range(centre.x - reach, centre.x + reach, self.left, self.width);
        let rows = self.index_range(centre.y - reach, centre.y + reach, self.top, self.height);
        let mass = |pixel: f64, c: f64| {
            normal_cdf((pixel + 0.5 - c) / sigma_px) - normal_cdf((pixel - 0.5 - c) / sigma_px)
        };
        let mut column_mass = [0.0f64; MAX_GAUSSIAN_SPAN];
        for (slot, col) in column_mass.iter_mut().zip(cols.clone()) {
            *slot = mass((self.left + col) as f64, centre.x);
        }
        let scale = peak * std::f64::consts::TAU * sigma_px * sigma_px;
        let width = self.width;
        for row in rows {
            let row_mass = scale * mass((self.top + row) as f64, centre.y);
            let Some(line) = self.values.get_mut(row * width..(row + 1) * width) else {
                continue;
            };
            for (col, m) in cols.clone().zip(column_mass) {
                if let Some(value) = line.get_mut(col) {
                    *value += (row_mass * m) as f32;
                }
            }
        }
    }

    /// Adds `weight ×` the glow profile around `centre`.
    pub(crate) fn add_glow(&mut self, centre: Point, glow_radius_px: f64, weight: f64) {
        self.add_kernel(centre, glow_radius_px + 1.0, |px, py| {
            let d2 = (px - centre.x).powi(2) + (py - centre.y).powi(2);
            weight * glow_profile(d2, glow_radius_px)
        });
    }

    /// Adds `kernel(px, py)` to every patch pixel within `reach_px` (per axis) of `centre`.
    pub(super) fn add_kernel(
        &mut self,
        centre: Point,
        reach_px: f64,
        kernel: impl Fn(f64, f64) -> f64,
    ) {
        let cols = self.index_range(
            centre.x - reach_px,
            centre.x + reach_px,
            self.left,
            self.width,
        );
        let rows = self.index_range(
            centre.y - reach_px,
            centre.y + reach_px,
            self.top,
            self.height,
        );
        let width = self.width;
        for row in rows {
            let py = (self.top + row) as f64;
            let Some(line) = self.values.get_mut(row * width..(row + 1) * width) else {
                continue;
            };
            for col in cols.clone() {
                if let Some(value) = line.get_mut(col) {
                    *value += kernel((self.left + col) as f64, py) as f32;
                }
            }
        }
    }

    /// Patch-relative indices of the pixels whose centres lie in `[lo, hi]`.
    pub(super) fn index_range(
        &self,
        lo: f64,
        hi: f64,
        origin: usize,
        len: usize,
    ) -> std::ops::Range<usize> {
        let first = (lo - origin as f64).ceil().max(0.0);
        let end = ((hi - origin as f64).floor() + 1.0).min(len as f64);
        if first < end {
            first as usize..end as usize
        } else {
            0..0
        }
    }

    /// Radiance at frame pixel `(x, y)`, 0 outside the patch.
    #[cfg(test)]
    pub(crate) fn at(&self, x: usize, y: usize) -> f32 {
        if x < self.left
            || y < self.top
            || x >= self.left + self.width
            || y >= self.top + self.height
        {
            return 0.0;
        }
        self.values
            .get((y - self.top) * self.width + (x - self.left))
            .copied()
            .unwrap_or(0.0)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::PI;

    /// Brute-force coverage by a fine grid of sub-samples, to check the closed form against.
    fn sampled_area(r: f64, x0: f64, x1: f64, y0: f64, y1: f64) -> f64 {
        let n = 400;
        let (dx, dy) = ((x1 - x0) / n as f64, (y1 - y0) / n as f64);
        let mut inside = 0usize;
        for i in 0..n {
            for j in 0..n {
                let x = x0 + (i as f64 + 0.5) * dx;
                let y = y0 + (j as f64 + 0.5) * dy;
                if x * x + y * y <= r * r {
                    inside += 1;
                }
            }
        }
        inside as f64 * dx * dy
    }

    #[test]
    fn disk_rect_area_matches_sampling() {
        let cases = [
            (3.0, -0.5, 0.5, -0.5, 0.5),
            (3.0, 2.3, 3.3, -0.2, 0.8),
            (3.0, 1.7, 2.7, 1.6, 2.6),
            (1.2, -0.7, 0.3, 0.4, 1.4),
            (0.3, -0.5, 0.5, -0.5, 0.5),
            (2.0, 1.9, 2.9, 1.9, 2.9),
            (4.0, -0.5, 0.5, 3.6, 4.6),
        ];
        for (r, x0, x1, y0, y1) in cases {
            let exact = disk_rect_area(r, x0, x1, y0, y1);
            let sampled = sampled_area(r, x0, x1, y0, y1);
            assert!(
                (exact - sampled).abs() < 2e-3,
                "r={r} [{x0},{x1}]x[{y0},{y1}]: exact {exact} sampled {sampled}"
            );
        }
    }

    #[test]
    fn whole_disk_and_quadrant_areas_are_exact() {
        assert!((disk_rect_area(2.5, -3.0, 3.0, -3.0, 3.0) - PI * 6.25).abs() < 1e-12);
        assert!((disk_rect_area(2.5, 0.0, 3.0, 0.0, 3.0) - PI * 6.25 / 4.0).abs() < 1e-12);
        assert_eq!(disk_rect_area(2.5, 2.6, 3.0, 0.0, 1.0), 0.0);
    }

    /// The sum of the rendered coverage is exactly the disk's area, and its centroid the
    /// disk's centre up to pixel-locking: a pixel-centre centroid of box-integrated light is
    /// biased by ~1e-3 px for a sharp-edged disk, on a real sensor as here.
    #[test]
    fn coverage_centroid_and_sum_are_exact() {
        for centre in [
            Point::new(20.3, 17.71),
            Point::new(21.5, 18.0),
            Point::new(19.02, 16.49),
        ] {
            let radius = 3.7;
            let mut patch = Patch::around(centre, centre, radius + 1.0, 64, 48);
            patch.add_disk(centre, radius, 1.0);
            let (mut sum, mut sx, mut sy) = (0.0, 0.0, 0.0);
            for y in 0..48 {
                for x in 0..64 {
                    let v = f64::from(patch.at(x, y));
                    sum += v;
                    sx += v * x as f64;
                    sy += v * y as f64;
                }
            }
            assert!((sum - PI * radius * radius).abs() < 1e-4, "sum {sum}");
            assert!(
                (sx / sum - centre.x).abs() < 0.005,
                "cx {} vs {}",
                sx / sum,
                centre.x
            );
            assert!(
                (sy / sum - centre.y).abs() < 0.005,
                "cy {} vs {}",
                sy / sum,
                centre.y
            );
        }
    }

    /// A pixel-integrated Gaussian holds exactly `2πσ² · peak` and is centred on its centre.
    #[test]
    fn gaussian_sum_and_centroid_are_exact() {
        for (centre, sigma) in [
            (Point::new(30.37, 22.8), 0.8),
            (Point::new(31.5, 20.02), 2.7),
        ] {
            let mut patch = Patch::around(centre, centre, 15.0, 64, 48);
            patch.add_gaussian(centre, sigma, 2.0);
            let (mut sum, mut sx, mut sy) = (0.0, 0.0, 0.0);
            for y in 0..48 {
                for x in 0..64 {
                    let v = f64::from(patch.at(x, y));
                    sum += v;
                    sx += v * x as f64;
                    sy += v * y as f64;
                }
            }
            let expected = 2.0 * std::f64::consts::TAU * sigma * sigma;
            assert!(
                (sum - expected).abs() < 1e-3 * expected,
                "sum {sum} vs {expected}"
            );
            assert!((sx / sum - centre.x).abs() < 1e-3 && (sy / sum - centre.y).abs() < 1e-3);
        }
        assert!((normal_cdf(0.0) - 0.5).abs() < 1e-9);
        assert!((normal_cdf(1.0) - 0.841_344_746).abs() < 2e-7);
    }

    #[test]
    fn glow_is_centred_on_the_led() {
        let centre = Point::new(30.37, 22.8);
        let mut patch = Patch::around(centre, centre, 10.0, 64, 48);
        patch.add_glow(centre, 8.0, 0.1);
        let (mut sum, mut sx, mut sy) = (0.0, 0.0, 0.0);
        for y in 0..48 {
            for x in 0..64 {
                let v = f64::from(patch.at(x, y));
                sum += v;
                sx += v * x as f64;
                sy += v * y as f64;
            }
        }
        assert!(sum > 0.0);
        assert!((sx / sum - centre.x).abs() < 1e-3 && (sy / sum - centre.y).abs() < 1e-3);
    }

    #[test]
    fn patch_is_clipped_to_the_frame() {
        let patch = Patch::around(Point::new(-3.0, 2.0), Point::new(5.0, 2.0), 4.0, 10, 4);
        assert_eq!((patch.left, patch.top), (0, 0));
        assert_eq!((patch.width, patch.height), (10, 4));
        let outside = Patch::around(Point::new(-30.0, 2.0), Point::new(-20.0, 2.0), 4.0, 10, 4);
        assert_eq!(outside.width * outside.height, 0);
    }
}
