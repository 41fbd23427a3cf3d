//! Accuracy over a sweep of physical parameters (spot profile and width, brightness, gamma,
//! noise, range, straight and curved paths, and a wide-angle lens that squeezes the spot), not
//! at one renderer setting: every point of a seeded random subset of the sweep is held to the
//! bounds. Where the lens squeezes the spot, the detector is told the lens's local map there,
//! as `glint track --calib` tells it from the calibrated lens.
//!
//! Acquisition is scored on its own: a light that has stood still since it appeared is never
//! the LED, so the sweep's still LED first moves into place, and the LED must be reported
//! within [`ACQUIRE_MAX_FRAMES`] of the frame in which it had moved [`MOTION_SHOWN_PX`], and
//! in every visible frame from then on.
//!
//! The default run takes [`DEFAULT_POINTS`] points; `GLINT_SWEEP_POINTS=N` takes the first N
//! of the same sweep (the README's figures use 200), and `GLINT_SWEEP_SEED` another sweep.
//!
//! It measures glint's default streak model, `auto` (`GLINT_STREAK_MODEL=ramps` measures the
//! ramps alone, `GLINT_STREAK_MODEL=fit` the fit alone). `GLINT_SWEEP_GAMMA=1` draws every
//! point through that tone curve instead of its own (1: a linear camera, outside the
//! sweep's 1.8–2.4).
//! To see where the errors come from: `GLINT_SWEEP_ONLY=5,13` runs only those points,
//! `GLINT_SWEEP_FLAT_FLOOR=1` renders the floor without texture, `GLINT_SWEEP_NO_NOISE=1`
//! without noise (neither the read noise nor the noise after the clip),
//! `GLINT_SWEEP_NO_OPTICS=1` keeps the lens from the detector, and `GLINT_SWEEP_FLOOR_SEEN=N`
//! shows the camera N frames of the scene without the LED before its first frame, so that the
//! floor under the glow of a track's first frames is known (what glint cannot know of a
//! scene whose LED moves from its first frame).
//!
//! NOT YET HELD: neither model holds these bounds on every point of the sweep yet (README,
//! "Accuracy over the sweep"), so the test is ignored by default and run on purpose with
//! `cargo test --test streak_sweep -- --ignored`. It prints every point's figures and the
//! sweep's totals, then fails listing the points out of bounds.

mod common;

use common::{in_process, shutter_skew, slope_and_mean};
use glint::detect::spot_shape::{SpotOptics, SpotShape};
use glint::detect::streak::{FitFloor, StreakModel};
use glint::detect::{Detector, DetectorConfig};
use glint::frame::{Frame, FrameSize};
use glint::source::FrameMeta;
use glint::track::shutter::RollingShutter;
use glint::track::{Tracker, TrackerConfig, VelocityMethod};
use glint_tools::scene::{
    Range, Scene, SceneConfig, SpotKind, Squeeze, SweepPath, SweepPoint, Visibility,
};

/// Points checked in the default test run.
const DEFAULT_POINTS: usize = 24;
/// The sweep's seed unless `GLINT_SWEEP_SEED` says otherwise.
const DEFAULT_SEED: u64 = 11;

const HEAD_MEDIAN_MAX_PX: f64 = 0.5;
const HEAD_P95_MAX_PX: f64 = 1.5;
const MID_MEDIAN_MAX_PX: f64 = 0.2;
const MID_P95_MAX_PX: f64 = 0.5;
/// The middle is held to its bounds on streaks this long (the table).
const MIDDLE_STREAK_PX: f64 = 60.0;
const SPEED_MEDIAN_MAX: f64 = 0.03;
const SPEED_P95_MAX: f64 = 0.10;
/// Single-frame speed is held to its bounds on streaks at least this long.
const SPEED_MIN_STREAK_PX: f64 = 8.0;
/// The LED has shown motion once it is this far from where it was when it appeared (at the
/// start of the first exposure it was seen in): a light that has stood still since it
/// appeared is never the LED, and a blob's centre wanders by about a pixel with noise.
const MOTION_SHOWN_PX: f64 = 2.0;
/// The LED is reported at most this many frames after the one in which it had shown motion.
/// A light alone in view is taken in the first frame only when it is smeared; a round one may
/// be a lamp, and its motion is seen against the next frame: one frame.
const ACQUIRE_MAX_FRAMES: usize = 1;

/// The q-quantile by nearest rank (`None` for no values).
fn quantile(values: &[f64], q: f64) -> Option<f64> {
    if values.is_empty() {
        return None;
    }
    let mut sorted = values.to_vec();
    sorted.sort_by(f64::total_cmp);
    let rank = ((q * sorted.len() as f64).ceil() as usize).clamp(1, sorted.len());
    Some(sorted[rank - 1])
}

/// The lens as a calibrated detector knows it: the sweep's LED stays within a few dozen pixels
/// of the picture's centre, over which the lens's local map is taken as the same.
struct SweepLens(SpotShape);

impl SpotOptics for SweepLens {
    fn spot_shape_at(&self, _px: (f32, f32)) -> Option<SpotShape> {
        Some(self.0)
    }
}

/// The lens of `point` for the detector: `None` where it leaves the spot round (no lens to
/// tell, as for an uncalibrated or ideal camera), or with `GLINT_SWEEP_NO_OPTICS` (what the
/// lens costs a detector that is not told of it).
fn optics(point: &SweepPoint) -> Option<Box<dyn SpotOptics>> {
    if point.lens.is_none() || std::env::var_os("GLINT_SWEEP_NO_OPTICS").is_some() {
        return None;
    }
    let m = point.lens.image_to_round().map(|row| row.map(|v| v as f32));
    let shape = SpotShape::new(m).expect("a squeeze is one-to-one");
    Some(Box::new(SweepLens(shape)))
}

/// `point` at the picture's centre, where the lens leaves its spot round: for the tests that
/// hold one case of the round spot.
fn round(mut point: SweepPoint) -> SweepPoint {
    point.lens = Squeeze::NONE;
    point
}

/// One sweep point's errors.
#[derive(Default)]
struct PointScore {
    visible: usize,
    found: usize,
    false_reports: usize,
    /// Current position, in frames after the first found (the head needs a previous
    /// position) and, for an LED that moves into place, once it is in place.
    head_px: Vec<f64>,
    mid_px: Vec<f64>,
    /// The frame of each of those middles.
    mid_frames: Vec<usize>,
    /// Relative single-frame speed errors on streaks of at least [`SPEED_MIN_STREAK_PX`].
    speed: Vec<f64>,
    /// The same frames' signed errors, each with its frame and the LED's true vertical speed.
    speed_frames: Vec<SpeedFrame>,
    /// Frames whose speed should have come from the streak but did not.
    speed_missing: usize,
    /// The first visible frame in which the LED had shown motion (see [`MOTION_SHOWN_PX`]).
    first_motion: Option<usize>,
    /// The first frame in which the LED was reported.
    acquired: Option<usize>,
    /// Visible frames not found, by when: before the LED had shown motion (a light standing
    /// still since it appeared is never the LED), after it had but before it was first
    /// reported (acquisition), and after it was first reported (the LED lost: a defect).
    missed_still: usize,
    missed_acquiring: usize,
    missed_tracked: usize,
    /// Of those, frames reported `ambiguous`.
    missed_ambiguous: usize,
    /// Frames reported before the LED had shown motion.
    reported_still: usize,
}

/// One frame's single-frame speed, against the truth.
struct SpeedFrame {
    index: usize,
    /// (read − true) / true.
    signed_error: f64,
    true_vy_px_s: f64,
}

impl PointScore {
    /// Frames from the one in which the LED had shown motion to the one it was first
    /// reported in (`None` until both happened).
    fn acquisition_delay(&self) -> Option<usize> {
        Some(self.acquired?.saturating_sub(self.first_motion?))
    }
}

/// `config` as the diagnostics ask: which error comes from the floor's texture
/// (`GLINT_SWEEP_FLAT_FLOOR`), which from the noise (`GLINT_SWEEP_NO_NOISE`).
fn diagnosed(mut config: SceneConfig) -> SceneConfig {
    if std::env::var_os("GLINT_SWEEP_FLAT_FLOOR").is_some() {
        config.floor.contrast = 0.0;
    }
    if std::env::var_os("GLINT_SWEEP_NO_NOISE").is_some() {
        config.camera.noise_sigma = 0.0;
        config.camera.post_noise_luma = 0.0;
    }
    config
}

/// Diagnostics (`GLINT_SWEEP_FLOOR_SEEN=N`): shows `pipeline` N frames of `point`'s scene with
/// its LED hidden (its floor, noise and static lights as they are), frames `period_us` apart
/// from 0 on; returns N, the frames (and frame intervals) the scene's own frames come after.
fn floor_seen_first(
    point: &SweepPoint,
    pipeline: &mut glint::pipeline::Pipeline,
    bytes: &mut [u8],
    period_us: u64,
) -> u64 {
    let frames: u64 = env_or("GLINT_SWEEP_FLOOR_SEEN", 0);
    if frames == 0 {
        return 0;
    }
    let mut config = diagnosed(point.config());
    // Hidden over the whole scene: one range.
    let whole = 0..config.frame_count;
    config.led_hidden_frames = core::iter::once(whole).collect();
    let unlit = Scene::new(config).expect("sweep scene");
    let size = FrameSize::new(unlit.width_px(), unlit.height_px()).unwrap();
    for i in 0..frames {
        unlit
            .render(i as usize % unlit.frame_count(), bytes)
            .unwrap();
        let frame = Frame::new_checked(bytes, size, size.row_bytes()).unwrap();
        let meta = FrameMeta {
            index: i,
            sequence: i,
            dropped: 0,
            timestamp_us: i * period_us,
            monotonic_us: i * period_us,
        };
        pipeline.process(&frame, meta);
    }
    frames
}

fn run_point(point: &SweepPoint, model: StreakModel) -> PointScore {
    run_point_through(point, model, None)
}

/// `point` seen by a camera whose rolling shutter reads a row every `row_time_us` (a global
/// shutter for `None`), and glint told so.
fn run_point_through(
    point: &SweepPoint,
    model: StreakModel,
    row_time_us: Option<f64>,
) -> PointScore {
    let mut config = diagnosed(point.config());
    config.row_time_us = row_time_us.unwrap_or(0.0);
    let scene = Scene::new(config).expect("sweep scene");
    let size = FrameSize::new(scene.width_px(), scene.height_px()).unwrap();
    let mut pipeline = in_process::pipeline(&scene, model);
    if let Some(row_time_us) = row_time_us {
        let shutter = RollingShutter::new(row_time_us as f32).expect("a positive row time");
        pipeline = pipeline.with_rolling_shutter(shutter);
    }
    if let Some(optics) = optics(point) {
        pipeline.set_optics(optics);
    }
    let mut bytes = vec![0u8; scene.frame_len_bytes()];
    let mut s = PointScore::default();
    let period_us = (1e6 / scene.fps()) as u64;
    let floor_seen_frames = floor_seen_first(point, &mut pipeline, &mut bytes, period_us);
    let frames_printed = std::env::var_os("GLINT_SWEEP_FRAMES").is_some();
    // Where the LED was at the start of the first exposure it was seen in.
    let mut appeared_at: Option<(f64, f64)> = None;
    for index in 0..scene.frame_count() {
        let truth = scene.render(index, &mut bytes).unwrap();
        let frame = Frame::new_checked(&bytes, size, size.row_bytes()).unwrap();
        let meta = FrameMeta {
            index: floor_seen_frames + index as u64,
            sequence: floor_seen_frames + index as u64,
            dropped: 0,
            timestamp_us: (floor_seen_frames + index as u64) * period_us,
            monotonic_us: (floor_seen_frames + index as u64) * period_us,
        };
        let report = pipeline.process(&frame, meta);
        match truth.visible {
            Visibility::Hidden => s.false_reports += usize::from(report.position.is_some()),
            Visibility::Partial => {}
            Visibility::Visible => {
                s.visible += 1;
                let (x, y) = (truth.x_px.unwrap(), truth.y_px.unwrap());
                let (mx, my) = (truth.mid_x_px.unwrap(), truth.mid_y_px.unwrap());
                // The start of a straight streak (arcs move far more than the threshold in
                // their first frame).
                let start = *appeared_at.get_or_insert((2.0 * mx - x, 2.0 * my - y));
                if s.first_motion.is_none() && (x - start.0).hypot(y - start.1) > MOTION_SHOWN_PX {
                    s.first_motion = Some(index);
                }
                let Some(e) = report.position else {
                    s.missed_ambiguous += usize::from(report.ambiguous);
                    if s.acquired.is_some() {
                        s.missed_tracked += 1;
                    } else if s.first_motion.is_some() {
                        s.missed_acquiring += 1;
                    } else {
                        s.missed_still += 1;
                    }
                    if frames_printed {
                        print_miss(index, report.ambiguous, pipeline.detector());
                    }
                    continue;
                };
                s.reported_still += usize::from(s.first_motion.is_none());
                let acquired = *s.acquired.get_or_insert(index);
                s.found += 1;
                let d = |(x, y): (f32, f32), tx: Option<f64>, ty: Option<f64>| {
                    (f64::from(x) - tx.unwrap()).hypot(f64::from(y) - ty.unwrap())
                };
                s.mid_px.push(d(e.mid_px, truth.mid_x_px, truth.mid_y_px));
                s.mid_frames.push(index);
                if frames_printed {
                    print_frame(index, &truth, &e, report.detection.best.as_ref());
                }
                // The head needs a previous position. An LED moving into place is measured
                // once in place: on its way in it speeds up and slows down within an
                // exposure, where the streak's mean speed is not the speed at its end.
                let measured = index > acquired && index >= point.path.settled_frame();
                if measured {
                    s.head_px.push(d(e.position_px, truth.x_px, truth.y_px));
                }
                let streak_px = truth.streak_px.unwrap();
                // The streak's speed needs its direction, which needs a previous frame.
                if streak_px >= SPEED_MIN_STREAK_PX && measured {
                    let true_vy_px_s = truth.vy_px_s.unwrap();
                    let true_speed = truth.vx_px_s.unwrap().hypot(true_vy_px_s);
                    match e.velocity_px_s {
                        Some(((vx, vy), VelocityMethod::Streak)) => {
                            let signed_error =
                                (f64::from(vx).hypot(f64::from(vy)) - true_speed) / true_speed;
                            s.speed.push(signed_error.abs());
                            s.speed_frames.push(SpeedFrame {
                                index,
                                signed_error,
                                true_vy_px_s,
                            });
                        }
                        _ => s.speed_missing += 1,
                    }
                }
            }
        }
    }
    s
}

/// A frame in which the LED was not found (`GLINT_SWEEP_FRAMES=1`): whether it was
/// `ambiguous`, and the candidates the tracker chose among (area, mass centre, elongation).
fn print_miss(index: usize, ambiguous: bool, detector: Option<&Detector>) {
    let candidates: Vec<_> = detector
        .into_iter()
        .flat_map(|d| d.candidates())
        .map(|(_, b)| (b.area_px, b.mass_centre_px, b.elongation))
        .collect();
    eprintln!(
        "    frame {index:>2}: not found{}, candidates {candidates:?}",
        if ambiguous { ", ambiguous" } else { "" }
    );
}

/// One frame's figures (`GLINT_SWEEP_FRAMES=1`), to tell the kinds of error apart: the head's
/// error, its distance from the true start (a reversed direction lands there), how the
/// position was taken, and the fitted path against the true one.
fn print_frame(
    index: usize,
    truth: &glint_tools::scene::Truth,
    e: &glint::track::Estimate,
    best: Option<&(glint::detect::blobs::Blob, glint::detect::streak::Streak)>,
) {
    let (Some(x), Some(y), Some(mx), Some(my)) =
        (truth.x_px, truth.y_px, truth.mid_x_px, truth.mid_y_px)
    else {
        return;
    };
    let d =
        |(px, py): (f32, f32), (tx, ty): (f64, f64)| (f64::from(px) - tx).hypot(f64::from(py) - ty);
    let start = (2.0 * mx - x, 2.0 * my - y);
    // The middle's error along the true direction of travel and across it.
    let (vx, vy) = (truth.vx_px_s.unwrap_or(0.0), truth.vy_px_s.unwrap_or(0.0));
    let speed = vx.hypot(vy);
    let (ex, ey) = (f64::from(e.mid_px.0) - mx, f64::from(e.mid_px.1) - my);
    let split = |(ex, ey): (f64, f64)| {
        if speed > 0.0 {
            ((ex * vx + ey * vy) / speed, (ey * vx - ex * vy) / speed)
        } else {
            (f64::NAN, f64::NAN)
        }
    };
    let (mid_along, mid_across) = split((ex, ey));
    let (head_along, head_across) = split((
        f64::from(e.position_px.0) - x,
        f64::from(e.position_px.1) - y,
    ));
    let streak = best.map(|(_, s)| s);
    let path = streak.and_then(|s| s.path);
    eprintln!(
        "    frame {index:>2}: true len {:.1} px, head {:.2} px (along {:+.2}, across {:+.2}, from the start {:.2}), mid {:.2} px (along {:+.2}, across {:+.2}), \
         {} {}, fitted len {}, fit_px {} on a {} floor, thickness {}",
        truth.streak_px.unwrap_or(f64::NAN),
        d(e.position_px, (x, y)),
        head_along,
        head_across,
        d(e.position_px, start),
        d(e.mid_px, (mx, my)),
        mid_along,
        mid_across,
        e.position_method.name(),
        match (streak.map(|s| s.path_failed), path) {
            (Some(true), _) => "fit failed",
            (_, Some(p)) if p.ends_px[0] == p.ends_px[1] => "still",
            (_, Some(_)) => "path",
            _ => "no path",
        },
        path.map_or("-".to_string(), |p| format!("{:.2}", p.path_length_px)),
        path.and_then(|p| p.fit_px).map_or("-".to_string(), |f| format!("{f:.3}")),
        path.and_then(|p| p.fit_floor).map_or("-", |f| f.name()),
        streak.map_or("-".to_string(), |s| format!("{:.1}", s.thickness_px)),
    );
}

/// Errors of the heads of a still LED, in frames after the first, with `model`: detection and
/// the tracker's head without acquisition, which (rightly) never takes a round spot that stood
/// still since it appeared, alone in view, for the LED. Every frame must be detected.
fn still_heads(point: &SweepPoint, model: StreakModel) -> Vec<f64> {
    let scene = Scene::new(point.config()).expect("sweep scene");
    let size = FrameSize::new(scene.width_px(), scene.height_px()).unwrap();
    let config = DetectorConfig {
        streak_model: model,
        ..DetectorConfig::default()
    };
    let mut detector = Detector::new(size, config).unwrap();
    if let Some(optics) = optics(point) {
        detector.set_optics(optics);
    }
    let mut tracker = Tracker::new(TrackerConfig {
        exposure_us: Some(scene.exposure_us()),
    });
    let mut bytes = vec![0u8; scene.frame_len_bytes()];
    let period_us = (1e6 / scene.fps()) as u64;
    let mut head_px = Vec::new();
    for index in 0..scene.frame_count() {
        let truth = scene.render(index, &mut bytes).unwrap();
        let frame = Frame::new_checked(&bytes, size, size.row_bytes()).unwrap();
        let detection = detector.detect(&frame);
        let streak = detection.best.as_ref().map(|(_, s)| s);
        let estimate = tracker.update(index as u64 * period_us, streak);
        let e = estimate.unwrap_or_else(|| panic!("{point}: frame {index} not detected"));
        if index > 0 {
            if std::env::var_os("GLINT_SWEEP_FRAMES").is_some() {
                print_frame(index, &truth, &e, detection.best.as_ref());
            }
            let (x, y) = e.position_px;
            head_px.push(
                (f64::from(x) - truth.x_px.unwrap()).hypot(f64::from(y) - truth.y_px.unwrap()),
            );
        }
    }
    head_px
}

/// The goal for a nearly still LED on real footage: x, y within this of the
/// reference (p95).
const STILL_P95_MAX_PX: f64 = 0.75;

/// A still LED reads still: with either streak model, the position of an LED that does not
/// move stays within [`STILL_P95_MAX_PX`] of the truth for every spot, brightness, gamma, noise
/// and range of the sweep. Before the ramps' rule "a path no longer than the streak is wide is
/// still", they picked an "end" of a round blob and reported it up to 13.7 px off on the
/// sweep's still points.
fn assert_a_still_led_reads_still(model: StreakModel) {
    let mut worst = Vec::new();
    for mut point in SweepPoint::sweep(DEFAULT_SEED, 12) {
        point.path = SweepPath::Line {
            length_px: 0.0,
            angle_rad: 0.0,
        };
        let head_px = still_heads(&point, model);
        let p95 = quantile(&head_px, 0.95).unwrap();
        eprintln!("still, {model:?}: p95 {p95:.3} px: {point}");
        worst.push((p95, point.to_string()));
    }
    for (p95, point) in worst {
        assert!(
            p95 <= STILL_P95_MAX_PX,
            "{model:?}, {point}: p95 {p95:.3} px"
        );
    }
}

#[test]
fn a_still_led_reads_still() {
    assert_a_still_led_reads_still(StreakModel::Fit);
}

#[test]
fn a_still_led_reads_still_with_the_ramps() {
    assert_a_still_led_reads_still(StreakModel::Ramps);
}

/// The acquisition rules on the sweep, in the default run: an LED that moves into
/// place (the sweep's still kind, its first three points, with the fitted model) is reported
/// within [`ACQUIRE_MAX_FRAMES`] of the frame in which it had moved, never before, stays
/// tracked once it stops, and its head at rest is held to the sweep's bounds (before the
/// tracker took the slower of the three frames' and the last frame's velocity, the first
/// frames at rest read 2-5 px ahead with the fit).
#[test]
fn an_led_moving_into_place_is_acquired_as_it_moves_and_kept_at_rest() {
    for point in SweepPoint::sweep(DEFAULT_SEED, 12).into_iter().step_by(4) {
        assert!(matches!(point.path, SweepPath::Settle { .. }), "{point}");
        let s = run_point(&point, StreakModel::Fit);
        let delay = s.acquisition_delay();
        let p95 = quantile(&s.head_px, 0.95).unwrap();
        eprintln!("{point}: acquired {delay:?} frames after it moved, head p95 {p95:.3} px");
        assert!(delay.is_some_and(|d| d <= ACQUIRE_MAX_FRAMES), "{point}");
        assert_eq!(s.reported_still, 0, "{point}");
        assert_eq!(s.missed_tracked, 0, "{point}: lost once acquired");
        assert!(s.head_px.len() >= 9, "{point}: measured at rest");
        assert!(p95 <= HEAD_P95_MAX_PX, "{point}: head p95 {p95:.3} px");
    }
}

/// The spot the fitted model is made of (a Gaussian of σ 1.5 px, 4× the clip, seen through
/// gamma 2.2, clipped exactly at white) swept along a 20 px line, at read noise `noise_luma`.
fn gaussian_streak(noise_luma: f64) -> SweepPoint {
    let mut point = round(SweepPoint::new(DEFAULT_SEED, 1));
    point.spot = glint_tools::scene::SpotKind::Gaussian;
    point.width_px = 1.5;
    point.saturation = 4.0;
    point.gamma = 2.2;
    point.noise_luma = noise_luma;
    point.post_noise_luma = 0.0;
    point.path = SweepPath::Line {
        length_px: 20.0,
        angle_rad: 0.4,
    };
    point
}

/// A detector with the fitted streak model for frames of `size`.
fn fit_detector(size: FrameSize) -> glint::detect::Detector {
    let config = DetectorConfig {
        streak_model: StreakModel::Fit,
        ..DetectorConfig::default()
    };
    glint::detect::Detector::new(size, config).unwrap()
}

/// The fitted model on the spot it is made of (a Gaussian, seen through gamma 2.2, clipped)
/// over a flat floor: the ends of a 20 px streak land within 0.3 px of the truth, and the
/// reported uncertainty (`fit_px`) grows with the noise. (Over the presets' textured floor
/// the same streak's ends are about 0.6 px off, and `fit_px` says so: the model's floor is
/// flat. The sweep measures that case.)
#[test]
fn the_fit_finds_a_gaussian_streak_s_ends_and_knows_its_noise() {
    let mut uncertainties = Vec::new();
    for noise_luma in [0.0, 4.0] {
        let point = gaussian_streak(noise_luma);
        let mut config = point.config();
        config.floor.contrast = 0.0;
        let scene = Scene::new(config).unwrap();
        let size = FrameSize::new(scene.width_px(), scene.height_px()).unwrap();
        let mut detector = fit_detector(size);
        let mut bytes = vec![0u8; scene.frame_len_bytes()];
        let truth = scene.render(1, &mut bytes).unwrap();
        let frame = Frame::new_checked(&bytes, size, size.row_bytes()).unwrap();
        let (_, streak) = detector.detect(&frame).best.expect("the streak is found");
        let path = streak.path.expect("the fit converges");
        let end = (truth.x_px.unwrap(), truth.y_px.unwrap());
        let mid = (truth.mid_x_px.unwrap(), truth.mid_y_px.unwrap());
        let start = (2.0 * mid.0 - end.0, 2.0 * mid.1 - end.1);
        let d =
            |(x, y): (f32, f32), (tx, ty): (f64, f64)| (f64::from(x) - tx).hypot(f64::from(y) - ty);
        let [a, b] = path.ends_px;
        let error = (d(a, start).max(d(b, end))).min(d(a, end).max(d(b, start)));
        eprintln!(
            "noise {noise_luma}: ends within {error:.3} px, fit_px {:?}",
            path.fit_px
        );
        assert!(error <= 0.3, "noise {noise_luma}: ends {error:.3} px off");
        uncertainties.push(path.fit_px.unwrap());
    }
    assert!(
        uncertainties[1] > uncertainties[0],
        "fit_px grows with the noise: {uncertainties:?}"
    );
}

/// The same streak over the presets' textured floor: the fit learns the floor where the
/// streak is not (the frames before) and fits the light on it, so the texture under the
/// streak is not read as light. With a flat floor instead (the model before the learned one)
/// the noiseless ends are 0.19–0.33 px off here; with it they land within 0.1 px, and
/// at σ 4 luma within 0.5 px (the floor learned from two to five frames carries their noise).
#[test]
fn the_fit_reads_a_streak_on_a_textured_floor_it_has_seen() {
    for (noise_luma, bound_px) in [(0.0, 0.1), (4.0, 0.5)] {
        let point = gaussian_streak(noise_luma);
        let config = point.config();
        assert!(config.floor.contrast > 0.0, "the floor is textured");
        let scene = Scene::new(config).unwrap();
        let size = FrameSize::new(scene.width_px(), scene.height_px()).unwrap();
        let mut detector = fit_detector(size);
        let mut bytes = vec![0u8; scene.frame_len_bytes()];
        let mut worst_px = 0.0f64;
        for index in 0..scene.frame_count().min(6) {
            let truth = scene.render(index, &mut bytes).unwrap();
            let frame = Frame::new_checked(&bytes, size, size.row_bytes()).unwrap();
            let (_, streak) = detector.detect(&frame).best.expect("the streak is found");
            // The floor under the streak's start was under the last frame's streak: it is
            // seen from the third frame on. Before any floor is learned, the fit says it ran
            // on a flat one.
            // From the fourth frame on, every fitted pixel's floor has been seen.
            let floor = streak.path.and_then(|p| p.fit_floor);
            let expected = match index {
                0 => FitFloor::Flat,
                1 | 2 => FitFloor::Partly,
                _ => FitFloor::Learned,
            };
            assert_eq!(floor, Some(expected), "frame {index}");
            if index < 2 {
                continue;
            }
            let path = streak.path.expect("the fit converges");
            let end = (truth.x_px.unwrap(), truth.y_px.unwrap());
            let mid = (truth.mid_x_px.unwrap(), truth.mid_y_px.unwrap());
            let start = (2.0 * mid.0 - end.0, 2.0 * mid.1 - end.1);
            let d = |(x, y): (f32, f32), (tx, ty): (f64, f64)| {
                (f64::from(x) - tx).hypot(f64::from(y) - ty)
            };
            let [a, b] = path.ends_px;
            let error = (d(a, start).max(d(b, end))).min(d(a, end).max(d(b, start)));
            eprintln!("noise {noise_luma}, frame {index}: ends within {error:.3} px");
            worst_px = worst_px.max(error);
        }
        assert!(
            worst_px <= bound_px,
            "noise {noise_luma}: ends {worst_px:.3} px off"
        );
    }
}

/// Blooms whose saturated region is wide and flat: the fit reads the spot from the border of
/// the clipped region and the unclipped flanks, not from the clipped pixels inside, which
/// only say "at least the clip". Before the inside pixels were left out they were much of
/// the fitted pixels on these streaks (the body and caps subsampled among them), and a frame
/// here or there came out 2–6 px off (points 21 and 38 of the sweep, seed 11: head p95 3.08
/// and 1.66 px, speed p95 11 %). Their middles are not held here (README: the first frame's
/// floor is not learned yet, and a streak whose fitted σ is the glow's takes the middle of its
/// light). Point 182, a 60 px bloom 16× the clip, is not held either: now that it is taken in
/// its first frame, its second frame is fitted on a floor learned from one frame only and its
/// head lands 3 px off (its `fit_px`, 7 px, says so).
///
/// Both points as they were drawn before the sweep drew noise after the clip: point 21 draws
/// 1.0 luma of it now, and with it one frame's head lands 1.6 px off (the sweep counts it).
#[test]
fn a_bloom_s_wide_saturated_streak_gives_its_head_and_speed() {
    for index in [21, 38] {
        let mut point = round(SweepPoint::new(DEFAULT_SEED, index));
        point.post_noise_luma = 0.0;
        assert_eq!(point.spot, glint_tools::scene::SpotKind::Bloom, "{point}");
        let s = run_point(&point, StreakModel::Fit);
        let q = |v: &[f64], q: f64| quantile(v, q).unwrap_or(f64::NAN);
        let (median, p95) = (q(&s.head_px, 0.5), q(&s.head_px, 0.95));
        eprintln!(
            "{index}: head {median:.2}/{p95:.2} px, speed p95 {:.1} %: {point}",
            100.0 * q(&s.speed, 0.95)
        );
        // (Acquisition, not the fit, may miss the first frame: the head is held on the rest.)
        assert!(
            s.found + 1 >= s.visible,
            "{point}: found {} of {}",
            s.found,
            s.visible
        );
        assert!(
            median <= HEAD_MEDIAN_MAX_PX && p95 <= HEAD_P95_MAX_PX,
            "{point}: head {median:.2}/{p95:.2} px"
        );
        if point.path.length_px() >= SPEED_MIN_STREAK_PX {
            assert!(s.speed_missing * 10 <= s.visible, "{point}");
            assert!(
                q(&s.speed, 0.5) <= SPEED_MEDIAN_MAX && q(&s.speed, 0.95) <= SPEED_P95_MAX,
                "{point}: speed p95 {:.1} %",
                100.0 * q(&s.speed, 0.95)
            );
        }
    }
}

/// A 60 px streak of a Bloom whose clipped glow is 35 px wide (sweep seed 11, point 182, through
/// its lens). Thinning a blob that thick leaves spurs, and in its sixth frame the skeleton's
/// two ends lay across the streak, not along it: the fit started there did not converge (its
/// deviation 28 px), and the head given from the middles' motion was 14.5 px off. The blob's
/// moments give its axis whatever its spurs, so a skeleton whose chord lies across that axis
/// is not the rough path; the head holds the p95 bound in every frame. (The median of the
/// point's five heads sits at the 0.5 px: 0.49 px before the fit's narrow cold start,
/// 0.50 px with it, where frame 4's head moved by 0.01 px. The full sweep counts it there.)
#[test]
fn a_thick_streak_s_path_starts_along_its_axis() {
    let point = SweepPoint::new(DEFAULT_SEED, 182);
    let s = run_point(&point, StreakModel::Auto);
    assert!(s.found >= 5, "{point}: found {} of {}", s.found, s.visible);
    let worst_px = s.head_px.iter().copied().fold(0.0f64, f64::max);
    assert!(
        worst_px <= HEAD_P95_MAX_PX,
        "{point}: heads {:?} px",
        s.head_px
    );
}

/// 60 px streaks whose core is buried in a saturated glow (sweep seed 11, points 30 and 94):
/// the fitted spot is the glow (σ 6–12 px), so the streak is only two or three fitted spots
/// long, and its middle used to be taken from the light's centre, which over a wide glow on a
/// textured floor was 0.5–1.3 px off (point 94: 0.71–1.00 px in frames 2–5; point 30: 1.32 px
/// in frame 4). The fit pins these paths' ends to a few tenths of a pixel, a small fraction of
/// their length, and its middle is taken: within the 0.5 px (p95) in every frame once
/// the floor under the streak has been seen (from frame 2 on; frames 0 and 1 read it flat).
#[test]
fn a_long_streak_in_a_saturated_glow_takes_the_fitted_middle() {
    for index in [30, 94] {
        let point = round(SweepPoint::new(DEFAULT_SEED, index));
        assert_eq!(point.spot, SpotKind::Bloom, "{point}");
        assert_eq!(point.path.length_px(), MIDDLE_STREAK_PX, "{point}");
        let s = run_point(&point, StreakModel::Fit);
        let middles: Vec<(usize, f64)> = s
            .mid_frames
            .iter()
            .copied()
            .zip(s.mid_px.iter().copied())
            .filter(|&(frame, _)| frame >= 2)
            .collect();
        eprintln!("{index}: middles by frame {middles:.2?}: {point}");
        assert!(middles.len() >= 3, "{point}: {} frames", middles.len());
        for (frame, mid_px) in middles {
            assert!(
                mid_px <= MID_P95_MAX_PX,
                "{point}: frame {frame}: middle {mid_px:.2} px off"
            );
        }
    }
}

/// Sweep points searched for tight circles in a glow.
const TIGHT_ARC_POINTS: usize = 48;

/// A tight circle inside a saturated glow: its fitted path is as long as the glow is wide, so
/// it reads still, and its head was the middle carried by the last three frames' velocity,
/// which on a circle turning half a radian or more a frame points far from the tangent:
/// 10–14 px off on sweep points 7 and 39. The tracker now carries the middle by the middles'
/// turning motion (`src/track/motion.rs`): the head is `(1 + r) m_k − r m_{k−1}` turned, with
/// `r` half the exposure over the frame interval, so its error is at most `1 + 2 r` times
/// the middles' (their errors adding in the worst case), whatever the fit claims.
#[test]
fn a_tight_circle_in_a_glow_takes_its_head_from_the_middles_turn() {
    let period_s = 1.0 / 90.0;
    let exposure_s = 0.010;
    let r = 0.5 * exposure_s / period_s;
    let tight: Vec<SweepPoint> = SweepPoint::sweep(DEFAULT_SEED, TIGHT_ARC_POINTS)
        .into_iter()
        .filter(|p| match p.path {
            SweepPath::Arc {
                radius_px,
                length_px,
            } => p.spot == SpotKind::Bloom && length_px / radius_px * period_s / exposure_s >= 0.5,
            _ => false,
        })
        .collect();
    assert!(
        !tight.is_empty(),
        "no tight circle in a glow among the points"
    );
    for point in tight {
        let s = run_point(&point, StreakModel::Fit);
        let head = quantile(&s.head_px, 0.5).unwrap();
        let middle = quantile(&s.mid_px, 0.5).unwrap();
        eprintln!("{point}: head median {head:.2} px, middle median {middle:.2} px");
        assert!(
            head <= (1.0 + 2.0 * r) * middle,
            "{point}: head median {head:.2} px, middle {middle:.2} px"
        );
    }
}

fn env_or<T: std::str::FromStr>(name: &str, default: T) -> T {
    std::env::var(name)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

#[test]
#[ignore = "the bounds are not yet held on every point of the sweep (README)"]
fn every_sweep_point_holds_the_bounds() {
    let seed = env_or("GLINT_SWEEP_SEED", DEFAULT_SEED);
    let count = env_or("GLINT_SWEEP_POINTS", DEFAULT_POINTS);
    let model = match std::env::var("GLINT_STREAK_MODEL").as_deref() {
        Ok("ramps") => StreakModel::Ramps,
        Ok("fit") => StreakModel::Fit,
        _ => StreakModel::default(),
    };
    let mut failures = Vec::new();
    let mut misses = [0usize; 4];
    // Points acquired 0, 1, 2 and more frames after the LED had moved.
    let mut delays = [0usize; 4];
    let (mut all_head, mut all_mid60, mut all_speed) = (Vec::new(), Vec::new(), Vec::new());
    let only: Option<Vec<usize>> = std::env::var("GLINT_SWEEP_ONLY")
        .ok()
        .map(|v| v.split(',').filter_map(|i| i.parse().ok()).collect());
    let gamma: Option<f64> = std::env::var("GLINT_SWEEP_GAMMA")
        .ok()
        .and_then(|v| v.parse().ok());
    for mut point in SweepPoint::sweep(seed, count) {
        if let Some(gamma) = gamma {
            point.gamma = gamma;
        }
        if only.as_ref().is_some_and(|o| !o.contains(&point.index)) {
            continue;
        }
        let s = run_point(&point, model);
        misses[0] += s.missed_still;
        misses[1] += s.missed_acquiring;
        misses[2] += s.missed_tracked;
        misses[3] += s.missed_ambiguous;
        let delay = s.acquisition_delay();
        if let Some(d) = delay {
            delays[d.min(delays.len() - 1)] += 1;
        }
        let q = |v: &[f64], q: f64| quantile(v, q).unwrap_or(0.0);
        eprintln!(
            "{:>3} head {:.2}/{:.2} px, mid {:.2}/{:.2} px, speed {:.1}/{:.1} % ({} missing), \
             found {}/{}, acquired {}: {point}",
            point.index,
            q(&s.head_px, 0.5),
            q(&s.head_px, 0.95),
            q(&s.mid_px, 0.5),
            q(&s.mid_px, 0.95),
            100.0 * q(&s.speed, 0.5),
            100.0 * q(&s.speed, 0.95),
            s.speed_missing,
            s.found,
            s.visible,
            match (s.acquired, delay) {
                (Some(a), Some(d)) => format!("in frame {a}, {d} after it moved"),
                (Some(a), None) => format!("in frame {a}, before it moved"),
                (None, _) => "never".to_string(),
            },
        );
        if s.found != s.visible {
            eprintln!(
                "    not found: {} before it moved, {} while acquiring, {} lost after it was \
                 acquired ({} of them ambiguous)",
                s.missed_still, s.missed_acquiring, s.missed_tracked, s.missed_ambiguous,
            );
        }
        let mut fail =
            |what: String| failures.push(format!("point {}: {what} ({point})", point.index));
        // Every visible frame from the acquisition on is found; before it, the LED must have
        // moved (a light standing still since it appeared is never the LED, nor reported)
        // and be taken within ACQUIRE_MAX_FRAMES of that.
        if s.visible == 0 || s.first_motion.is_none() {
            fail(format!("{} visible frames, motion in none", s.visible));
        }
        match delay {
            None => fail(format!("never acquired in {} visible frames", s.visible)),
            Some(d) if d > ACQUIRE_MAX_FRAMES => {
                fail(format!("acquired {d} frames after it moved"));
            }
            Some(_) => {}
        }
        if s.missed_tracked > 0 {
            fail(format!(
                "lost in {} frames after acquisition",
                s.missed_tracked
            ));
        }
        if s.reported_still > 0 {
            fail(format!(
                "reported in {} frames before it moved",
                s.reported_still
            ));
        }
        if s.false_reports > 0 {
            fail(format!("{} false reports", s.false_reports));
        }
        if q(&s.head_px, 0.5) > HEAD_MEDIAN_MAX_PX || q(&s.head_px, 0.95) > HEAD_P95_MAX_PX {
            fail(format!(
                "head {:.2}/{:.2} px",
                q(&s.head_px, 0.5),
                q(&s.head_px, 0.95)
            ));
        }
        // The bound on the middle is for 60 px streaks.
        if point.path.length_px() == MIDDLE_STREAK_PX
            && (q(&s.mid_px, 0.5) > MID_MEDIAN_MAX_PX || q(&s.mid_px, 0.95) > MID_P95_MAX_PX)
        {
            fail(format!(
                "middle {:.2}/{:.2} px",
                q(&s.mid_px, 0.5),
                q(&s.mid_px, 0.95)
            ));
        }
        if point.path.length_px() >= SPEED_MIN_STREAK_PX
            && (s.speed_missing * 10 > s.visible
                || q(&s.speed, 0.5) > SPEED_MEDIAN_MAX
                || q(&s.speed, 0.95) > SPEED_P95_MAX)
        {
            fail(format!(
                "speed {:.1}/{:.1} %, {} frames without",
                100.0 * q(&s.speed, 0.5),
                100.0 * q(&s.speed, 0.95),
                s.speed_missing
            ));
        }
        all_head.extend(&s.head_px);
        if point.path.length_px() == MIDDLE_STREAK_PX {
            all_mid60.extend(&s.mid_px);
        }
        all_speed.extend(&s.speed);
    }
    let q = |v: &[f64], q: f64| quantile(v, q).unwrap_or(f64::NAN);
    eprintln!(
        "{model:?}, sweep seed {seed}, {count} points: head {:.3}/{:.3} px, middle on 60 px streaks \
         {:.3}/{:.3} px, speed on streaks >= 8 px {:.2}/{:.2} %",
        q(&all_head, 0.5),
        q(&all_head, 0.95),
        q(&all_mid60, 0.5),
        q(&all_mid60, 0.95),
        100.0 * q(&all_speed, 0.5),
        100.0 * q(&all_speed, 0.95),
    );
    eprintln!(
        "visible frames not found: {} before the LED moved, {} while acquiring, {} lost after \
         acquisition ({} of them ambiguous); acquired 0 / 1 / 2 / more frames after it moved: \
         {:?} points",
        misses[0], misses[1], misses[2], misses[3], delays
    );
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// Sweep points with Gaussian and blooming spots the ramps' speed is held on.
const GAUSSIAN_SPEED_POINTS: usize = 10;

/// The ramps read a Gaussian-like spot's ends from its line profile across the streak
/// (`src/detect/line_profile.rs`): on the first sweep points (seed 11) with a Gaussian or
/// blooming spot and a streak of at least 8 px, the single-frame speed's median error, pooled,
/// is within the 3 %. With the ends placed as for a disk, these ends landed 0.5–0.8 px
/// inside and the speed read short (pooled median 7.1 % on these points; 1.7 % now).
#[test]
fn the_ramps_read_a_gaussian_streak_s_speed() {
    let points: Vec<SweepPoint> = SweepPoint::sweep(DEFAULT_SEED, 4 * GAUSSIAN_SPEED_POINTS)
        .into_iter()
        .filter(|p| p.spot != SpotKind::Disk && p.path.length_px() >= SPEED_MIN_STREAK_PX)
        .take(GAUSSIAN_SPEED_POINTS)
        .collect();
    assert_eq!(points.len(), GAUSSIAN_SPEED_POINTS, "enough such points");
    let mut speed = Vec::new();
    for point in &points {
        let s = run_point(point, StreakModel::Ramps);
        eprintln!(
            "{}: speed median {:.1} %: {point}",
            point.index,
            100.0 * quantile(&s.speed, 0.5).unwrap_or(f64::NAN)
        );
        speed.extend(s.speed);
    }
    let median = quantile(&speed, 0.5).expect("speeds were read");
    eprintln!("pooled median {:.2} %", 100.0 * median);
    assert!(
        median <= SPEED_MEDIAN_MAX,
        "pooled median {:.2} %",
        100.0 * median
    );
}

/// A 60 px streak in a glow bright enough to clip on its own (its line profile across the
/// body, `saturation × glow width × glow ratio` of the clip, at least 1): the streak's edges
/// are the glow's, which carries the light 20–40 px out. The ramps and the line profile cut
/// their levels from the floor where that light has died (`src/detect/ray_floor.rs`); with the
/// floor read 14 px out, on the glow, every level was lifted towards the clip and these
/// streaks' speed read 16–17 % short. On the default run's points of the sweep (seed 11:
/// points 14 and 22) the pooled single-frame speed is within the bounds. NOT YET HELD further on: point 38 (seed 11) reads 5.7 %
/// short in the median, and points 30 and 34, whose glows are wider still, get no path.
#[test]
fn the_ramps_read_a_streak_s_speed_in_a_wide_glow() {
    let points: Vec<SweepPoint> = SweepPoint::sweep(DEFAULT_SEED, DEFAULT_POINTS)
        .into_iter()
        .filter(|p| {
            p.spot == SpotKind::Bloom
                && p.path.length_px() == MIDDLE_STREAK_PX
                && p.saturation * p.glow.0 * p.glow.1 >= 1.0
        })
        .collect();
    let mut speed = Vec::new();
    for point in &points {
        let s = run_point(point, StreakModel::Ramps);
        eprintln!("{}: speed {:?}: {point}", point.index, s.speed);
        speed.extend(s.speed);
    }
    assert!(
        speed.len() >= 4,
        "speeds were read on {} frames",
        speed.len()
    );
    let (median, p95) = (
        quantile(&speed, 0.5).unwrap(),
        quantile(&speed, 0.95).unwrap(),
    );
    eprintln!("pooled {:.2} / {:.2} %", 100.0 * median, 100.0 * p95);
    assert!(
        median <= SPEED_MEDIAN_MAX && p95 <= SPEED_P95_MAX,
        "pooled {:.2} / {:.2} %",
        100.0 * median,
        100.0 * p95
    );
}

/// The ramps' middle of a long straight streak is placed by the mirror symmetry of its light
/// (`src/detect/mirror_middle.rs`): on the default run's 60 px lines of spots without a glow
/// (a disk or a Gaussian; sweep seed 11), the middle, pooled over every frame, is within the
/// issue's bounds (0.2 / 0.5 px). The intensity-weighted centroid it was before, which weighs
/// the rim 30 px out on either side, read 0.22 / 0.60 px on these points (0.22 / 0.68 px
/// on point 18 alone). Blooms are left out: on a glow's shallow flank the floor's texture
/// moves the crossings by tenths of a pixel (README, "Accuracy over a sweep").
#[test]
fn the_ramps_place_a_long_streak_s_middle_by_its_symmetry() {
    let points: Vec<SweepPoint> = SweepPoint::sweep(DEFAULT_SEED, DEFAULT_POINTS)
        .into_iter()
        .filter(|p| {
            p.spot != SpotKind::Bloom
                && matches!(p.path, SweepPath::Line { length_px, .. } if length_px == MIDDLE_STREAK_PX)
        })
        .collect();
    assert!(points.len() >= 3, "{} such points", points.len());
    let mut middles = Vec::new();
    for point in &points {
        let s = run_point(point, StreakModel::Ramps);
        eprintln!("{}: middle {:.2?} px: {point}", point.index, s.mid_px);
        middles.extend(s.mid_px);
    }
    let (median, p95) = (
        quantile(&middles, 0.5).expect("middles were read"),
        quantile(&middles, 0.95).unwrap(),
    );
    eprintln!(
        "pooled {median:.3} / {p95:.3} px over {} frames",
        middles.len()
    );
    assert!(
        median <= MID_MEDIAN_MAX_PX && p95 <= MID_P95_MAX_PX,
        "pooled {median:.3} / {p95:.3} px"
    );
}

/// A sharp disk of about a pixel, clipped many times over, on 60 px lines at angles that cross
/// the pixel grid at every phase: its light falls from the clip to the floor within a pixel,
/// so one cross-section places the centre line only as well as the grid allows. Placed by the
/// lines across the whole body (a centre line fitted along it), the middle pooled over every
/// frame is within 0.1 px (median) and the 0.5 px (p95); measured 0.068 / 0.215 px.
/// By the lines across within a pixel of the bisector alone it was 0.153 / 0.313 px (sweep
/// seed 11's points 114 and 134, such disks, were 0.2–0.3 px across in most frames). What is
/// left at the p95 is along the streak, where only the two caps place the middle.
#[test]
fn a_sharp_disk_s_long_streak_is_centred_across_along_its_whole_body() {
    let mut middles = Vec::new();
    for (k, angle_rad) in [0.13, 0.52, 0.91, 1.27].into_iter().enumerate() {
        let mut point = gaussian_streak(2.5);
        point.spot = glint_tools::scene::SpotKind::Disk;
        point.width_px = [1.0, 1.2][k % 2];
        point.saturation = 15.0;
        point.path = SweepPath::Line {
            length_px: MIDDLE_STREAK_PX,
            angle_rad,
        };
        let s = run_point(&point, StreakModel::Ramps);
        eprintln!("{point}: middle {:.2?} px", s.mid_px);
        middles.extend(s.mid_px);
    }
    assert!(middles.len() >= 12, "{} middles", middles.len());
    let (median, p95) = (
        quantile(&middles, 0.5).unwrap(),
        quantile(&middles, 0.95).unwrap(),
    );
    eprintln!(
        "pooled {median:.3} / {p95:.3} px over {} frames",
        middles.len()
    );
    assert!(
        median <= 0.1 && p95 <= MID_P95_MAX_PX,
        "pooled {median:.3} / {p95:.3} px"
    );
}

/// A clip spread by noise after it (compression, sharpening or denoising after the sensor
/// clips: `post_noise_luma`), in full range (clamped at 255, so half the plateau reads 255)
/// and studio range (spread both ways around 235), on a Gaussian spot's 12 and 60 px streaks:
/// the speed and the head hold the bounds, pooled (measured: speed 0.6 / 4.4 %, head
/// 0.10 / 0.51 px, median / p95). Taking every saturated pixel below the blob's top luma as a
/// value, and cutting the blob a margin below that top (the plateau's highest noise), these
/// streaks' speed was 5.3 / 19.2 % and their head 0.30 / 1.45 px.
#[test]
fn a_clip_spread_by_noise_after_it_keeps_the_streak_s_length() {
    let (mut speed, mut head) = (Vec::new(), Vec::new());
    for (post_noise_luma, range) in [
        (1.0, Range::Full),
        (2.5, Range::Full),
        (1.0, Range::Studio),
        (2.5, Range::Studio),
    ] {
        for length_px in [12.0, 60.0] {
            let mut point = gaussian_streak(1.0);
            point.post_noise_luma = post_noise_luma;
            point.range = range;
            point.saturation = 8.0;
            point.path = SweepPath::Line {
                length_px,
                angle_rad: 0.7,
            };
            let s = run_point(&point, StreakModel::Auto);
            eprintln!(
                "{point}: head p95 {:.2} px, speed p95 {:.1} %",
                quantile(&s.head_px, 0.95).unwrap_or(f64::NAN),
                100.0 * quantile(&s.speed, 0.95).unwrap_or(f64::NAN)
            );
            assert_eq!(s.found, s.visible, "{point}");
            assert!(s.speed_missing * 10 <= s.visible, "{point}");
            speed.extend(s.speed);
            head.extend(s.head_px);
        }
    }
    let q = |v: &[f64], q: f64| quantile(v, q).unwrap_or(f64::NAN);
    eprintln!(
        "pooled: speed {:.2}/{:.2} %, head {:.3}/{:.3} px",
        100.0 * q(&speed, 0.5),
        100.0 * q(&speed, 0.95),
        q(&head, 0.5),
        q(&head, 0.95)
    );
    assert!(q(&speed, 0.5) <= SPEED_MEDIAN_MAX && q(&speed, 0.95) <= SPEED_P95_MAX);
    assert!(q(&head, 0.5) <= HEAD_MEDIAN_MAX_PX && q(&head, 0.95) <= HEAD_P95_MAX_PX);
}

/// The rolling-shutter sweep's readouts, as fractions of the frame period: a sensor running
/// at its top frame rate reads its rows over nearly the whole period, one slowed by its
/// exposure or its link over less.
const READOUT_RANGE: (f64, f64) = (0.4, 0.95);
/// Moving points (streaks of at least [`SPEED_MIN_STREAK_PX`]) the rolling-shutter sweep
/// takes in the default run (`GLINT_ROLLING_POINTS=N` takes N).
const ROLLING_POINTS: usize = 24;
/// How much of the shutter's skew may be left in the speed: the slope of the speed's error
/// against the skew, frame by frame. Uncorrected it is 1; 0.2 is about four standard errors
/// of the slope over the default run's 150-odd frames (the single frame's speed scatters by
/// about 2 % against a skew that varies by about 4 %).
const SKEW_LEFT_MAX: f64 = 0.2;
/// The mean difference from the global shutter's speed on the same frames.
const ROLLING_BIAS_MAX: f64 = 0.01;

/// The sweep seen through a rolling shutter: moving points of the sweep (every spot, width,
/// brightness, gamma, noise, range, lens and path kind it draws), each rendered once with a
/// global shutter and once reading a row every `τ` (a readout of 40–95 % of the frame period:
/// 10–22 µs a row at the sweep's 90 fps, skewing the speed by up to ±10 %), and tracked with
/// `--row-time-us τ`. Frame by frame against the global shutter's reading of the same frame,
/// the speed keeps at most [`SKEW_LEFT_MAX`] of the skew and reads within
/// [`ROLLING_BIAS_MAX`] of it on average; pooled, the speed and the head hold the issue's
/// bounds; and no frame the global shutter's track kept is lost. Measured on 24 / 40 / 120
/// points: +0.01 / +0.01 / −0.02 of the skew left (1.10 without `--row-time-us`), +0.63 /
/// +0.49 / +0.31 % from the global shutter. At these row times the spot's own skew is a tenth of a
/// pixel or two; that the spot is read through it is held in `tests/rolling_shutter.rs`, at
/// 62.5 µs rows (here, read round, 0.10 of the skew is left and the head's median is 0.03 px
/// worse).
#[test]
fn the_sweep_through_a_rolling_shutter_reads_the_leds_speed() {
    let count = env_or("GLINT_ROLLING_POINTS", ROLLING_POINTS);
    let points: Vec<SweepPoint> = (0..)
        .map(|i| SweepPoint::new(DEFAULT_SEED, i))
        .filter(|p| p.path.length_px() >= SPEED_MIN_STREAK_PX)
        .take(count)
        .collect();
    let (mut skews, mut differences) = (Vec::new(), Vec::new());
    let (mut speed, mut head) = (Vec::new(), Vec::new());
    let q = |v: &[f64], q: f64| quantile(v, q).unwrap_or(f64::NAN);
    for (k, point) in points.iter().enumerate() {
        let scene = Scene::new(point.config()).expect("sweep scene");
        // Spread evenly over the range, by the golden ratio's fractions.
        let fraction = (k as f64 * 0.618_033_988_75).fract();
        let readout = READOUT_RANGE.0 + fraction * (READOUT_RANGE.1 - READOUT_RANGE.0);
        let row_time_us = readout * 1e6 / scene.fps() / f64::from(scene.height_px());
        let global = run_point(point, StreakModel::Auto);
        let rolling = run_point_through(point, StreakModel::Auto, Some(row_time_us));
        let mut point_skews = Vec::new();
        for f in &rolling.speed_frames {
            if let Some(g) = global.speed_frames.iter().find(|g| g.index == f.index) {
                point_skews.push(shutter_skew(f.true_vy_px_s, row_time_us));
                differences.push(f.signed_error - g.signed_error);
            }
        }
        eprintln!(
            "{:>3} {row_time_us:.1} µs rows, skew {:+.1} %: speed {:.1}/{:.1} % (global {:.1}/{:.1} %), \
             head p95 {:.2} px (global {:.2}): {point}",
            point.index,
            100.0 * q(&point_skews, 0.5),
            100.0 * q(&rolling.speed, 0.5),
            100.0 * q(&rolling.speed, 0.95),
            100.0 * q(&global.speed, 0.5),
            100.0 * q(&global.speed, 0.95),
            q(&rolling.head_px, 0.95),
            q(&global.head_px, 0.95),
        );
        assert!(
            rolling.missed_tracked <= global.missed_tracked && rolling.false_reports == 0,
            "{point}: lost {} frames (global {}), {} false reports",
            rolling.missed_tracked,
            global.missed_tracked,
            rolling.false_reports
        );
        skews.extend(point_skews);
        speed.extend(rolling.speed);
        head.extend(rolling.head_px);
    }
    let (skew_left, bias) = slope_and_mean(&skews, &differences);
    let skew_spread = (skews.iter().map(|s| s * s).sum::<f64>() / skews.len() as f64).sqrt();
    eprintln!(
        "pooled over {} frames: speed {:.2}/{:.2} %, head {:.3}/{:.3} px; against the global \
         shutter {:+.2} %, {skew_left:+.3} of a skew of {:.1} % (rms) left",
        skews.len(),
        100.0 * q(&speed, 0.5),
        100.0 * q(&speed, 0.95),
        q(&head, 0.5),
        q(&head, 0.95),
        100.0 * bias,
        100.0 * skew_spread,
    );
    // The sweep exercises the shutter: uncorrected, its speeds would be skewed by this much.
    assert!(
        skew_spread > 0.02,
        "skew {:.2} % (rms)",
        100.0 * skew_spread
    );
    assert!(
        skew_left.abs() <= SKEW_LEFT_MAX,
        "{skew_left:+.3} of the skew left"
    );
    assert!(
        bias.abs() <= ROLLING_BIAS_MAX,
        "{:+.2} % from the global shutter",
        100.0 * bias
    );
    assert!(
        q(&speed, 0.5) <= SPEED_MEDIAN_MAX && q(&speed, 0.95) <= SPEED_P95_MAX,
        "speed {:.2}/{:.2} %",
        100.0 * q(&speed, 0.5),
        100.0 * q(&speed, 0.95)
    );
    assert!(
        q(&head, 0.5) <= HEAD_MEDIAN_MAX_PX && q(&head, 0.95) <= HEAD_P95_MAX_PX,
        "head {:.3}/{:.3} px",
        q(&head, 0.5),
        q(&head, 0.95)
    );
}

/// Points of the sweep drawn through tone curves outside its own 1.8–2.4.
const OTHER_CURVES_POINTS: usize = 40;

/// Tone curves outside the sweep's 1.8–2.4: a linear camera (gamma 1, as machine-vision
/// cameras often deliver their luma) and a steep one (2.8). The sweep's first
/// [`OTHER_CURVES_POINTS`] points, drawn through each, hold the bounds pooled on the
/// head and the single-frame speed and the 60 px middle's median, with no false report and
/// no tracked LED lost (README, "A linear camera"; measured: head p95 1.00 and 0.93 px,
/// speed p95 8.0 and 6.0 %). NOT YET HELD, so not asserted: the 60 px middle's p95 over
/// these points, which three blooms' middles put at 0.52 and 0.84 px, and at 0.91 px drawn
/// through the sweep's own curves.
#[test]
fn the_sweep_through_other_tone_curves_holds_the_pooled_bounds() {
    let q = |v: &[f64], q: f64| quantile(v, q).unwrap_or(f64::NAN);
    let mut out = Vec::new();
    for gamma in [1.0, 2.8] {
        let (mut head, mut mid60, mut speed) = (Vec::new(), Vec::new(), Vec::new());
        let (mut false_reports, mut lost) = (0usize, 0usize);
        for mut point in SweepPoint::sweep(DEFAULT_SEED, OTHER_CURVES_POINTS) {
            point.gamma = gamma;
            let s = run_point(&point, StreakModel::Auto);
            false_reports += s.false_reports;
            lost += s.missed_tracked;
            head.extend(&s.head_px);
            if point.path.length_px() == MIDDLE_STREAK_PX {
                mid60.extend(&s.mid_px);
            }
            speed.extend(&s.speed);
        }
        let figures = format!(
            "gamma {gamma}: head {:.3}/{:.3} px, middle on 60 px streaks {:.3}/{:.3} px, speed \
             {:.2}/{:.2} %, {false_reports} false reports, {lost} frames lost",
            q(&head, 0.5),
            q(&head, 0.95),
            q(&mid60, 0.5),
            q(&mid60, 0.95),
            100.0 * q(&speed, 0.5),
            100.0 * q(&speed, 0.95),
        );
        eprintln!("{figures}");
        if q(&head, 0.5) > HEAD_MEDIAN_MAX_PX
            || q(&head, 0.95) > HEAD_P95_MAX_PX
            || q(&mid60, 0.5) > MID_MEDIAN_MAX_PX
            || q(&speed, 0.5) > SPEED_MEDIAN_MAX
            || q(&speed, 0.95) > SPEED_P95_MAX
            || false_reports > 0
            || lost > 0
        {
            out.push(figures);
        }
    }
    assert!(out.is_empty(), "{}", out.join("\n"));
}
