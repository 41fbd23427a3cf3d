//! An elliptic LED spot, still or slowly moving: what a wide-angle lens makes of a round spot
//! near the picture's edge (squeezed radially), or a defocused LED. The spot is a hard-edged
//! ellipse swept along a straight path and clipped (as `glint-scene` draws its disk LED, whose
//! renderer has no elliptic LED spot), drawn here into a small synthetic YUYV frame at several
//! aspect ratios, orientations and path lengths, and run through the detector.
//!
//! Asserted: a still spot reads still (no path: nothing to make a velocity from) in at least
//! four cases of five, with its middle within the middle's bounds; a spot moving under a pixel
//! per exposure keeps its single-frame head (the path's end nearest the true end, as the
//! tracker picks it, or the middle when it reads still) within the accuracy tests' head bounds.

mod common;

use common::quantile;
use glint::detect::{Detector, DetectorConfig};
use glint::frame::{Frame, FrameSize};

const WIDTH_PX: usize = 96;
const HEIGHT_PX: usize = 72;
/// The floor's luma; the LED is many times the clip level, as in the renders.
const FLOOR_LUMA: f64 = 70.0;
const PEAK_TIMES_CLIP: f64 = 20.0;
/// Sub-samples per pixel side and along the path: the coverage of each pixel to about 1 %.
const SUB_SAMPLES: usize = 6;
const PATH_SAMPLES: usize = 16;

/// The accuracy tests' bounds (`tests/streak_sweep.rs`, `tests/replay_accuracy.rs`).
const HEAD_MEDIAN_MAX_PX: f64 = 0.5;
const HEAD_P95_MAX_PX: f64 = 1.5;
const MID_P95_MAX_PX: f64 = 0.5;

/// A hard ellipse of semi-axes `radii_px`, its first axis at `tilt_rad`, swept from `from` to
/// `to` during the exposure; a YUYV frame with a faint deterministic texture on the floor.
fn render(radii_px: (f64, f64), tilt_rad: f64, from: (f64, f64), to: (f64, f64)) -> Vec<u8> {
    let (c, s) = (tilt_rad.cos(), tilt_rad.sin());
    let mut bytes = vec![128u8; WIDTH_PX * HEIGHT_PX * 2];
    let mut seed = 0x2545_f491_u32;
    for y in 0..HEIGHT_PX {
        for x in 0..WIDTH_PX {
            let mut light = 0.0;
            let reach = radii_px.0.max(radii_px.1) + 1.0;
            let near =
                |a: f64, lo: f64, hi: f64| a >= lo.min(hi) - reach && a <= lo.max(hi) + reach;
            let lit = near(x as f64, from.0, to.0) && near(y as f64, from.1, to.1);
            for k in 0..PATH_SAMPLES * usize::from(lit) {
                let t = (k as f64 + 0.5) / PATH_SAMPLES as f64;
                let (cx, cy) = (from.0 + t * (to.0 - from.0), from.1 + t * (to.1 - from.1));
                for i in 0..SUB_SAMPLES {
                    for j in 0..SUB_SAMPLES {
                        let px = x as f64 - 0.5 + (i as f64 + 0.5) / SUB_SAMPLES as f64 - cx;
                        let py = y as f64 - 0.5 + (j as f64 + 0.5) / SUB_SAMPLES as f64 - cy;
                        let (u, v) = (c * px + s * py, -s * px + c * py);
                        if (u / radii_px.0).powi(2) + (v / radii_px.1).powi(2) <= 1.0 {
                            light += 1.0;
                        }
                    }
                }
            }
            light /= (PATH_SAMPLES * SUB_SAMPLES * SUB_SAMPLES) as f64;
            seed = seed.wrapping_mul(1_664_525).wrapping_add(1_013_904_223);
            let texture = f64::from(seed >> 29) - 3.5;
            let luma = FLOOR_LUMA + texture + light * PEAK_TIMES_CLIP * 255.0;
            bytes[(y * WIDTH_PX + x) * 2] = luma.round().clamp(0.0, 255.0) as u8;
        }
    }
    bytes
}

struct Outcome {
    /// The reported head's distance from the true end of the exposure (the middle when there
    /// is no path).
    head_px: f64,
    mid_px: f64,
    has_path: bool,
}

fn detect(radii_px: (f64, f64), tilt_rad: f64, from: (f64, f64), to: (f64, f64)) -> Outcome {
    let bytes = render(radii_px, tilt_rad, from, to);
    let size = FrameSize::new(WIDTH_PX as u32, HEIGHT_PX as u32).unwrap();
    let frame = Frame::new_checked(&bytes, size, WIDTH_PX * 2).unwrap();
    let mut detector = Detector::new(size, DetectorConfig::default()).unwrap();
    let detection = detector.detect(&frame);
    let (_, streak) = detection.best.expect("the spot is found");
    let mid_truth = (0.5 * (from.0 + to.0), 0.5 * (from.1 + to.1));
    let d = |p: (f32, f32), q: (f64, f64)| (f64::from(p.0) - q.0).hypot(f64::from(p.1) - q.1);
    let head = match streak.path {
        Some(path) => path
            .ends_px
            .iter()
            .map(|&e| d(e, to))
            .fold(f64::INFINITY, f64::min),
        None => d(streak.mid_px, to),
    };
    Outcome {
        head_px: head,
        mid_px: d(streak.mid_px, mid_truth),
        has_path: streak.path.is_some(),
    }
}

/// Aspect ratios from round to the wide lens's corners and beyond, tilts all round, and
/// sub-pixel positions, each still and moving along the spot's long axis, its short axis and
/// obliquely.
#[test]
fn an_elliptic_spot_reads_still_when_still_and_keeps_its_head_when_moving_slowly() {
    let mut still_mid = Vec::new();
    let mut still_with_path = 0;
    let mut slow_head = Vec::new();
    let mut faster_head = Vec::new();
    for (n, &(long_px, short_px)) in [(4.0, 4.0), (4.0, 3.4), (4.0, 2.8), (3.0, 2.0), (5.0, 3.0)]
        .iter()
        .enumerate()
    {
        for tilt_deg in [0.0, 30.0, 55.0, 90.0, 125.0] {
            let tilt = f64::to_radians(tilt_deg);
            let centre = (47.3 + 0.17 * n as f64, 35.6 - 0.23 * n as f64);
            let o = detect((long_px, short_px), tilt, centre, centre);
            still_with_path += usize::from(o.has_path);
            still_mid.push(o.mid_px);
            eprintln!(
                "still {long_px}x{short_px} tilt {tilt_deg}: mid {:.2} px, path {}",
                o.mid_px, o.has_path
            );
            // Under a pixel per exposure (the lens tours), and a few pixels.
            for (length_px, heading_deg) in [(0.8, 0.0), (0.8, 90.0), (2.0, 40.0), (4.0, 0.0)] {
                let heading = tilt + f64::to_radians(heading_deg);
                let half = 0.5 * length_px;
                let (dx, dy) = (half * heading.cos(), half * heading.sin());
                let from = (centre.0 - dx, centre.1 - dy);
                let to = (centre.0 + dx, centre.1 + dy);
                let o = detect((long_px, short_px), tilt, from, to);
                eprintln!(
                    "  moving {length_px} px at {heading_deg}° to the long axis: head {:.2} px, \
                     mid {:.2} px, path {}",
                    o.head_px, o.mid_px, o.has_path
                );
                if length_px < 1.0 {
                    slow_head.push(o.head_px);
                } else {
                    faster_head.push(o.head_px);
                }
            }
        }
    }
    let (m50, m95) = (quantile(&still_mid, 0.5), quantile(&still_mid, 0.95));
    let (s50, s95) = (quantile(&slow_head, 0.5), quantile(&slow_head, 0.95));
    let (f50, f95) = (quantile(&faster_head, 0.5), quantile(&faster_head, 0.95));
    eprintln!(
        "still: middle median {m50:.2} / p95 {m95:.2} px, {still_with_path} of {} with a path; \
         under 1 px per exposure: head median {s50:.2} / p95 {s95:.2} px; 2-4 px: head median \
         {f50:.2} / p95 {f95:.2} px",
        still_mid.len()
    );
    // Not yet every still spot: the caps are read to a few tenths of a pixel, and a few of the
    // most elongated spots still show a path (13 of 25 did when the width across the middle
    // was subtracted from the ends of the long axis).
    assert!(
        still_with_path * 5 <= still_mid.len(),
        "a still spot reads still: {still_with_path} of {} with a path",
        still_mid.len()
    );
    assert!(m95 <= MID_P95_MAX_PX, "still middle p95 {m95:.2} px");
    assert!(s50 <= HEAD_MEDIAN_MAX_PX, "slow head median {s50:.2} px");
    assert!(s95 <= HEAD_P95_MAX_PX, "slow head p95 {s95:.2} px");
    // Paths of 2–4 px on a spot this size are reported, not asserted: read as still, their
    // middle is half the path behind the head (the tracker carries it by the frames' motion).
}
