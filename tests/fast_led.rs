//! A fast LED filmed at a short exposure: between two frames it moves several times its
//! streak's length, and the streak fit still starts each frame from the spot it fitted in the
//! last one, when the detector knows the exposure.

mod common;

use common::quantile;
use glint::detect::streak::StreakModel;
use glint::detect::{Detector, DetectorConfig};
use glint::frame::{Frame, FrameSize};
use glint_tools::scene::{Point, Scene, Spot, Trajectory, Visibility};

/// An LED speeding up and braking along the picture's diagonal (688 px in 0.5 s, raised
/// cosine: up to 2750 px/s, so up to 92 px a frame at 30 fps), a Gaussian spot of
/// `sigma_px`, filmed at `exposure_us` (a few times shorter than the frame interval).
fn scene(sigma_px: f64, exposure_us: u32) -> Scene {
    let mut config = Scene::preset_config("speed-ramp").expect("preset");
    config.led.spot = Spot::Gaussian { sigma_px };
    config.led.glow_peak = 0.0;
    config.exposure_us = exposure_us;
    config.frame_count = 24;
    config.trajectory = Trajectory::Arrive {
        from_px: Point::new(40.0, 440.0),
        to_px: Point::new(600.0, 40.0),
        move_s: 0.5,
        arrive_s: 0.6,
        then_velocity_px_s: Point::new(0.0, 0.0),
    };
    Scene::new(config).expect("scene")
}

/// Streaks shorter than this are left out: their ends are the spot's, not the motion's.
const MIN_STREAK_PX: f64 = 8.0;

/// Errors of the fitted streaks on `scene`, by a detector told the exposure or not: the
/// middles against the path's halfway point, and the farther of the fitted ends against the
/// path's, on the frames whose streak is at least [`MIN_STREAK_PX`] long.
fn errors(scene: &Scene, exposure_us: Option<u32>) -> (Vec<f64>, Vec<f64>) {
    let size = FrameSize::new(scene.width_px(), scene.height_px()).unwrap();
    let mut detector = Detector::new(
        size,
        DetectorConfig {
            streak_model: StreakModel::Fit,
            ..DetectorConfig::default()
        },
    )
    .unwrap();
    detector.set_exposure_us(exposure_us);
    let mut bytes = vec![0u8; scene.frame_len_bytes()];
    let (mut mids, mut ends) = (Vec::new(), Vec::new());
    for index in 0..scene.config().frame_count {
        let truth = scene.render(index, &mut bytes).unwrap();
        let frame = Frame::new_checked(&bytes, size, size.row_bytes()).unwrap();
        let best = detector.detect(&frame).best;
        let (Some((_, streak)), Visibility::Visible, Some(streak_px)) =
            (best, truth.visible, truth.streak_px)
        else {
            continue;
        };
        if streak_px < MIN_STREAK_PX {
            continue;
        }
        let d =
            |(x, y): (f32, f32), (tx, ty): (f64, f64)| (f64::from(x) - tx).hypot(f64::from(y) - ty);
        let mid = (truth.path_mid_x_px.unwrap(), truth.path_mid_y_px.unwrap());
        mids.push(d(streak.mid_px, mid));
        let path = streak.path.expect("the fit reads every moving streak");
        let end = (truth.x_px.unwrap(), truth.y_px.unwrap());
        let start = (2.0 * mid.0 - end.0, 2.0 * mid.1 - end.1);
        let [a, b] = path.ends_px;
        ends.push((d(a, start).max(d(b, end))).min(d(a, end).max(d(b, start))));
    }
    (mids, ends)
}

/// Median and 95th percentile.
fn quantiles(v: Vec<f64>) -> (f64, f64) {
    (quantile(&v, 0.5), quantile(&v, 0.95))
}

/// With the exposure known, the fit starts from the last frame's spot (`SpotMemory`), its
/// width, brightness and tone, and lays the light along the path as the LED's change of speed
/// says; taken to move about its streak's length a frame (the exposure unknown), the LED is
/// out of reach of its last spot wherever it moves more than that and 24 px (at 10 ms, every
/// streak over 10 px), and those fits start cold. Over Gaussian spots
/// of σ 1–2 px at 5 and 10 ms (48 frames): ends 0.044 / 0.32 px off (median / p95, nearest
/// rank) where the cold fits were 0.084 / 0.42, and the middles' median 0.015 px where it was
/// 0.040.
#[test]
fn a_fast_led_at_a_short_exposure_is_fitted_from_its_last_spot() {
    let (mut warm, mut cold) = ((Vec::new(), Vec::new()), (Vec::new(), Vec::new()));
    for exposure_us in [5_000, 10_000] {
        for sigma_px in [1.0, 1.5, 2.0] {
            let scene = scene(sigma_px, exposure_us);
            let (mids, ends) = errors(&scene, Some(exposure_us));
            warm.0.extend(mids);
            warm.1.extend(ends);
            let (mids, ends) = errors(&scene, None);
            cold.0.extend(mids);
            cold.1.extend(ends);
        }
    }
    let frames = warm.0.len();
    let [warm_mid, warm_ends, cold_mid, cold_ends] =
        [warm.0, warm.1, cold.0, cold.1].map(quantiles);
    eprintln!(
        "{frames} frames: middles {warm_mid:.3?} (cold {cold_mid:.3?}), ends {warm_ends:.3?} (cold {cold_ends:.3?})"
    );
    // The bounds on the middle, and the current position's on the ends.
    assert!(
        warm_mid.0 <= 0.2 && warm_mid.1 <= 0.5,
        "middles {warm_mid:?}"
    );
    assert!(
        warm_ends.0 <= 0.5 && warm_ends.1 <= 1.5,
        "ends {warm_ends:?}"
    );
    // And nearer than the cold fits (the middles' tail is the short streaks', whose middle is
    // the light's centre either way).
    assert!(
        warm_mid.0 < cold_mid.0,
        "middles {warm_mid:?} against {cold_mid:?}"
    );
    assert!(
        warm_ends.0 < cold_ends.0 && warm_ends.1 < cold_ends.1,
        "ends {warm_ends:?} against {cold_ends:?}"
    );
}
