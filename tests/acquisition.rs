//! Acquisition and the automatic level against the scene renderer's truth, over a small sweep
//! of each situation (glare size, shape and level; LED brightness; noise):
//!
//! - the LED at rest at the start among static glare of several shapes: `ambiguous` and
//!   `found: false` while it stands still, then found once it moves, and never the glare;
//! - a hot pixel brighter than an LED the camera does not clip;
//! - a large clipped window beside an LED dimmer than the window;
//! - an LED passing along a clipped window it touches, before the window is learned;
//! - three LEDs on one rigid body: the tracker stays on one of them.
//!
//! In every case: after acquisition every visible frame is found, and every report lies
//! within [`REPORT_TOLERANCE_PX`] of the true LED (no false reports).

use glint::detect::{Detector, DetectorConfig};
use glint::frame::{Frame, FrameSize};
use glint::pipeline::{Pipeline, PipelineConfig};
use glint::report::FrameReport;
use glint::source::FrameMeta;
use glint::track::{TrackerConfig, SMEARED_ELONGATION};
use glint_tools::scene::{
    Point, Scene, SceneConfig, Spot, StaticLight, Trajectory, Truth, Visibility,
};

/// A report farther than this from the true LED is a false report.
const REPORT_TOLERANCE_PX: f64 = 3.0;

/// Current-position p95 bound, as in `tests/replay_accuracy.rs`.
const POS_P95_MAX_PX: f64 = 1.5;

/// Current-position median bound for an LED whose spot touches a clipped window. Not the
/// accuracy tests' 0.5: the part of the spot that lies on the window's rim is taken out with
/// the window, before the window is learned as after, and the middle across the edge is read
/// from what is left (0.5 px towards the window on a Gaussian spot 1 px from it).
const BESIDE_WINDOW_MEDIAN_MAX_PX: f64 = 0.75;

/// Current-position median bound for a dot that does not clip. Not the accuracy tests' 0.5:
/// with 2.5 luma of noise an unclipped dot's head is 0.6 px off in the median (0.04–0.06 px at
/// 1–2 luma), which is the streak model's to improve, not acquisition's.
const DIM_DOT_MEDIAN_MAX_PX: f64 = 0.75;

/// Frames after the LED starts to move within which it must be acquired (0.2 s at 30 fps).
const ACQUIRE_WITHIN_FRAMES: usize = 6;

/// Runs glint's pipeline in-process over every frame of `config`'s scene.
fn run(config: SceneConfig) -> (Scene, Vec<(FrameReport, Truth)>) {
    let scene = Scene::new(config).expect("valid scene");
    let size = FrameSize::new(scene.width_px(), scene.height_px()).unwrap();
    let pipeline_config = PipelineConfig {
        tracker: TrackerConfig {
            exposure_us: Some(scene.exposure_us()),
        },
        ..PipelineConfig::default()
    };
    let mut pipeline = Pipeline::new(size, pipeline_config).unwrap();
    let mut buffer = vec![0u8; scene.frame_len_bytes()];
    let frame_us = 1e6 / scene.fps();
    let reports = (0..scene.frame_count())
        .map(|i| {
            let truth = scene.render(i, &mut buffer).unwrap();
            let frame = Frame::new_checked(&buffer, size, size.row_bytes()).unwrap();
            let meta = FrameMeta {
                index: i as u64,
                sequence: i as u64,
                dropped: 0,
                timestamp_us: (i as f64 * frame_us) as u64,
                monotonic_us: (i as f64 * frame_us) as u64,
            };
            (pipeline.process(&frame, meta), truth)
        })
        .collect();
    (scene, reports)
}

/// Distance of a report's position from a truth shifted by `offset_px`.
fn error_px(report: &FrameReport, truth: &Truth, offset_px: Point) -> Option<f64> {
    let p = report.position?.position_px;
    let (x, y) = (truth.x_px? + offset_px.x, truth.y_px? + offset_px.y);
    Some((f64::from(p.0) - x).hypot(f64::from(p.1) - y))
}

/// Holds a run to the common rules: from the first found frame on, every visible frame is
/// found, every report is within tolerance of the LED at `offset_px` from the truth, and
/// nothing is reported while the LED is hidden. Returns the first found frame.
fn check(label: &str, runs: &[(FrameReport, Truth)], offset_px: Point) -> usize {
    let first = runs
        .iter()
        .position(|(r, _)| r.position.is_some())
        .unwrap_or_else(|| panic!("{label}: the LED is never found"));
    let mut worst_px: f64 = 0.0;
    for (i, (report, truth)) in runs.iter().enumerate() {
        match truth.visible {
            Visibility::Hidden => {
                assert!(report.position.is_none(), "{label}: frame {i} hidden");
            }
            Visibility::Visible if i >= first => {
                let error = error_px(report, truth, offset_px)
                    .unwrap_or_else(|| panic!("{label}: frame {i} visible but not found"));
                worst_px = worst_px.max(error);
                assert!(
                    error <= REPORT_TOLERANCE_PX,
                    "{label}: frame {i} reported {error:.1} px from the LED"
                );
            }
            _ => {
                if let Some(error) = error_px(report, truth, offset_px) {
                    assert!(error <= REPORT_TOLERANCE_PX, "{label}: frame {i} off");
                }
            }
        }
    }
    eprintln!("{label}: acquired in frame {first}, worst report {worst_px:.2} px");
    first
}

/// The q-quantile of `sorted` by nearest rank.
fn nearest_rank(sorted: &[f64], q: f64) -> f64 {
    sorted[((q * sorted.len() as f64).ceil() as usize).max(1) - 1]
}

/// `speed-ramp` (an LED at rest for about 7 frames, then a run) with its spot a bloom: a glow
/// `glow_width` times the core's σ at `glow_ratio` of its radiance, on a camera of read noise
/// `noise` (clip units) and tone exponent `gamma`.
fn speed_ramp_in_bloom(glow_width: f64, glow_ratio: f64, noise: f64, gamma: f64) -> SceneConfig {
    in_bloom(preset("speed-ramp"), glow_width, glow_ratio, noise, gamma)
}

/// `config` with its spot a bloom: a glow `glow_width` times the core's σ at `glow_ratio` of
/// its radiance, on a camera of read noise `noise` (clip units) and tone exponent `gamma`.
fn in_bloom(
    mut config: SceneConfig,
    glow_width: f64,
    glow_ratio: f64,
    noise: f64,
    gamma: f64,
) -> SceneConfig {
    config.camera.noise_sigma = noise;
    config.camera.gamma = gamma;
    let sigma_px = config.led.radius_px;
    config.led.spot = Spot::Bloom {
        sigma_px,
        glow_sigma_px: glow_width * sigma_px,
        glow_ratio,
    };
    config.led.glow_peak = 0.0;
    config
}

fn preset(name: &str) -> SceneConfig {
    Scene::preset_config(name).unwrap_or_else(|| panic!("no preset {name}"))
}

#[test]
fn an_led_at_rest_among_static_glare_is_not_guessed() {
    // Glare size scale, glare level (clip units), noise σ.
    for (scale, peak, noise) in [(0.7, 1.3, 0.005), (1.0, 3.0, 0.01), (1.6, 8.0, 0.02)] {
        let mut config = preset("rest-glare");
        config.frame_count = 60;
        config.camera.noise_sigma = noise;
        for light in &mut config.static_lights {
            match light {
                StaticLight::Ellipse {
                    radii_px, peak: p, ..
                } => {
                    *radii_px = Point::new(radii_px.x * scale, radii_px.y * scale);
                    *p = peak;
                }
                StaticLight::Rect {
                    width_px,
                    height_px,
                    peak: p,
                    ..
                } => {
                    *width_px *= scale;
                    *height_px *= scale;
                    *p = peak;
                }
                StaticLight::Pixel { .. } => {}
            }
        }
        let label = format!("rest-glare ×{scale} at {peak}× clip, σ {noise}");
        let (_, runs) = run(config);
        let rest = runs
            .iter()
            .take_while(|(_, t)| t.vx_px_s == Some(0.0) && t.vy_px_s == Some(0.0))
            .count();
        assert!(rest >= 25, "{label}: the LED rests about a second: {rest}");
        for (i, (report, _)) in runs.iter().take(rest).enumerate() {
            assert!(
                report.position.is_none() && report.ambiguous,
                "{label}: frame {i}, LED at rest among glare, must be ambiguous"
            );
        }
        let first = check(&label, &runs, Point::default());
        assert!(
            first <= rest + ACQUIRE_WITHIN_FRAMES,
            "{label}: acquired {first}, moving from {rest}"
        );
    }
}

#[test]
fn a_hot_pixel_does_not_hide_an_unclipped_led() {
    // LED radiance over the floor (top from about 232 to 248), hot pixel, noise σ.
    for (led_peak, hot, noise) in [(0.52, 0.96, 0.004), (0.55, 0.97, 0.008), (0.6, 1.0, 0.01)] {
        let mut config = preset("hot-pixel");
        config.frame_count = 60;
        config.led.peak = led_peak;
        config.camera.noise_sigma = noise;
        for light in &mut config.static_lights {
            if let StaticLight::Pixel { radiance, .. } = light {
                *radiance = hot;
            }
        }
        let label = format!("hot-pixel LED {led_peak}, hot {hot}, σ {noise}");
        let (_, runs) = run(config);
        // Round and creeping, alone in view: not told from a glare spot until it has crept
        // DRIFT_PX from where it first appeared; ambiguous until then, found from the frame in
        // which it crossed that distance on.
        let (_, start) = &runs[0];
        let crept = runs
            .iter()
            .position(|(_, t)| {
                let (x0, y0) = (start.mid_x_px.unwrap(), start.mid_y_px.unwrap());
                let (x, y) = (t.mid_x_px.unwrap(), t.mid_y_px.unwrap());
                (x - x0).hypot(y - y0) > f64::from(glint::track::statics::DRIFT_PX)
            })
            .unwrap();
        let first = check(&label, &runs, Point::default());
        assert!(
            first <= crept,
            "{label}: acquired in frame {first}, crept 2 px by {crept}"
        );
        assert!(runs[..first].iter().all(|(r, _)| r.ambiguous));
    }
}

#[test]
fn an_led_dimmer_than_a_window_is_found_beside_it() {
    // LED radiance over the floor, window size scale and level, noise σ.
    for (led_peak, scale, window, noise) in [
        (0.54, 1.0, 1.1, 0.004),
        (0.56, 0.6, 1.5, 0.008),
        (0.6, 1.3, 3.0, 0.01),
    ] {
        let mut config = preset("window");
        config.frame_count = 60;
        config.led.peak = led_peak;
        config.camera.noise_sigma = noise;
        for light in &mut config.static_lights {
            if let StaticLight::Rect {
                width_px,
                height_px,
                peak,
                ..
            } = light
            {
                *width_px *= scale;
                *height_px *= scale;
                *peak = window;
            }
        }
        let label = format!("window ×{scale} at {window}, LED {led_peak}, σ {noise}");
        let (_, runs) = run(config);
        assert!(
            check(&label, &runs, Point::default()) <= 1,
            "{label}: acquired late"
        );
    }
}

#[test]
fn three_leds_on_one_body_the_tracker_stays_on_one() {
    // The tracked LED's and its companions' radiance (clip units), noise σ. At 0.62 over the
    // floor the first LED barely reaches clip: a level taken from the brightest LED in view
    // would make it flicker in and out of the mask.
    for (peak, peaks, noise) in [
        (20.0, [6.0, 2.0], 0.005),
        (20.0, [20.0, 1.3], 0.01),
        (2.0, [1.5, 20.0], 0.02),
        (0.62, [20.0, 6.0], 0.01),
    ] {
        let mut config = preset("three-leds");
        config.frame_count = 90;
        config.camera.noise_sigma = noise;
        config.led.peak = peak;
        for (companion, peak) in config.companions.iter_mut().zip(peaks) {
            companion.led.peak = peak;
        }
        let offsets: Vec<Point> = core::iter::once(Point::default())
            .chain(config.companions.iter().map(|c| c.offset_px))
            .collect();
        let label = format!("three-leds {peak} and {peaks:?}, σ {noise}");
        let (_, runs) = run(config);
        let (first_report, first_truth) = runs
            .iter()
            .find(|(r, _)| r.position.is_some())
            .unwrap_or_else(|| panic!("{label}: never found"));
        let offset = offsets
            .iter()
            .copied()
            .min_by(|a, b| {
                let e = |o: Point| error_px(first_report, first_truth, o).unwrap();
                e(*a).total_cmp(&e(*b))
            })
            .unwrap();
        let first = check(&label, &runs, offset);
        assert!(first <= 1, "{label}: acquired in frame {first}");
    }
}

/// The real-footage case: a dot whose peak is 216–250 moving beside a static window that
/// reads 244 and up (its noise straddles any level cut just below its top), over a sweep of
/// window level and size, dot brightness and noise. The window is never reported; the dot is
/// found in at least 99 % of its visible frames, within the accuracy tests' position bounds.
#[test]
fn a_dim_dot_beside_a_window_that_reads_244_and_up() {
    // Window radiance over the floor (0.57: about 245, not clipped; 0.62: just clipped; 1.5:
    // clipped), its size scale, the dot's radiance over the floor (0.46: peak about 216; 0.6:
    // about 250) and noise σ, each row one point of the sweep.
    for (window, scale, dot, noise) in [
        (0.57, 1.0, 0.46, 0.004),
        (0.57, 1.6, 0.52, 0.01),
        (0.62, 0.6, 0.46, 0.008),
        (0.62, 1.3, 0.6, 0.004),
        (1.5, 1.0, 0.5, 0.01),
        (1.5, 1.6, 0.46, 0.006),
    ] {
        let mut config = preset("window");
        config.led.peak = dot;
        config.camera.noise_sigma = noise;
        for light in &mut config.static_lights {
            if let StaticLight::Rect {
                width_px,
                height_px,
                peak,
                ..
            } = light
            {
                *width_px *= scale;
                *height_px *= scale;
                *peak = window;
            }
        }
        let label = format!("window ×{scale} at {window}, dot {dot}, σ {noise}");
        let (_, runs) = run(config);
        let visible = runs
            .iter()
            .filter(|(_, t)| t.visible == Visibility::Visible)
            .count();
        let mut errors: Vec<f64> = runs
            .iter()
            .filter_map(|(r, t)| error_px(r, t, Point::default()))
            .collect();
        let worst = errors.iter().copied().fold(0.0, f64::max);
        errors.sort_by(f64::total_cmp);
        let quantile = |q: f64| nearest_rank(&errors, q);
        eprintln!(
            "{label}: found {} of {visible}, position median {:.2} p95 {:.2} worst {worst:.2} px",
            errors.len(),
            quantile(0.5),
            quantile(0.95)
        );
        assert!(
            worst <= REPORT_TOLERANCE_PX,
            "{label}: a report {worst:.1} px from the dot"
        );
        assert!(
            errors.len() * 100 >= visible * 99,
            "{label}: found in {} of {visible} visible frames",
            errors.len()
        );
        assert!(quantile(0.5) <= DIM_DOT_MEDIAN_MAX_PX, "{label}: median");
        assert!(quantile(0.95) <= POS_P95_MAX_PX, "{label}: p95");
    }
}

/// Three LEDs on one rigid body, close together (22–30 px) and far apart (real footage: 43
/// jumps of 116–223 px between LEDs): the track never jumps to another LED. The first frame of
/// a track acquired because it moved starts from where it came from, so the second frame does
/// not predict it standing still and take another LED now nearer its old place.
#[test]
fn three_close_leds_moving_together_the_track_never_jumps() {
    // Companion offsets (px) and brightness (clip units), noise σ.
    for (offsets, peaks, noise) in [
        ([(22.0, 0.0), (11.0, 19.0)], [6.0, 20.0], 0.005),
        ([(30.0, -10.0), (-15.0, 25.0)], [20.0, 1.5], 0.01),
        ([(120.0, 40.0), (-100.0, 90.0)], [20.0, 20.0], 0.008),
    ] {
        let mut config = preset("three-leds");
        config.frame_count = 90;
        config.camera.noise_sigma = noise;
        for ((companion, offset), peak) in config.companions.iter_mut().zip(offsets).zip(peaks) {
            companion.offset_px = Point::new(offset.0, offset.1);
            companion.led.peak = peak;
        }
        let label = format!("three-leds at {offsets:?}, {peaks:?}, σ {noise}");
        let (_, runs) = run(config);
        // The LED taken is the one nearest the first report; every later report must be
        // nearest that one too: no jump.
        let all: Vec<Point> = core::iter::once(Point::default())
            .chain(offsets.iter().map(|&(x, y)| Point::new(x, y)))
            .collect();
        let nearest = |r: &FrameReport, t: &Truth| {
            all.iter()
                .copied()
                .min_by(|a, b| {
                    let e = |o: Point| error_px(r, t, o).unwrap_or(f64::INFINITY);
                    e(*a).total_cmp(&e(*b))
                })
                .unwrap()
        };
        let (first_report, first_truth) = runs
            .iter()
            .find(|(r, _)| r.position.is_some())
            .unwrap_or_else(|| panic!("{label}: never found"));
        let taken = nearest(first_report, first_truth);
        let jumps = runs
            .iter()
            .filter(|(r, t)| r.position.is_some() && nearest(r, t) != taken)
            .count();
        eprintln!("{label}: {jumps} jumps");
        assert_eq!(jumps, 0, "{label}: the track jumped between LEDs");
        assert!(check(&label, &runs, taken) <= 1, "{label}: acquired late");
    }
}

/// A single glare spot in view and no LED (round or elongated, dim or bright): it has stood
/// still since it appeared, so it is never reported.
#[test]
fn a_lone_glare_spot_with_no_led_in_view_is_never_reported() {
    // Radii (px), level (clip units), noise σ.
    for (radii, peak, noise) in [
        ((3.0, 3.0), 3.0, 0.005),
        ((5.0, 4.0), 1.3, 0.01),
        ((14.0, 2.5), 8.0, 0.008),
    ] {
        let mut config = preset("rest-glare");
        config.frame_count = 45;
        config.camera.noise_sigma = noise;
        config.led.peak = 0.0;
        config.static_lights = vec![StaticLight::Ellipse {
            centre_px: Point::new(300.0, 200.0),
            radii_px: Point::new(radii.0, radii.1),
            angle_rad: 0.5,
            peak,
        }];
        let label = format!("lone glare {radii:?} at {peak}, σ {noise}");
        let (_, runs) = run(config);
        let reported = runs.iter().filter(|(r, _)| r.position.is_some()).count();
        let seen = runs
            .iter()
            .filter(|(r, _)| r.detection.blob_count > 0)
            .count();
        eprintln!("{label}: seen in {seen} frames, reported in {reported}");
        assert_eq!(seen, runs.len(), "{label}: the glare is in the mask");
        // An elongated spot alone in the first frame looks like a smear: it may be reported
        // in that frame and the next (a reversing streak stands still for one), never after.
        // So may one whose streak reads a path longer than the spot the fit measures: the
        // 5×4 px spot at 1.3 times the clip reads as a 2.9 px path of a 2.0 px spot, 0.3 px
        // deviation (a sharp-edged spot is a narrow core to the fit).
        assert!(
            runs.iter().skip(2).all(|(r, _)| r.position.is_none()),
            "{label}: reported"
        );
        if radii.0 == radii.1 {
            assert_eq!(reported, 0, "{label}: a round spot is never reported");
        }
    }
}

/// An LED at rest in a wide glow that clips (a bloom 20–35 px across) lights the floor beside
/// it: specks of its rim cut at a level near its top, and of the floor's bright texture lit up
/// to the clip or just short of it, split from the glow by the floor's dark lines. The specks
/// merge and split with the noise, so their mass centres wander by more than a blob that
/// "stood still". None of them is the LED: while the LED rests nothing is reported; once it
/// moves it is taken, starting from where it rested, and every report after is the LED's (its
/// first head, and every path's middle, within tolerance: the later heads of an LED starting
/// off inside its own clipped glow are not this test's concern, see the README).
#[test]
fn the_floor_an_led_at_rest_lights_through_its_glow_is_never_reported() {
    // Glow σ over core σ, glow over core radiance, core radiance (clip units), noise σ,
    // gamma: the glow's centre from 0.6 to 1.5 times the clip.
    for (glow_width, glow_ratio, peak, noise, gamma) in [
        (4.0, 0.05, 20.0, 0.01, 1.0),
        (3.0, 0.1, 20.0, 0.004, 1.8),
        (4.0, 0.04, 30.0, 0.008, 1.0),
        (4.0, 0.1, 12.0, 0.008, 1.0),
        (5.0, 0.04, 20.0, 0.004, 1.0),
        (5.0, 0.05, 20.0, 0.012, 2.4),
        (3.0, 0.05, 30.0, 0.008, 2.2),
        (3.0, 0.03, 20.0, 0.006, 1.0),
    ] {
        let mut config = speed_ramp_in_bloom(glow_width, glow_ratio, noise, gamma);
        config.frame_count = 20;
        config.led.peak = peak;
        let label =
            format!("glow {glow_width}σ at {glow_ratio}, peak {peak}, σ {noise}, γ {gamma}");
        let (_, runs) = run(config);
        let rest = runs
            .iter()
            .take_while(|(_, t)| t.vx_px_s == Some(0.0) && t.vy_px_s == Some(0.0))
            .count();
        assert!(rest >= 6, "{label}: the LED rests first: {rest} frames");
        let mut first = None;
        let mut worst_px: f64 = 0.0;
        for (i, (report, truth)) in runs.iter().enumerate() {
            let Some(position) = report.position else {
                assert!(first.is_none(), "{label}: frame {i} lost after acquisition");
                continue;
            };
            assert!(i >= rest, "{label}: frame {i} reported while the LED rests");
            if first.is_none() {
                // The track starts from the LED's resting place, not from a speck beside it
                // that flickered as if it moved: the first head is the LED's.
                let head_px = error_px(report, truth, Point::default()).unwrap();
                assert!(
                    head_px <= REPORT_TOLERANCE_PX,
                    "{label}: frame {i}, the first, has its head {head_px:.1} px off"
                );
            }
            first.get_or_insert(i);
            let (mx, my) = position.mid_px;
            let (tx, ty) = (truth.path_mid_x_px.unwrap(), truth.path_mid_y_px.unwrap());
            let error_px = (f64::from(mx) - tx).hypot(f64::from(my) - ty);
            worst_px = worst_px.max(error_px);
            assert!(
                error_px <= REPORT_TOLERANCE_PX,
                "{label}: frame {i} reported {error_px:.1} px from the LED's path"
            );
        }
        let first = first.unwrap_or_else(|| panic!("{label}: never found"));
        eprintln!(
            "{label}: at rest for {rest} frames, acquired in frame {first}, worst middle \
             {worst_px:.2} px"
        );
        assert!(
            first <= rest + ACQUIRE_WITHIN_FRAMES,
            "{label}: acquired late"
        );
    }
}

/// The goal for a nearly still LED (x, y within this of the truth, p95), as in
/// `tests/streak_sweep.rs`.
const STILL_P95_MAX_PX: f64 = 0.75;

/// An LED come to rest in a glow that clips 20–35 px across reads still: its position at rest
/// stays within [`STILL_P95_MAX_PX`] (p95) of where it is. Before the centre of its light
/// above the learned floor was taken, the fit's middle of so round a blob jittered, and the
/// default bloom read 1.24 px off at p95.
#[test]
fn an_led_at_rest_in_its_clipped_glow_reads_still() {
    // Glow σ over core σ, glow over core radiance, noise σ, gamma.
    for (glow_width, glow_ratio, noise, gamma) in [
        (4.0, 0.05, 0.01, 1.0),
        (3.0, 0.1, 0.004, 1.8),
        (5.0, 0.04, 0.008, 2.2),
    ] {
        let label = format!("glow {glow_width}σ at {glow_ratio}, σ {noise}, γ {gamma}");
        let (_, runs) = run(speed_ramp_in_bloom(glow_width, glow_ratio, noise, gamma));
        // The frames after the LED came to rest, but the first (its last move's end).
        let arrived = runs
            .iter()
            .rposition(|(_, t)| t.vx_px_s != Some(0.0) || t.vy_px_s != Some(0.0))
            .unwrap_or_else(|| panic!("{label}: the LED moves"));
        let mut errors: Vec<f64> = runs[arrived + 2..]
            .iter()
            .map(|(r, t)| {
                error_px(r, t, Point::default())
                    .unwrap_or_else(|| panic!("{label}: at rest, not found"))
            })
            .collect();
        assert!(
            errors.len() >= 20,
            "{label}: {} frames at rest",
            errors.len()
        );
        errors.sort_by(f64::total_cmp);
        let p95 = nearest_rank(&errors, 0.95);
        eprintln!(
            "{label}: at rest over {} frames, median {:.3} px, p95 {p95:.3} px",
            errors.len(),
            nearest_rank(&errors, 0.5)
        );
        assert!(p95 <= STILL_P95_MAX_PX, "{label}: p95 {p95:.3} px");
    }
}

/// An LED moving from the first frame in a glow that clips round it (a bloom whose glow is 3–4
/// times the core's σ at 0.03–0.1 of its radiance, the glow's centre near the clip): its
/// outline is round, the streak shorter than the clipped glow is wide, so that the outline
/// alone cannot call it smeared (and the test asserts that). Its streak can: the fitted path
/// is longer than the spot the fit measures is wide. It is taken in the first frame, at its
/// streak's middle, and kept. These are the points of a grid (glow 3–4σ at 0.03–0.1, core at
/// 10–30 times the clip, streaks of 8–20 px) where the first frame's fit, cold and on a floor
/// not yet learned, resolves the path; at most others its ends' deviation (2–20 px) covers the
/// path, and the frame stays `ambiguous` until the LED has moved (README, "A smear in a glow
/// that clips round").
#[test]
fn a_smear_in_a_glow_that_clips_round_is_taken_in_the_first_frame() {
    // Glow σ over core σ, glow over core radiance, core radiance (clip units), streak length
    // (px). Read noise σ 0.006 of the clip, gamma 2.2: with σ 0.01 and gamma 1 or 2.4 the same
    // points' first fits did not resolve their paths.
    let (noise, gamma) = (0.006, 2.2);
    for (glow_width, glow_ratio, peak, streak_px) in [
        (3.0, 0.03, 30.0, 14.0),
        (3.0, 0.1, 10.0, 20.0),
        (4.0, 0.03, 30.0, 20.0),
    ] {
        let mut config = in_bloom(preset("slow-line"), glow_width, glow_ratio, noise, gamma);
        config.frame_count = 8;
        let exposure_s = f64::from(config.exposure_us) * 1e-6;
        config.trajectory = Trajectory::Line {
            start_px: Point::new(200.0, 240.0),
            velocity_px_s: Point::new(0.8 * streak_px / exposure_s, 0.6 * streak_px / exposure_s),
        };
        config.led.peak = peak;
        let label =
            format!("{streak_px} px streak, glow {glow_width}σ at {glow_ratio}, peak {peak}");
        let (_, runs) = run(config);
        let (first, truth) = &runs[0];
        let (blob, _) = first
            .detection
            .best
            .unwrap_or_else(|| panic!("{label}: not found in the first frame"));
        assert!(
            blob.elongation < SMEARED_ELONGATION,
            "{label}: its outline is elongated ({:.2}): not the case under test",
            blob.elongation
        );
        let mid_px = first.position.expect("a position where found").mid_px;
        let (tx, ty) = (truth.path_mid_x_px.unwrap(), truth.path_mid_y_px.unwrap());
        let error_px = (f64::from(mid_px.0) - tx).hypot(f64::from(mid_px.1) - ty);
        eprintln!(
            "{label}: outline elongation {:.2}, first middle {error_px:.2} px off",
            blob.elongation
        );
        assert!(
            error_px <= POS_P95_MAX_PX,
            "{label}: the first middle is {error_px:.2} px off"
        );
        // Its first position is the middle (no direction to tell the head by); from the
        // next frame on, the head.
        check(&label, &runs[1..], Point::default());
    }
}

/// A blob probed before the tracker chooses (`Detector::probe`: a first frame's round outline
/// whose streak must say whether it is smeared) and then not taken leaves nothing behind: a
/// detector that probed the LED's blob in the first frame, without analysing it, reads every
/// streak after exactly as one that did not. Left behind, the probe's fitted spot would start
/// the next frame's fit warm (here the first fits' ends, of an LED at rest, 25 px uncertain).
#[test]
fn a_probed_blob_leaves_no_trace_in_the_streaks_read_after() {
    let mut config = in_bloom(preset("speed-ramp"), 4.0, 0.05, 0.008, 2.2);
    config.frame_count = 30;
    let scene = Scene::new(config).expect("valid scene");
    let size = FrameSize::new(scene.width_px(), scene.height_px()).unwrap();
    let detector = || {
        let mut d = Detector::new(size, DetectorConfig::default()).unwrap();
        d.set_exposure_us(Some(scene.exposure_us()));
        d
    };
    let (mut probing, mut plain) = (detector(), detector());
    let mut buffer = vec![0u8; scene.frame_len_bytes()];
    let mut fitted = 0;
    for i in 0..scene.frame_count() {
        scene.render(i, &mut buffer).unwrap();
        let frame = Frame::new_checked(&buffer, size, size.row_bytes()).unwrap();
        let t_us = i as u64 * 33_333;
        let read = |d: &mut Detector, probe: bool| {
            let levels = d.segment_at(&frame, t_us).levels;
            let largest = d.candidates().max_by_key(|(_, b)| b.area_px);
            largest.and_then(|(index, _)| match (i, probe) {
                (0, true) => d.probe(&frame, index, levels).map(|_| None),
                (0, false) => Some(None),
                _ => Some(d.analyze(&frame, index, levels)),
            })
        };
        let (probed, unprobed) = (read(&mut probing, true), read(&mut plain, false));
        assert!(probed.is_some(), "frame {i}: the LED is in view");
        fitted += usize::from(unprobed.flatten().is_some_and(|(_, s)| s.fitted()));
        assert_eq!(probed, unprobed, "frame {i}");
    }
    assert!(
        fitted >= 10,
        "the streak model was fitted in {fitted} frames"
    );
}

/// An LED that passes along a clipped window's edge, touching it, again and again from the
/// first frame on, before the static map has learned the window (3.2 s) and after: its blob
/// and the window's are one, too large to be an LED and standing still. Swept over the
/// window's level, the LED's speed, spot profile and gap to the window, and noise. Once the
/// window has stood still for a quarter of a second (see `glint::detect::threshold::steady`)
/// every frame is found, every report is within the acquisition tests' tolerance (so the
/// window is never reported), and the position holds the accuracy tests' p95.
#[test]
fn an_led_passing_along_a_window_it_touches_is_tracked_before_the_window_is_learned() {
    // Window radiance over the floor, the LED's speed (px/s), its spot (a disk or a Gaussian
    // of the preset's radius, or the `window` preset's dot that does not clip, at this
    // radiance over the floor: 0.5 peaks near 230, 0.6 near 250), the gap between the spot's
    // rim and the window's edge (px; 0 touches, negative overlaps) and noise σ, each row one
    // point of the sweep.
    enum Light {
        Disk,
        Gaussian,
        Dot(f64),
    }
    for (window, speed, light, gap, noise) in [
        (1.5, 900.0, Light::Disk, 0.0, 0.004),
        (3.0, 900.0, Light::Gaussian, 0.0, 0.01),
        (1.5, 450.0, Light::Disk, -1.0, 0.008),
        (1.2, 450.0, Light::Gaussian, 1.0, 0.006),
        (3.0, 1800.0, Light::Disk, 0.5, 0.01),
        (1.5, 450.0, Light::Dot(0.5), 0.0, 0.004),
        (1.2, 900.0, Light::Dot(0.6), 0.5, 0.006),
    ] {
        let mut config = preset("fast-line");
        let fps = config.fps;
        config.frame_count = 150;
        config.exposure_us = 10_000;
        config.camera.noise_sigma = noise;
        let window_scene = preset("window");
        config.static_lights = window_scene.static_lights;
        let mut bottom_px = 0.0;
        for light in &mut config.static_lights {
            if let StaticLight::Rect {
                top_px,
                height_px,
                peak,
                ..
            } = light
            {
                *peak = window;
                bottom_px = *top_px + *height_px;
            }
        }
        let spot = match light {
            Light::Disk => "disk".to_owned(),
            Light::Gaussian => {
                config.led.spot = Spot::Gaussian {
                    sigma_px: 0.5 * config.led.radius_px,
                };
                "Gaussian".to_owned()
            }
            Light::Dot(peak) => {
                config.led = window_scene.led;
                config.led.peak = peak;
                config.floor = window_scene.floor;
                format!("unclipped {peak}")
            }
        };
        // Back and forth under the window's bottom edge (x 450–570), 300 px a leg (a whole
        // number of frames at each speed), turning between exposures so that every streak is
        // straight. The LED spends most of its time within reach of the window, which keeps
        // the window's rim out of the static map in many periods (see
        // `glint::detect::threshold::static_map`).
        let y = bottom_px + config.led.radius_px + gap;
        let (a_x, b_x) = (320.0, 620.0);
        let gap_s = 1.0 / fps - f64::from(config.exposure_us) * 1e-6;
        let turn_s = 0.5 * gap_s;
        config.trajectory = Trajectory::PingPong {
            a_px: Point::new(a_x, y),
            b_px: Point::new(b_x, y),
            speed_px_s: speed,
            at_a_s: turn_s,
        };
        // A frame right after an instant turn can show the same streak as the frame before
        // it, read back the other way, and the next one's head is pulled by the motion before
        // the turn (2.2 px, far from the window as beside it): the two frames after a turn
        // and the one before are not this test's.
        let leg_s = (b_x - a_x) / speed;
        let by_a_turn = |i: usize| {
            let since_s = (i as f64 / fps - turn_s).rem_euclid(leg_s);
            since_s < 2.5 / fps || leg_s - since_s < 1.5 / fps
        };
        let label = format!(
            "window at {window}, LED at {speed} px/s, {spot} spot {gap} px from it, σ {noise}"
        );
        let (_, runs) = run(config);
        let from =
            (glint::detect::threshold::steady::STEADY_US as f64 * 1e-6 * fps).ceil() as usize + 1;
        let mut errors = Vec::new();
        for (i, (report, truth)) in runs.iter().enumerate().skip(from) {
            if by_a_turn(i) {
                continue;
            }
            assert_eq!(truth.visible, Visibility::Visible, "{label}: frame {i}");
            let error = error_px(report, truth, Point::default())
                .unwrap_or_else(|| panic!("{label}: frame {i} not found"));
            assert!(
                error <= REPORT_TOLERANCE_PX,
                "{label}: frame {i} reported {error:.1} px from the LED"
            );
            errors.push(error);
        }
        errors.sort_by(f64::total_cmp);
        let quantile = |q: f64| nearest_rank(&errors, q);
        eprintln!(
            "{label}: position median {:.2} p95 {:.2} worst {:.2} px",
            quantile(0.5),
            quantile(0.95),
            quantile(1.0)
        );
        // A dot that does not clip adds its light to the window's unclipped rim, which then
        // joins its blob: it reads 1–2 px towards the window, as it does once the window is
        // learned. Only the rules above hold it.
        if !matches!(light, Light::Dot(_)) {
            assert!(
                quantile(0.5) <= BESIDE_WINDOW_MEDIAN_MAX_PX,
                "{label}: median"
            );
            assert!(quantile(0.95) <= POS_P95_MAX_PX, "{label}: p95");
        }
    }
}
