//! The fitted streak model through a lens that squeezes the LED's spot: near a wide lens's
//! corners a round spot is imaged as an ellipse (up to a third shorter radially), and the fit
//! must place the path's ends and measure its length for that ellipse, not for a round spot.
//!
//! A Gaussian spot (the fit's own domain, and `auto`'s: its edge is not sharp), squeezed by a
//! known linear map, is swept along straight paths of several lengths and headings, seen
//! through a gamma-2.2 tone curve and clipped, into small synthetic YUYV frames. The detector
//! is told the lens's local map (as `glint track --calib` tells it), with `--streak-model fit`
//! and `auto`. Asserted over aspect ratios, tilts, spot widths and paths, against the
//! renderer's exact path: the head (the path's end nearest the true end, or the middle when
//! it reads still) and the single-frame speed (path length) within the sweep's bounds
//! (`tests/streak_sweep.rs`). A round model, fitted to the same frames, lengthens a path
//! along the spot's long axis by the ellipse's extra extent: it was out of both bounds.

mod common;

use common::quantile;
use glint::detect::spot_shape::{SpotOptics, SpotShape};
use glint::detect::streak::StreakModel;
use glint::detect::{Detector, DetectorConfig};
use glint::frame::{Frame, FrameSize};

const WIDTH_PX: usize = 96;
const HEIGHT_PX: usize = 72;
/// The floor's luma, and the streak's brightest light over the clip level (both linear).
const FLOOR_LUMA: f64 = 60.0;
const CORE_TIMES_CLIP: f64 = 5.0;
const GAMMA: f64 = 2.2;
/// Sub-samples per pixel side, and along the path.
const SUB_SAMPLES: usize = 4;
const PATH_SAMPLES: usize = 48;

/// The sweep's bounds (`tests/streak_sweep.rs`).
const HEAD_MEDIAN_MAX_PX: f64 = 0.5;
const HEAD_P95_MAX_PX: f64 = 1.5;
const SPEED_MEDIAN_MAX: f64 = 0.03;
const SPEED_P95_MAX: f64 = 0.10;
/// Streaks at least this long have their speed measured (the sweep's rule).
const SPEED_MIN_PATH_PX: f64 = 8.0;

/// A round Gaussian spot of σ `sigma_px` in ideal pixels, imaged squeezed by `squeeze` (the
/// image's extent over the ideal one) along the direction `tilt_rad`.
#[derive(Clone, Copy)]
struct Squeeze {
    sigma_px: f64,
    squeeze: f64,
    tilt_rad: f64,
}

impl Squeeze {
    /// Image displacement to ideal: stretch the squeezed axis back by `1 / squeeze`.
    fn to_ideal(self, d: (f64, f64)) -> (f64, f64) {
        let (c, s) = (self.tilt_rad.cos(), self.tilt_rad.sin());
        let along = (d.0 * c + d.1 * s) / self.squeeze;
        let across = -d.0 * s + d.1 * c;
        (along * c - across * s, along * s + across * c)
    }

    /// The same map as a matrix (rows), for the detector.
    fn matrix(self) -> [[f32; 2]; 2] {
        let x = self.to_ideal((1.0, 0.0));
        let y = self.to_ideal((0.0, 1.0));
        [[x.0 as f32, y.0 as f32], [x.1 as f32, y.1 as f32]]
    }
}

/// The lens as the detector sees it: the same local map everywhere in this small frame.
struct Optics(SpotShape);

impl SpotOptics for Optics {
    fn spot_shape_at(&self, _px: (f32, f32)) -> Option<SpotShape> {
        Some(self.0)
    }
}

/// The spot `s` swept from `from` to `to` during the exposure, its brightest pixel
/// [`CORE_TIMES_CLIP`] times the clip level in linear light (the sweep's measure of an LED's
/// brightness); a YUYV frame with a faint deterministic texture on the floor.
fn render(s: Squeeze, from: (f64, f64), to: (f64, f64)) -> Vec<u8> {
    let reach = 6.0 * s.sigma_px + 2.0;
    let near = |x: f64, y: f64| {
        x >= from.0.min(to.0) - reach
            && x <= from.0.max(to.0) + reach
            && y >= from.1.min(to.1) - reach
            && y <= from.1.max(to.1) + reach
    };
    let mut light = vec![0.0f64; WIDTH_PX * HEIGHT_PX];
    for (i, l) in light.iter_mut().enumerate() {
        let (fx, fy) = ((i % WIDTH_PX) as f64, (i / WIDTH_PX) as f64);
        if !near(fx, fy) {
            continue;
        }
        for sy in 0..SUB_SAMPLES {
            for sx in 0..SUB_SAMPLES {
                let px = fx - 0.5 + (sx as f64 + 0.5) / SUB_SAMPLES as f64;
                let py = fy - 0.5 + (sy as f64 + 0.5) / SUB_SAMPLES as f64;
                for k in 0..PATH_SAMPLES {
                    let t = (k as f64 + 0.5) / PATH_SAMPLES as f64;
                    let c = (from.0 + t * (to.0 - from.0), from.1 + t * (to.1 - from.1));
                    let (ix, iy) = s.to_ideal((px - c.0, py - c.1));
                    *l += (-0.5 * (ix * ix + iy * iy) / (s.sigma_px * s.sigma_px)).exp();
                }
            }
        }
    }
    let peak = light.iter().copied().fold(0.0, f64::max);
    let floor_linear = (FLOOR_LUMA / 255.0).powf(GAMMA);
    let mut bytes = vec![128u8; WIDTH_PX * HEIGHT_PX * 2];
    let mut seed = 0x9e37_79b9_u32;
    for (i, l) in light.iter().enumerate() {
        seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
        let texture = f64::from(seed >> 30) - 1.5;
        let linear = floor_linear + CORE_TIMES_CLIP * l / peak;
        let luma = 255.0 * linear.powf(1.0 / GAMMA) + texture;
        bytes[i * 2] = luma.round().clamp(0.0, 255.0) as u8;
    }
    bytes
}

/// The head's distance from the true end, and the path's length (0 when it reads still).
fn detect(model: StreakModel, s: Squeeze, from: (f64, f64), to: (f64, f64)) -> (f64, f64) {
    let bytes = render(s, from, to);
    let size = FrameSize::new(WIDTH_PX as u32, HEIGHT_PX as u32).unwrap();
    let frame = Frame::new_checked(&bytes, size, WIDTH_PX * 2).unwrap();
    let config = DetectorConfig {
        streak_model: model,
        ..DetectorConfig::default()
    };
    let mut detector = Detector::new(size, config).unwrap();
    detector.set_optics(Box::new(Optics(SpotShape::new(s.matrix()).unwrap())));
    let (_, streak) = detector.detect(&frame).best.expect("the spot is found");
    let d = |p: (f32, f32), q: (f64, f64)| (f64::from(p.0) - q.0).hypot(f64::from(p.1) - q.1);
    match streak.path {
        Some(path) => (
            path.ends_px
                .iter()
                .map(|&e| d(e, to))
                .fold(f64::INFINITY, f64::min),
            f64::from(path.path_length_px),
        ),
        None => (d(streak.mid_px, to), 0.0),
    }
}

/// Squeezes from none to a wide lens's corners, tilts all round, two spot widths; paths from
/// still to 14 px, along the squeezed axis, across it and obliquely (all longer than the spot
/// is wide, or still: a shorter path reads still, and the tracker carries its middle).
fn holds_through_the_lens(model: StreakModel) {
    let mut heads = Vec::new();
    let mut speeds = Vec::new();
    let mut n = 0;
    for squeeze in [1.0, 0.8, 0.67] {
        for tilt_deg in [0.0, 35.0, 90.0, 140.0] {
            for sigma_px in [1.0, 1.6] {
                let s = Squeeze {
                    sigma_px,
                    squeeze,
                    tilt_rad: f64::to_radians(tilt_deg),
                };
                for (length_px, heading_deg) in [(0.0, 0.0), (6.0, 0.0), (8.0, 90.0), (14.0, 45.0)]
                {
                    n += 1;
                    let centre = (47.3 + 0.13 * (n % 7) as f64, 35.6 - 0.21 * (n % 5) as f64);
                    let heading = s.tilt_rad + f64::to_radians(heading_deg);
                    let half = 0.5 * length_px;
                    let (dx, dy) = (half * heading.cos(), half * heading.sin());
                    let from = (centre.0 - dx, centre.1 - dy);
                    let to = (centre.0 + dx, centre.1 + dy);
                    let (head_px, path_px) = detect(model, s, from, to);
                    heads.push(head_px);
                    let speed = (length_px >= SPEED_MIN_PATH_PX)
                        .then(|| (path_px - length_px).abs() / length_px);
                    speeds.extend(speed);
                    eprintln!(
                        "{model:?} squeeze {squeeze} tilt {tilt_deg}° σ {sigma_px}: {length_px} px \
                         at {heading_deg}°: head {head_px:.2} px, path {path_px:.2} px"
                    );
                }
            }
        }
    }
    let (h50, h95) = (quantile(&heads, 0.5), quantile(&heads, 0.95));
    let (v50, v95) = (quantile(&speeds, 0.5), quantile(&speeds, 0.95));
    eprintln!(
        "{model:?}: head median {h50:.2} / p95 {h95:.2} px; speed median {:.1} / p95 {:.1} %",
        100.0 * v50,
        100.0 * v95
    );
    assert!(
        h50 <= HEAD_MEDIAN_MAX_PX,
        "{model:?} head median {h50:.2} px"
    );
    assert!(h95 <= HEAD_P95_MAX_PX, "{model:?} head p95 {h95:.2} px");
    assert!(
        v50 <= SPEED_MEDIAN_MAX,
        "{model:?} speed median {:.1} %",
        100.0 * v50
    );
    assert!(
        v95 <= SPEED_P95_MAX,
        "{model:?} speed p95 {:.1} %",
        100.0 * v95
    );
}

#[test]
fn the_fit_measures_a_squeezed_spot_s_path_through_the_lens() {
    holds_through_the_lens(StreakModel::Fit);
}

#[test]
fn auto_measures_a_squeezed_spot_s_path_through_the_lens() {
    holds_through_the_lens(StreakModel::Auto);
}
