//! Sub-pixel corners: straight lines fitted to the marker's four outer edges, intersected.
//!
//! A corner pixel alone is worth about a pixel; an edge is worth dozens of measurements. Along
//! each side, the brightness profile across the edge (black border inside, white margin outside)
//! is sampled by bilinear interpolation, and the edge's position on it is found by the area
//! method: for a step from `dark` to `light` blurred by any symmetric kernel, the area between the
//! profile and the light level equals `(light − dark) × (distance from the profile's start to
//! the edge)`. It uses every sample, so noise averages out, and needs no model of the blur. The
//! edge points are fitted with a line by weighted total least squares (weights: the local
//! contrast, so shadowed stretches count less), twice, re-sampling along the refined line.
//! Adjacent lines meet at the corners.

use crate::frame::Frame;
use crate::geometry::Point;

use super::grid::luma_bilinear;

/// Half-length of the profile across an edge, in pixels, at most: long enough for camera blur.
const MAX_PROFILE_HALF_PX: f64 = 3.0;
/// Share of a border cell the profile may reach inward (beyond it lie the inner cells).
const PROFILE_CELL_SHARE: f64 = 0.45;
/// Spacing of profile samples across the edge, in pixels.
const PROFILE_STEP_PX: f64 = 0.25;
/// Spacing of profiles along the edge, in pixels.
const ALONG_STEP_PX: f64 = 1.0;
/// Samples at each end of a profile averaged for the dark and light levels.
const LEVEL_SAMPLES: usize = 3;
/// Least contrast across the edge (luma levels) for a profile to count.
const MIN_EDGE_CONTRAST: f64 = 15.0;
/// Half-length of the second, narrow profile around the first estimate, in pixels at most:
/// fewer noisy pixels in the area, still wider than an edge blurred by a webcam.
const NARROW_HALF_PX: f64 = 1.5;
/// Profiles either side averaged for the dark and light levels (at 1 px apart: ±4 px).
const LEVEL_SMOOTHING: usize = 4;
/// A profile whose own levels differ from the averaged ones by more than this share of its
/// contrast sits at a shadow's edge and keeps its own levels.
const LEVEL_JUMP_SHARE: f64 = 0.1;
/// Refits of an edge line without its outlying points.
const ROBUST_PASSES: usize = 2;
/// Edge points farther from the line than this many mean absolute residuals are outliers...
const OUTLIER_FACTOR: f64 = 3.0;
/// ...but never closer than this, in pixels (noise alone reaches it).
const MIN_OUTLIER_PX: f64 = 0.05;
/// Refinement passes: each re-samples along the lines of the previous one.
const PASSES: usize = 2;
/// Most profile samples (`2 × MAX_PROFILE_HALF_PX / PROFILE_STEP_PX + 1`).
const MAX_PROFILE_SAMPLES: usize = 25;

/// Why corners could not be refined.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RefineError {
    /// Too few usable edge profiles on a side (cut off, low contrast, or too small).
    WeakEdge,
    /// Adjacent edge lines do not meet (parallel).
    Parallel,
}

/// A line `n · p = c` with `|n| = 1`.
#[derive(Debug, Clone, Copy)]
struct Line {
    normal: nalgebra::Vector2<f64>,
    offset: f64,
}

/// Refines clockwise `corners` of a marker with `cells` cells per side (border included).
pub fn refine_corners(
    frame: &Frame<'_>,
    corners: &[Point; 4],
    cells: usize,
    samples: &mut Vec<EdgeSample>,
) -> Result<[Point; 4], RefineError> {
    let mut current = *corners;
    for _ in 0..PASSES {
        let mut lines = [Line {
            normal: nalgebra::Vector2::zeros(),
            offset: 0.0,
        }; 4];
        for (k, line) in lines.iter_mut().enumerate() {
            *line = fit_edge(frame, current[k], current[(k + 1) % 4], cells, samples)?;
        }
        for k in 0..4 {
            current[k] = intersect(&lines[(k + 3) % 4], &lines[k])?;
        }
    }
    Ok(current)
}

/// One profile across an edge from the first, wide pass: where it starts, its first edge
/// estimate and its end levels. Kept in a buffer the detector allocates once.
#[derive(Debug, Clone, Copy, Default)]
pub struct EdgeSample {
    base: Point,
    offset_px: f64,
    dark: f64,
    light: f64,
    valid: bool,
    /// The final edge point and its weight (0 when the second pass dropped it).
    edge: Point,
    weight: f64,
}

/// Fits the edge from `a` to `b` (clockwise, so the marker is on the right, outward normal left).
///
/// Two passes: wide profiles give a first edge position and the dark and light levels; then the
/// levels are averaged along the edge (they vary slowly, while each profile's own ends carry the
/// full pixel noise) and a narrow profile centred on the first estimate gives the final position.
fn fit_edge(
    frame: &Frame<'_>,
    a: Point,
    b: Point,
    cells: usize,
    samples: &mut Vec<EdgeSample>,
) -> Result<Line, RefineError> {
    let along = b - a;
    let len_px = along.norm();
    let cell_px = len_px / cells as f64;
    let half_px = (PROFILE_CELL_SHARE * cell_px).min(MAX_PROFILE_HALF_PX);
    let steps = ((2.0 * half_px / PROFILE_STEP_PX) as usize + 1).min(MAX_PROFILE_SAMPLES);
    if steps < 2 * LEVEL_SAMPLES + 2 || len_px <= 0.0 || samples.capacity() == 0 {
        return Err(RefineError::WeakEdge);
    }
    let dir = along / len_px;
    let outward = nalgebra::Vector2::new(dir.y, -dir.x);
    // Keep clear of the corners, where the profile would cross the neighbouring edge.
    let margin_px = half_px + 1.0;
    let span_px = len_px - 2.0 * margin_px;
    if span_px <= 0.0 {
        return Err(RefineError::WeakEdge);
    }
    let along_step_px = ALONG_STEP_PX.max(span_px / samples.capacity() as f64);
    let profiles = ((span_px / along_step_px) as usize + 1).min(samples.capacity());
    let mut profile = [0.0f64; MAX_PROFILE_SAMPLES];
    let sample = |profile: &mut [f64], base: Point, start_px: f64| {
        for (j, v) in profile.iter_mut().enumerate() {
            let p = base + outward * (start_px + j as f64 * PROFILE_STEP_PX);
            *v = luma_bilinear(frame, p.x, p.y)?;
        }
        Some(())
    };

    samples.clear();
    for i in 0..profiles {
        let base = a + dir * (margin_px + i as f64 * along_step_px);
        let wide = &mut profile[..steps];
        let first = sample(wide, base, -half_px).and_then(|()| edge_offset(wide, -half_px));
        let s = match first {
            Some(e) => EdgeSample {
                base,
                offset_px: e.offset_px,
                dark: e.dark,
                light: e.light,
                valid: true,
                ..EdgeSample::default()
            },
            None => EdgeSample::default(),
        };
        // `profiles` is at most the capacity, so this never reallocates.
        if samples.len() < samples.capacity() {
            samples.push(s);
        }
    }

    let narrow_half_px = NARROW_HALF_PX.min(half_px);
    let narrow_steps =
        ((2.0 * narrow_half_px / PROFILE_STEP_PX) as usize + 1).min(MAX_PROFILE_SAMPLES);
    for i in 0..samples.len() {
        let Some(&s) = samples.get(i) else { break };
        let near = samples
            .get(i.saturating_sub(LEVEL_SMOOTHING)..(i + LEVEL_SMOOTHING + 1).min(samples.len()))
            .unwrap_or(&[]);
        let edge = s.valid.then(|| {
            let (mut dark, mut light, mut n) = (0.0, 0.0, 0.0);
            for t in near.iter().filter(|t| t.valid) {
                dark += t.dark;
                light += t.light;
                n += 1.0;
            }
            let (mut dark, mut light) = (dark / n, light / n);
            // Across a shadow's edge the levels jump: there the profile's own levels are better.
            let tolerance = LEVEL_JUMP_SHARE * (s.light - s.dark);
            if (dark - s.dark).abs() > tolerance || (light - s.light).abs() > tolerance {
                (dark, light) = (s.dark, s.light);
            }
            let start_px = s.offset_px - narrow_half_px;
            let narrow = &mut profile[..narrow_steps];
            sample(narrow, s.base, start_px)?;
            let contrast = light - dark;
            let offset_px = start_px + area_above(narrow, light) / contrast;
            ((offset_px - s.offset_px).abs() < narrow_half_px)
                .then_some((s.base + outward * offset_px, contrast))
        });
        if let (Some(t), Some(Some((p, w)))) = (samples.get_mut(i), edge) {
            (t.edge, t.weight) = (p, w);
        }
    }
    robust_line(samples)
}

/// The weighted line through the edge points, refitted without the points far from it (where
/// a shadow's edge or a speck crosses the profile).
fn robust_line(samples: &[EdgeSample]) -> Result<Line, RefineError> {
    let fit = |keep: &dyn Fn(&EdgeSample) -> bool| {
        let mut sums = WeightedSums::default();
        for s in samples.iter().filter(|s| s.weight > 0.0 && keep(s)) {
            sums.add(s.edge, s.weight);
        }
        sums.line()
    };
    let mut line = fit(&|_| true).ok_or(RefineError::WeakEdge)?;
    for _ in 0..ROBUST_PASSES {
        let residual = |s: &EdgeSample| (line.normal.dot(&s.edge.coords) - line.offset).abs();
        // Mean absolute residual of the kept points sets the scale for outliers.
        let (sum, n) = samples
            .iter()
            .filter(|s| s.weight > 0.0)
            .fold((0.0, 0.0), |(a, n), s| (a + residual(s), n + 1.0));
        let limit = (OUTLIER_FACTOR * sum / n).max(MIN_OUTLIER_PX);
        line = fit(&|s| residual(s) <= limit).ok_or(RefineError::WeakEdge)?;
    }
    Ok(line)
}

/// A first estimate of an edge on a wide profile.
#[derive(Debug, Clone, Copy, PartialEq)]
struct EdgeEstimate {
    offset_px: f64,
    dark: f64,
    light: f64,
}

/// Edge position along a dark-to-light profile starting at `start_px`, by the area method with
/// the levels at the profile's ends; `None` if the contrast is too low or the edge is not inside.
fn edge_offset(profile: &[f64], start_px: f64) -> Option<EdgeEstimate> {
    let n = profile.len();
    let dark = profile.get(..LEVEL_SAMPLES)?.iter().sum::<f64>() / LEVEL_SAMPLES as f64;
    let light = profile.get(n - LEVEL_SAMPLES..)?.iter().sum::<f64>() / LEVEL_SAMPLES as f64;
    let contrast = light - dark;
    if contrast < MIN_EDGE_CONTRAST {
        return None;
    }
    let offset_px = start_px + area_above(profile, light) / contrast;
    let end_px = start_px + (n - 1) as f64 * PROFILE_STEP_PX;
    (offset_px > start_px && offset_px < end_px).then_some(EdgeEstimate {
        offset_px,
        dark,
        light,
    })
}

/// Trapezoidal area between the light level and the profile, in pixels × luma.
fn area_above(profile: &[f64], light: f64) -> f64 {
    profile
        .windows(2)
        .map(|w| (2.0 * light - w[0] - w[1]) * 0.5 * PROFILE_STEP_PX)
        .sum()
}

/// Running sums for a weighted total-least-squares line.
#[derive(Default)]
struct WeightedSums {
    w: f64,
    x: f64,
    y: f64,
    xx: f64,
    xy: f64,
    yy: f64,
    count: usize,
}

/// Fewest edge points a line is fitted to.
const MIN_EDGE_POINTS: usize = 6;

impl WeightedSums {
    fn add(&mut self, p: Point, weight: f64) {
        self.w += weight;
        self.x += weight * p.x;
        self.y += weight * p.y;
        self.xx += weight * p.x * p.x;
        self.xy += weight * p.x * p.y;
        self.yy += weight * p.y * p.y;
        self.count += 1;
    }

    /// The line through the weighted centroid along the principal axis.
    fn line(&self) -> Option<Line> {
        if self.count < MIN_EDGE_POINTS || self.w <= 0.0 {
            return None;
        }
        let (mx, my) = (self.x / self.w, self.y / self.w);
        let sxx = self.xx / self.w - mx * mx;
        let sxy = self.xy / self.w - mx * my;
        let syy = self.yy / self.w - my * my;
        // Direction of largest spread: angle θ with tan 2θ = 2 sxy / (sxx − syy).
        let theta = 0.5 * (2.0 * sxy).atan2(sxx - syy);
        let normal = nalgebra::Vector2::new(-theta.sin(), theta.cos());
        let offset = normal.x * mx + normal.y * my;
        (offset.is_finite()).then_some(Line { normal, offset })
    }
}

fn intersect(l1: &Line, l2: &Line) -> Result<Point, RefineError> {
    let det = l1.normal.x * l2.normal.y - l1.normal.y * l2.normal.x;
    if det.abs() < 1e-6 {
        return Err(RefineError::Parallel);
    }
    let x = (l1.offset * l2.normal.y - l1.normal.y * l2.offset) / det;
    let y = (l1.normal.x * l2.offset - l1.offset * l2.normal.x) / det;
    Ok(Point::new(x, y))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn area_method_finds_a_blurred_step_between_samples() {
        // A linear ramp from 20 to 220 centred at 0.3 px, one pixel wide, sampled every step.
        let start = -2.0;
        let profile: Vec<f64> = (0..17)
            .map(|j| {
                let s = start + j as f64 * PROFILE_STEP_PX;
                let t = (s - 0.3 + 0.5).clamp(0.0, 1.0);
                20.0 + 200.0 * t
            })
            .collect();
        let e = edge_offset(&profile, start).unwrap();
        assert!((e.offset_px - 0.3).abs() < 1e-9, "{e:?}");
        assert_eq!((e.dark, e.light), (20.0, 220.0));
        let flat = vec![100.0; 17];
        assert_eq!(edge_offset(&flat, start), None);
    }

    #[test]
    fn weighted_line_fit_recovers_a_slanted_line() {
        let mut s = WeightedSums::default();
        for i in 0..20 {
            let x = i as f64;
            s.add(Point::new(x, 0.5 * x + 3.0), 1.0 + i as f64);
        }
        let l = s.line().unwrap();
        // 0.5 x − y + 3 = 0, normalised.
        let k = (1.25f64).sqrt();
        let scale = if l.offset < 0.0 { -1.0 } else { 1.0 };
        assert!((l.normal.x * scale - (-0.5 / k)).abs() < 1e-9);
        assert!((l.normal.y * scale - (1.0 / k)).abs() < 1e-9);
        assert!((l.offset * scale - 3.0 / k).abs() < 1e-9);
    }
}
