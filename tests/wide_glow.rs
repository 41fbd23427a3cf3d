//! An LED whose glow clips so wide that its blob covers more than 2 % of the frame (the
//! detector's glare limit, `MAX_BLOB_FRACTION`): sweep point 118 (seed 11) was such a streak
//! and was never found. A blob that large is kept only when it moved since the last frame
//! (`src/detect/threshold/large_blob.rs`); a window as large beside it stands still and is
//! never reported.
//!
//! Rendered with the sweep's model (a Gaussian core in a Gaussian glow, its core `saturation`
//! times the clip along the streak), a 60 px streak at 640×480 and a 120 px one at 1280×720,
//! at 90 fps, 10 ms exposure, over glow widths and brightnesses chosen so that the clipped
//! pixels alone exceed 2 % of the frame (measured on the rendered frame, not assumed).
//! Asserted: the glow clips that wide; the LED is reported from the second frame on at the
//! latest (the first frame's large blob cannot be told from a window), in every visible frame
//! after, every report within [`REPORT_TOLERANCE_PX`] of the LED, and the static window of
//! more than 2 % of the frame beside it is never reported.

use glint::frame::{Frame, FrameSize};
use glint::pipeline::{Pipeline, PipelineConfig};
use glint::source::FrameMeta;
use glint::track::{PositionMethod, TrackerConfig};
use glint_tools::scene::{
    Led, Point, Scene, SceneConfig, Spot, Squeeze, StaticLight, Trajectory, Visibility,
};

/// The detector's glare limit (`glint::detect::MAX_BLOB_FRACTION`).
const GLARE_FRACTION: f64 = glint::detect::MAX_BLOB_FRACTION as f64;

/// A report farther than this from the true LED is a false report (as in
/// `tests/acquisition.rs`).
const REPORT_TOLERANCE_PX: f64 = 3.0;

const FPS: f64 = 90.0;
const EXPOSURE_US: u32 = 10_000;
const FRAMES: usize = 6;

/// One rendered case.
#[derive(Debug, Clone, Copy)]
struct Case {
    width_px: u32,
    height_px: u32,
    /// The streak's length.
    streak_px: f64,
    /// The core's σ.
    core_sigma_px: f64,
    /// Glow σ over core σ.
    glow_width: f64,
    /// Glow centre over core centre.
    glow_ratio: f64,
    /// The streak's core in multiples of the clip level.
    saturation: f64,
}

/// The scene: the streak along a line through the frame's centre, heading `angle_rad`, and
/// a clipped window (static) of more than 2 % of the frame in a corner away from it.
fn config(case: Case, angle_rad: f64) -> SceneConfig {
    let mut config = Scene::preset_config("fast-line").expect("preset");
    config.width_px = case.width_px;
    config.height_px = case.height_px;
    config.fps = FPS;
    config.exposure_us = EXPOSURE_US;
    config.frame_count = FRAMES;
    config.camera.gamma = 2.2;
    config.camera.noise_sigma = 2.0 / 255.0;
    // As the sweep: the streak's core is lit for the time the core takes to pass, so the
    // spot's peak is the streak's level times the streak's length over the core's span.
    let core_span_px = std::f64::consts::TAU.sqrt() * case.core_sigma_px;
    config.led = Led {
        radius_px: 2.0 * case.core_sigma_px,
        spot: Spot::Bloom {
            sigma_px: case.core_sigma_px,
            glow_sigma_px: case.glow_width * case.core_sigma_px,
            glow_ratio: case.glow_ratio,
        },
        squeeze: Squeeze::NONE,
        peak: case.saturation * case.streak_px / core_span_px,
        glow_peak: 0.0,
        glow_radius_px: 0.0,
    };
    let speed_px_s = case.streak_px / (f64::from(EXPOSURE_US) * 1e-6);
    let (dx, dy) = (angle_rad.cos(), angle_rad.sin());
    let half_s = 0.5 * FRAMES as f64 / FPS;
    let centre = Point::new(
        0.5 * f64::from(case.width_px),
        0.55 * f64::from(case.height_px),
    );
    config.trajectory = Trajectory::Line {
        start_px: Point::new(
            centre.x - speed_px_s * half_s * dx,
            centre.y - speed_px_s * half_s * dy,
        ),
        velocity_px_s: Point::new(speed_px_s * dx, speed_px_s * dy),
    };
    // A window of 3 % of the frame, clipped, in the top left corner.
    let (w, h) = (f64::from(case.width_px), f64::from(case.height_px));
    let side = (0.03 * w * h).sqrt();
    config.static_lights = vec![StaticLight::Rect {
        left_px: 0.03 * w,
        top_px: 0.03 * h,
        width_px: 1.33 * side,
        height_px: side / 1.33,
        peak: 1.5,
    }];
    config
}

/// Renders `case` and runs the pipeline: the most pixels clipped in one frame outside the
/// window's corner, the first reported frame, each visible frame's report error (`None`: not
/// found; the middle's where the report gives the middle, else the head's), and how many reports
/// lay farther than [`REPORT_TOLERANCE_PX`] from the LED.
fn run(case: Case, angle_rad: f64) -> (usize, Option<usize>, Vec<Option<f64>>, usize) {
    let scene = Scene::new(config(case, angle_rad)).expect("valid scene");
    let size = FrameSize::new(scene.width_px(), scene.height_px()).unwrap();
    let mut pipeline = Pipeline::new(
        size,
        PipelineConfig {
            tracker: TrackerConfig {
                exposure_us: Some(scene.exposure_us()),
            },
            ..PipelineConfig::default()
        },
    )
    .unwrap();
    let mut bytes = vec![0u8; scene.frame_len_bytes()];
    let white = scene.white_luma();
    let (w, h) = (scene.width_px() as usize, scene.height_px() as usize);
    let mut clipped_most = 0;
    let mut first = None;
    let mut errors = Vec::new();
    let mut off_led = 0;
    let period_us = 1e6 / FPS;
    for index in 0..scene.frame_count() {
        let truth = scene.render(index, &mut bytes).unwrap();
        // Clipped pixels outside the window's corner (the top left third by third).
        let clipped = (0..h)
            .flat_map(|y| (0..w).map(move |x| (x, y)))
            .filter(|&(x, y)| x >= w / 3 || y >= h / 3)
            .filter(|&(x, y)| bytes[2 * (y * w + x)] >= white)
            .count();
        clipped_most = clipped_most.max(clipped);
        let frame = Frame::new_checked(&bytes, size, size.row_bytes()).unwrap();
        let t_us = (index as f64 * period_us) as u64;
        let meta = FrameMeta {
            index: index as u64,
            sequence: index as u64,
            dropped: 0,
            timestamp_us: t_us,
            monotonic_us: t_us,
        };
        let report = pipeline.process(&frame, meta);
        // The frame a track is taken in has no previous position: it gives the streak's
        // middle, and says so; the head after.
        let error = report.position.map(|e| {
            let (x, y) = e.position_px;
            let (tx, ty) = match e.position_method {
                PositionMethod::Mid => (truth.mid_x_px.unwrap(), truth.mid_y_px.unwrap()),
                _ => (truth.x_px.unwrap(), truth.y_px.unwrap()),
            };
            (f64::from(x) - tx).hypot(f64::from(y) - ty)
        });
        if error.is_some() {
            first.get_or_insert(index);
        }
        if error.is_some_and(|e| e > REPORT_TOLERANCE_PX) {
            off_led += 1;
        }
        if truth.visible == Visibility::Visible {
            errors.push(error);
        }
    }
    (clipped_most, first, errors, off_led)
}

#[test]
fn an_led_whose_clipped_glow_exceeds_the_glare_limit_is_found_while_it_moves() {
    // Frame size, streak length, core σ, glow width and brightness, saturation, heading (the
    // path in full view in every frame, away from the window). Across a long streak the glow
    // clips out to d where saturation × glow ratio × glow width × exp(-d²/2σ_g²) = 1.
    let cases = [
        // Sweep point 118's kind at 640×480 (2 % is 6144 px): a glow 5.8× the core, clipped
        // some 30 px either side of a 60 px path.
        (640, 480, 60.0, 3.0, 5.8, 0.06, 20.0, 0.3),
        (640, 480, 60.0, 2.5, 6.0, 0.08, 24.0, 2.0),
        // 1280×720 (2 % is 18 432 px): the same LED seen twice as sharp and twice as fast
        // on the picture, a 120 px streak in a glow clipped some 55 px either side.
        (1280, 720, 120.0, 4.0, 6.0, 0.07, 30.0, 3.5),
        (1280, 720, 120.0, 3.0, 8.0, 0.05, 40.0, 5.9),
    ];
    let mut problems = Vec::new();
    for (
        width_px,
        height_px,
        streak_px,
        core_sigma_px,
        glow_width,
        glow_ratio,
        saturation,
        angle_rad,
    ) in cases
    {
        let case = Case {
            width_px,
            height_px,
            streak_px,
            core_sigma_px,
            glow_width,
            glow_ratio,
            saturation,
        };
        let (clipped, first, errors, off_led) = run(case, angle_rad);
        let frame_px = f64::from(width_px) * f64::from(height_px);
        let found: Vec<f64> = errors.iter().flatten().copied().collect();
        eprintln!(
            "{case:?}: clipped {:.1} % of the frame, first reported in frame {first:?}, found \
             {} of {} visible, errors {found:.2?}",
            100.0 * clipped as f64 / frame_px,
            found.len(),
            errors.len(),
        );
        if clipped as f64 <= GLARE_FRACTION * frame_px {
            problems.push(format!("{case:?}: the glow clips only {clipped} px"));
        }
        if off_led > 0 {
            problems.push(format!(
                "{case:?}: {off_led} reports off the LED (the window?)"
            ));
        }
        if first.is_none_or(|f| f > 1) {
            problems.push(format!("{case:?}: acquired in frame {first:?}"));
        }
        if !errors.iter().skip(1).all(Option::is_some) {
            problems.push(format!(
                "{case:?}: a visible frame not found after the first: {errors:.2?}"
            ));
        }
    }
    assert!(problems.is_empty(), "{}", problems.join("\n"));
}
