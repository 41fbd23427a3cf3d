//! A blob's rough path from its second moments, for a blob fatter than it is long.
//!
//! The streak fit ([`super::fit`]) starts from a rough path. For a streak longer than it is
//! wide the skeleton gives one (and follows an arc). For a short streak in a wide saturated
//! glow the blob is nearly round, and the skeleton of a round blob is noise: its "ends" may
//! lie across the streak, or off it by half the blob's width, and the fit, started there,
//! settles in a wrong minimum. The saturated blob of a swept spot is close to a stadium (a
//! rectangle as long as the path, capped by two half-disks), whose area and principal second
//! moments give the path's length, direction and middle: no skeleton needed.

/// A blob's pixel count, mean and second central moments.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Moments {
    area_px: f32,
    mean_px: (f32, f32),
    /// Variances along x and y and the covariance (px²).
    xx: f32,
    yy: f32,
    xy: f32,
}

/// The path of the stadium with a blob's moments.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StadiumPath {
    /// Both ends of the path.
    pub ends_px: [(f32, f32); 2],
    /// Its middle (the blob's mean).
    pub mid_px: (f32, f32),
    /// The stadium's width (twice its caps' radius).
    pub width_px: f32,
}

/// Bisection steps for the stadium's length (to well under a thousandth of a pixel).
const BISECTION_STEPS: usize = 40;

impl Moments {
    /// Of the pixels of `runs`, each `(y, x0, x1)`: pixels `x0..=x1` of row `y` (`None` for
    /// no pixels).
    pub fn of_runs(runs: impl Iterator<Item = (u16, u16, u16)>) -> Option<Self> {
        // Sums about the first pixel, so that large coordinates do not swamp the f64 sums.
        let mut origin: Option<(f64, f64)> = None;
        let (mut n, mut sx, mut sy, mut sxx, mut syy, mut sxy) = (0.0f64, 0.0, 0.0, 0.0, 0.0, 0.0);
        for (y, x0, x1) in runs {
            let (ox, oy) = *origin.get_or_insert((f64::from(x0), f64::from(y)));
            let (a, b) = (f64::from(x0) - ox, f64::from(x1.max(x0)) - ox);
            let count = b - a + 1.0;
            let y = f64::from(y) - oy;
            // Σx and Σx² over the integers a..=b.
            let sum_x = 0.5 * (a + b) * count;
            let sum_xx = (b * (b + 1.0) * (2.0 * b + 1.0) - (a - 1.0) * a * (2.0 * a - 1.0)) / 6.0;
            n += count;
            sx += sum_x;
            sxx += sum_xx;
            sy += y * count;
            syy += y * y * count;
            sxy += y * sum_x;
        }
        let (ox, oy) = origin?;
        let (mx, my) = (sx / n, sy / n);
        Some(Moments {
            area_px: n as f32,
            mean_px: ((ox + mx) as f32, (oy + my) as f32),
            xx: (sxx / n - mx * mx) as f32,
            yy: (syy / n - my * my) as f32,
            xy: (sxy / n - mx * my) as f32,
        })
    }

    /// The pixel count.
    pub fn area_px(&self) -> f32 {
        self.area_px
    }

    /// The stadium of the same area whose principal moments differ as the blob's do.
    pub fn stadium(&self) -> StadiumPath {
        let half_diff = 0.5 * (self.xx - self.yy);
        let spread = half_diff.hypot(self.xy);
        // Variance along the long axis minus across it.
        let difference = 2.0 * spread;
        let angle = 0.5 * self.xy.atan2(half_diff);
        let (dx, dy) = (angle.cos(), angle.sin());
        let area = self.area_px.max(1.0);
        let (mut lo, mut hi) = (0.0f32, area);
        for _ in 0..BISECTION_STEPS {
            let mid = 0.5 * (lo + hi);
            if stadium_difference(mid, area) < difference {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let length = 0.5 * (lo + hi);
        let half = 0.5 * length;
        let (mx, my) = self.mean_px;
        StadiumPath {
            ends_px: [
                (mx - half * dx, my - half * dy),
                (mx + half * dx, my + half * dy),
            ],
            mid_px: self.mean_px,
            width_px: 2.0 * cap_radius(length, area),
        }
    }
}

/// The caps' radius of the stadium of path `length` and `area`.
fn cap_radius(length: f32, area: f32) -> f32 {
    use core::f32::consts::PI;
    ((length * length + PI * area).sqrt() - length) / PI
}

/// The variance along a stadium's axis minus that across it, for path `length` and `area`:
/// `L²/12` for a long one, growing from zero for a short one.
fn stadium_difference(length: f32, area: f32) -> f32 {
    use core::f32::consts::PI;
    let (l, r) = (length, cap_radius(length, area));
    let along = r * l * l * l / 6.0 + PI * r * r * l * l / 4.0 + 4.0 * r * r * r * l / 3.0;
    let across = 2.0 * l * r * r * r / 3.0;
    (along - across) / area
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The moments of the pixels `inside` within a square of side `n`.
    fn moments_of(n: u16, inside: impl Fn(f32, f32) -> bool) -> Moments {
        let mut runs = Vec::new();
        for y in 0..n {
            let mut start = None;
            for x in 0..=n {
                let on = x < n && inside(f32::from(x), f32::from(y));
                match (on, start) {
                    (true, None) => start = Some(x),
                    (false, Some(x0)) => {
                        runs.push((y, x0, x - 1));
                        start = None;
                    }
                    _ => {}
                }
            }
        }
        Moments::of_runs(runs.into_iter()).unwrap()
    }

    fn stadium_at(ends: [(f32, f32); 2], radius: f32) -> impl Fn(f32, f32) -> bool {
        move |x, y| {
            let [a, b] = ends;
            let (dx, dy) = (b.0 - a.0, b.1 - a.1);
            let l2 = dx * dx + dy * dy;
            let t = (((x - a.0) * dx + (y - a.1) * dy) / l2).clamp(0.0, 1.0);
            (x - a.0 - t * dx).hypot(y - a.1 - t * dy) <= radius
        }
    }

    #[test]
    fn a_drawn_stadium_gives_back_its_path_long_or_short() {
        for (ends, radius) in [
            ([(20.0, 30.0), (80.0, 52.0)], 3.0),
            ([(40.0, 40.0), (46.0, 37.0)], 12.0),
            ([(50.0, 50.0), (50.0, 55.0)], 20.0),
        ] {
            let m = moments_of(100, stadium_at(ends, radius));
            let s = m.stadium();
            let d = |p: (f32, f32), q: (f32, f32)| (p.0 - q.0).hypot(p.1 - q.1);
            let error = (d(s.ends_px[0], ends[0]).max(d(s.ends_px[1], ends[1])))
                .min(d(s.ends_px[0], ends[1]).max(d(s.ends_px[1], ends[0])));
            assert!(
                error < 0.6,
                "{ends:?} r {radius}: {s:?}, ends {error:.2} px off"
            );
            assert!((s.width_px - 2.0 * radius).abs() < 1.0, "{s:?}");
        }
    }

    #[test]
    fn a_disk_is_a_path_of_no_length() {
        let m = moments_of(60, |x, y| (x - 30.0).hypot(y - 31.0) <= 15.0);
        let s = m.stadium();
        let length = (s.ends_px[0].0 - s.ends_px[1].0).hypot(s.ends_px[0].1 - s.ends_px[1].1);
        assert!(length < 0.5, "{s:?}");
        assert!((s.mid_px.0 - 30.0).abs() < 1e-3 && (s.mid_px.1 - 31.0).abs() < 1e-3);
    }
}
