//! A streak whose end runs into something bright beside the LED (a marker's white square, paper
//! white but below the LED's clip level), with no lens calibrated.
//!
//! The ramps (`src/detect/tips.rs`) walk out from each skeleton end until the brightness falls
//! through a low level between the clip and the floor; a white square just past the end keeps
//! the walk above that level, and the tip lands on the square's far side. The LED's centre at
//! the end of its path is inside the saturated blob, within the spot's own extent of the
//! skeleton's end, so such a tip is refused (`src/detect/spot_shape.rs`): the streak gives its
//! middle and no path. Asserted, on a swept disk drawn into a small YUYV frame at several
//! sub-pixel positions and headings, with the ramps and with the default model (which fits
//! the streak where the ramps' reading is doubtful): beside the square, no reported path end
//! is farther from the path's true ends than the accuracy tests' head bound; the same streaks
//! without the square keep their path (the guard refuses only what ran on); and the ramps
//! refuse at least half of those beside the square (else the square did not make the walk run
//! on, and the test shows nothing).

use glint::detect::streak::StreakModel;
use glint::detect::{Detector, DetectorConfig};
use glint::frame::{Frame, FrameSize};

const WIDTH_PX: usize = 96;
const HEIGHT_PX: usize = 72;
const FLOOR_LUMA: f64 = 70.0;
/// Paper white under the lights: bright, but below the LED's clip level.
const SQUARE_LUMA: f64 = 200.0;
const PEAK_TIMES_CLIP: f64 = 20.0;
const DISK_RADIUS_PX: f64 = 2.5;
/// The square's side. It touches the footprint's edge (a gap of floor between them stops the
/// walk, and the ramps read the tip right).
const SQUARE_PX: f64 = 6.0;
/// Sub-samples per pixel side and along the path.
const SUB_SAMPLES: usize = 6;
const PATH_SAMPLES: usize = 24;
/// The accuracy tests' head bound (p95, `tests/streak_sweep.rs`), for any single frame here.
const HEAD_MAX_PX: f64 = 1.5;

/// A disk swept from `from` to `to`, and with `square`, a white square of side [`SQUARE_PX`]
/// beyond the path's end, touching the footprint's edge, its sides along and across the path.
fn render(from: (f64, f64), to: (f64, f64), square: bool) -> Vec<u8> {
    let length = (to.0 - from.0).hypot(to.1 - from.1);
    let u = ((to.0 - from.0) / length, (to.1 - from.1) / length);
    let near = DISK_RADIUS_PX;
    let square_centre = (
        to.0 + (near + 0.5 * SQUARE_PX) * u.0,
        to.1 + (near + 0.5 * SQUARE_PX) * u.1,
    );
    let mut bytes = vec![128u8; WIDTH_PX * HEIGHT_PX * 2];
    for y in 0..HEIGHT_PX {
        for x in 0..WIDTH_PX {
            let mut light = 0.0;
            let mut paper = 0.0;
            for i in 0..SUB_SAMPLES {
                for j in 0..SUB_SAMPLES {
                    let px = x as f64 - 0.5 + (i as f64 + 0.5) / SUB_SAMPLES as f64;
                    let py = y as f64 - 0.5 + (j as f64 + 0.5) / SUB_SAMPLES as f64;
                    let (sx, sy) = (px - square_centre.0, py - square_centre.1);
                    // The square's sides along and across the path.
                    let (a, c) = (sx * u.0 + sy * u.1, -sx * u.1 + sy * u.0);
                    if square && a.abs() <= 0.5 * SQUARE_PX && c.abs() <= 0.5 * SQUARE_PX {
                        paper += 1.0;
                    }
                    for k in 0..PATH_SAMPLES {
                        let t = (k as f64 + 0.5) / PATH_SAMPLES as f64;
                        let (cx, cy) = (from.0 + t * (to.0 - from.0), from.1 + t * (to.1 - from.1));
                        if (px - cx).hypot(py - cy) <= DISK_RADIUS_PX {
                            light += 1.0;
                        }
                    }
                }
            }
            let cells = (SUB_SAMPLES * SUB_SAMPLES) as f64;
            light /= PATH_SAMPLES as f64 * cells;
            paper /= cells;
            let base = FLOOR_LUMA + paper * (SQUARE_LUMA - FLOOR_LUMA);
            let luma = base + light * PEAK_TIMES_CLIP * 255.0;
            bytes[(y * WIDTH_PX + x) * 2] = luma.round().clamp(0.0, 255.0) as u8;
        }
    }
    bytes
}

/// The farthest reported path end from the true end it stands for, with the streak model
/// `model` (`None`: no path).
fn worst_end_px(from: (f64, f64), to: (f64, f64), square: bool, model: StreakModel) -> Option<f64> {
    let bytes = render(from, to, square);
    let size = FrameSize::new(WIDTH_PX as u32, HEIGHT_PX as u32).unwrap();
    let frame = Frame::new_checked(&bytes, size, WIDTH_PX * 2).unwrap();
    let config = DetectorConfig {
        streak_model: model,
        ..DetectorConfig::default()
    };
    let mut detector = Detector::new(size, config).unwrap();
    let (_, streak) = detector.detect(&frame).best.expect("the streak is found");
    let path = streak.path?;
    let d = |p: (f32, f32), q: (f64, f64)| (f64::from(p.0) - q.0).hypot(f64::from(p.1) - q.1);
    let [a, b] = path.ends_px;
    Some((d(a, from).max(d(b, to))).min(d(a, to).max(d(b, from))))
}

#[test]
fn a_tip_run_into_a_white_square_is_refused_without_a_lens() {
    let mut refused = 0;
    let mut cases = 0;
    for (n, heading_deg) in [0.0f64, 20.0, 90.0, 160.0, 235.0].into_iter().enumerate() {
        let heading = heading_deg.to_radians();
        let centre = (44.2 + 0.31 * n as f64, 35.7 - 0.27 * n as f64);
        let half_px = 8.0;
        let (dx, dy) = (half_px * heading.cos(), half_px * heading.sin());
        let from = (centre.0 - dx, centre.1 - dy);
        let to = (centre.0 + dx, centre.1 + dy);
        for model in [StreakModel::Ramps, StreakModel::default()] {
            let clear = worst_end_px(from, to, false, model);
            let beside = worst_end_px(from, to, true, model);
            eprintln!(
                "heading {heading_deg}°, {model:?}: ends within {clear:?} px; beside the square \
                 {beside:?} px"
            );
            let clear = clear.unwrap_or_else(|| panic!("heading {heading_deg}°: no path"));
            assert!(
                clear <= HEAD_MAX_PX,
                "heading {heading_deg}°, {model:?}: ends {clear:.2} px off"
            );
            if let Some(worst) = beside {
                assert!(
                    worst <= HEAD_MAX_PX,
                    "heading {heading_deg}°, {model:?}: beside the square, an end {worst:.2} px off"
                );
            }
            if model == StreakModel::Ramps {
                refused += usize::from(beside.is_none());
                cases += 1;
            }
        }
    }
    // The square did make the ramps' walk run on (else the test shows nothing).
    assert!(
        refused * 2 >= cases,
        "only {refused} of {cases} paths refused"
    );
}
