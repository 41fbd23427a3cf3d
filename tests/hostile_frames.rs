//! Whatever a camera sends, the per-frame path neither panics nor reports a wild number.
//!
//! The other tests feed glint frames that look like an LED scene. A real camera also sends
//! frames that do not: a window beside the LED, a hot pixel, a lamp switched on, a frame of
//! one level, a spot of any width from a fraction of a pixel to half the frame, lights at the
//! edges, frames of a few pixels, timestamps repeated, a microsecond apart or after a stall.
//! proptest draws such sequences (every detector, streak model, skeleton, pixel format and
//! tracker set-up, with or without a floor calibration, a homography or a lens and a pose), and each frame goes through the
//! pipeline and the JSON lines sink. The promise checked is the one a user relies on before
//! any accuracy:
//! - no panic;
//! - every line is JSON (a NaN or an infinity would not be);
//! - positions lie near the frame (within the widest spot's reach and two frames of the
//!   fastest light), speeds within what the frame can show over the shorter of the exposure
//!   and the frame interval, lengths within twice the frame's diagonal, and fit residuals are
//!   not negative;
//! - a frame of one level reports nothing found (by saturation).
//!
//! `GLINT_HOSTILE_CASES` sets the number of sequences (500 by default: about 8 s optimised, 16 s in the test profile).

use std::cell::RefCell;

use glint::detect::morph::Kernel;
use glint::detect::skeleton::SkeletonMethod;
use glint::detect::streak::StreakModel;
use glint::detect::threshold::Threshold;
use glint::detect::{DetectorConfig, MaskMethod};
use glint::frame::{Frame, FrameSize, PixelFormat};
use glint::geometry::{CameraModel, FloorMapping, FloorStage, FloorUnit, Lens, Point, Pose};
use glint::pipeline::{Pipeline, PipelineConfig};
use glint::sink::{JsonLinesSink, Sink};
use glint::source::FrameMeta;
use glint::track::shutter::RollingShutter;
use glint::track::{MultiTracker, TrackerConfig};
use nalgebra::Vector3;
use proptest::prelude::*;
use proptest::test_runner::TestRunner;
use serde_json::Value;

/// The frame rate the sequences are stamped at, and its frame interval.
const FPS: f64 = 30.0;
const PERIOD_US: u64 = 33_333;

/// One light in the scene.
#[derive(Debug, Clone)]
struct Light {
    /// A Gaussian spot, or a sharp disk of this radius.
    disk: bool,
    /// σ of a Gaussian spot, or the disk's radius, in pixels.
    width_px: f32,
    /// Peak brightness above the floor, in luma steps before the clip at 255 (far above it
    /// for a strongly saturating LED).
    peak_luma: f32,
    /// Where it starts, as fractions of the frame's width and height (beyond 0..1: outside).
    start: (f32, f32),
    /// Displacement per frame in pixels, and the turn of that displacement per frame.
    step_px: (f32, f32),
    turn_rad: f32,
    /// The share of the frame interval the light is exposed for: the streak's length is this
    /// share of the step.
    exposed: f32,
    /// Frames it is off in: bit `i % 16` of this mask.
    off_mask: u16,
}

/// A static bright rectangle: its corner and size as fractions of the frame's, and its luma.
#[derive(Debug, Clone, Copy)]
struct Window {
    corner: (f32, f32),
    size: (f32, f32),
    luma: u8,
}

/// A floor calibration.
#[derive(Debug, Clone, Copy)]
enum Floor {
    /// The screen positions of a 100 cm square's corners on the floor, as fractions of the
    /// frame (any four points: a horizon may cross the frame).
    Corners([(f32, f32); 4]),
    /// A camera with a lens, looking at the floor's origin from `centre_cm` (below the floor
    /// is up, as glint's poses have it), the LED `led_height_cm` above the floor.
    Camera {
        k1: f64,
        k2: f64,
        /// Focal length over the frame's width.
        focal: f64,
        centre_cm: (f64, f64, f64),
        led_height_cm: f64,
    },
}

/// What a frame holds besides the lights.
#[derive(Debug, Clone, Copy)]
enum Event {
    /// The scene as it is.
    Plain,
    /// Every pixel at one level (a camera's blank frame, a lens cap, a flash).
    Level(u8),
    /// The whole frame brighter or darker by this factor (a room light switched).
    Gain(f32),
}

/// A sequence of frames and the pipeline that sees them.
#[derive(Debug, Clone)]
struct Case {
    size: (u32, u32),
    format: PixelFormat,
    floor_luma: u8,
    noise_luma: u8,
    /// A static bright rectangle (a window).
    window: Option<Window>,
    hot_pixels: Vec<(f32, f32)>,
    lights: Vec<Light>,
    /// Each frame's event and the time since the frame before (the first frame's is not used).
    events: Vec<Event>,
    gaps_us: Vec<u64>,
    detector: DetectorConfig,
    exposure_us: Option<u32>,
    row_time_us: Option<f32>,
    robots: usize,
    /// The floor calibration, when one is loaded.
    floor: Option<Floor>,
    seed: u64,
}

fn light() -> impl Strategy<Value = Light> {
    (
        any::<bool>(),
        prop_oneof![1 => 0.2f32..1.0, 4 => 1.0f32..6.0, 1 => 6.0f32..60.0],
        prop_oneof![1 => 0.0f32..255.0, 3 => 255.0f32..5000.0],
        prop_oneof![
            4 => (0.1f32..0.9, 0.1f32..0.9),
            1 => (-0.3f32..1.3, -0.3f32..1.3)
        ],
        prop_oneof![
            1 => Just((0.0f32, 0.0f32)),
            4 => (-12.0f32..12.0, -12.0f32..12.0),
            1 => (-120.0f32..120.0, -120.0f32..120.0)
        ],
        prop_oneof![2 => Just(0.0f32), 2 => -0.5f32..0.5, 1 => -3.2f32..3.2],
        prop_oneof![Just(1.0f32), 0.0f32..1.0],
        prop_oneof![4 => Just(0u16), 1 => any::<u16>()],
    )
        .prop_map(
            |(disk, width_px, peak_luma, start, step_px, turn_rad, exposed, off_mask)| Light {
                disk,
                width_px,
                peak_luma,
                start,
                step_px,
                turn_rad,
                exposed,
                off_mask,
            },
        )
}

fn event() -> impl Strategy<Value = Event> {
    prop_oneof![
        12 => Just(Event::Plain),
        1 => any::<u8>().prop_map(Event::Level),
        1 => (0.3f32..2.5).prop_map(Event::Gain),
    ]
}

/// The time from one frame to the next, in µs: the frame rate's mostly, and what cameras
/// also send: a repeated timestamp, a microsecond, a frame or many dropped, a stall.
fn frame_gap_us() -> impl Strategy<Value = u64> {
    prop_oneof![
        12 => Just(PERIOD_US),
        1 => Just(0u64),
        1 => 1u64..100,
        1 => (2u64..5).prop_map(|n| n * PERIOD_US),
        1 => 1_000_000u64..100_000_000,
    ]
}

fn detector() -> impl Strategy<Value = DetectorConfig> {
    (
        prop_oneof![
            4 => Just(MaskMethod::Saturation),
            1 => (1u8..80, 1usize..4).prop_map(|(diff_luma, frames)| {
                MaskMethod::BackgroundDifference { diff_luma, frames }
            }),
        ],
        prop_oneof![
            3 => Just(Threshold::Auto),
            1 => any::<u8>().prop_map(Threshold::Fixed),
        ],
        prop_oneof![3 => Just(0u32), 1 => 1u32..4],
        prop_oneof![Just(Kernel::Square), Just(Kernel::Cross)],
        prop_oneof![
            Just(SkeletonMethod::Thinning),
            Just(SkeletonMethod::Morphological)
        ],
        1u32..30,
        prop_oneof![
            Just(StreakModel::Auto),
            Just(StreakModel::Fit),
            Just(StreakModel::Ramps)
        ],
    )
        .prop_map(
            |(method, threshold, erosions, erosion_kernel, skeleton, min_area_px, streak_model)| {
                DetectorConfig {
                    method,
                    threshold,
                    erosions,
                    erosion_kernel,
                    skeleton,
                    min_area_px,
                    streak_model,
                }
            },
        )
}

fn case() -> impl Strategy<Value = Case> {
    let size = prop_oneof![
        1 => (1u32..5, 1u32..5).prop_map(|(w, h)| (2 * w, h)),
        3 => (4u32..80, 3u32..120).prop_map(|(w, h)| (2 * w, h)),
        2 => Just((320u32, 240u32)),
        1 => Just((640u32, 480u32)),
    ];
    (
        (
            size,
            prop_oneof![
                Just(PixelFormat::Yuyv),
                Just(PixelFormat::Uyvy),
                Just(PixelFormat::Grey)
            ],
            prop_oneof![3 => 0u8..120, 1 => any::<u8>()],
            prop_oneof![Just(0u8), 0u8..8, 8u8..40],
            proptest::option::of(
                (
                    (0.0f32..1.0, 0.0f32..1.0),
                    (0.0f32..0.6, 0.0f32..0.6),
                    200u8..=255,
                )
                    .prop_map(|(corner, size, luma)| Window { corner, size, luma }),
            ),
            proptest::collection::vec((0.0f32..1.0, 0.0f32..1.0), 0..6),
        ),
        (
            prop_oneof![1 => proptest::collection::vec(light(), 0..4), 2 => proptest::collection::vec(light(), 1..=1)],
            proptest::collection::vec((event(), frame_gap_us()), 2..16),
            detector(),
            prop_oneof![1 => Just(None), 3 => (50u32..40_000).prop_map(Some)],
            prop_oneof![3 => Just(None), 1 => (1.0f32..80.0).prop_map(Some)],
            prop_oneof![3 => Just(1usize), 1 => 2usize..4],
            prop_oneof![
                2 => Just(None),
                2 => proptest::array::uniform4((-0.2f32..0.2, -0.2f32..0.2)).prop_map(|d| {
                    // A camera looking at a square on the floor: a quadrilateral round the
                    // frame, its corners moved at random.
                    let base = [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 1.0)];
                    let corners = [0, 1, 2, 3].map(|i| (base[i].0 + d[i].0, base[i].1 + d[i].1));
                    Some(Floor::Corners(corners))
                }),
                1 => proptest::array::uniform4((-0.5f32..1.5, -0.5f32..1.5))
                    .prop_map(|c| Some(Floor::Corners(c))),
                2 => (
                    -0.5f64..0.3,
                    -0.2f64..0.2,
                    0.5f64..2.0,
                    (-100.0f64..100.0, -300.0f64..-50.0, -300.0f64..-80.0),
                    0.0f64..30.0,
                )
                    .prop_map(|(k1, k2, focal, centre_cm, led_height_cm)| {
                        Some(Floor::Camera {
                            k1,
                            k2,
                            focal,
                            centre_cm,
                            led_height_cm,
                        })
                    }),
            ],
            any::<u64>(),
        ),
    )
        .prop_map(
            |(
                (size, format, floor_luma, noise_luma, window, hot_pixels),
                (lights, frames, detector, exposure_us, row_time_us, robots, floor, seed),
            )| Case {
                size,
                format,
                floor_luma,
                noise_luma,
                window,
                hot_pixels,
                lights,
                events: frames.iter().map(|f| f.0).collect(),
                gaps_us: frames.iter().map(|f| f.1).collect(),
                detector,
                exposure_us,
                row_time_us,
                robots,
                floor,
                seed,
            },
        )
}

/// A small deterministic generator for the sensor noise (proptest draws the scene; the noise
/// need not shrink).
struct Noise(u64);

impl Noise {
    /// Uniform in −1..1.
    fn next(&mut self) -> f32 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 40) as f32 / (1u64 << 23) as f32 - 1.0
    }
}

/// A light's centre at time `t` frames after the start.
fn light_at(l: &Light, size: (f32, f32), t: f32) -> (f32, f32) {
    let (x0, y0) = (l.start.0 * size.0, l.start.1 * size.1);
    if l.turn_rad.abs() < 1e-4 {
        return (x0 + l.step_px.0 * t, y0 + l.step_px.1 * t);
    }
    // Turning at a steady rate: the step's direction rotates by `turn_rad` per frame.
    let (c, s) = ((l.turn_rad * t).cos(), (l.turn_rad * t).sin());
    let (dx, dy) = (
        (l.step_px.0 * s - l.step_px.1 * (1.0 - c)) / l.turn_rad,
        (l.step_px.1 * s + l.step_px.0 * (1.0 - c)) / l.turn_rad,
    );
    (x0 + dx, y0 + dy)
}

/// Frame `index` of `case`, as luma.
fn render_luma(case: &Case, index: usize, noise: &mut Noise) -> Vec<u8> {
    let (w, h) = (case.size.0 as usize, case.size.1 as usize);
    let size = (w as f32, h as f32);
    let mut light = vec![f32::from(case.floor_luma); w * h];
    if let Some(Window {
        corner: (x0, y0),
        size: (rw, rh),
        luma,
    }) = case.window
    {
        let (x0, y0) = ((x0 * size.0) as usize, (y0 * size.1) as usize);
        let (x1, y1) = (
            (x0 + (rw * size.0) as usize + 1).min(w),
            (y0 + (rh * size.1) as usize + 1).min(h),
        );
        for y in y0.min(h)..y1 {
            for x in x0.min(w)..x1 {
                light[y * w + x] = f32::from(luma);
            }
        }
    }
    for l in &case.lights {
        if l.off_mask & (1 << (index % 16)) != 0 {
            continue;
        }
        // The spot swept over the exposure, sampled every tenth of a pixel of path.
        let t0 = index as f32;
        let (a, b) = (light_at(l, size, t0), light_at(l, size, t0 + l.exposed));
        let path_px = (b.0 - a.0).hypot(b.1 - a.1);
        let samples = ((path_px * 10.0) as usize).clamp(1, 4000);
        let reach = if l.disk {
            l.width_px + 1.0
        } else {
            4.0 * l.width_px + 1.0
        };
        for k in 0..samples {
            let t = t0 + l.exposed * (k as f32 + 0.5) / samples as f32;
            let (cx, cy) = light_at(l, size, t);
            let (xa, xb) = (
                (cx - reach).floor().max(0.0),
                (cx + reach).ceil().min(size.0 - 1.0),
            );
            let (ya, yb) = (
                (cy - reach).floor().max(0.0),
                (cy + reach).ceil().min(size.1 - 1.0),
            );
            if xa > xb || ya > yb {
                continue;
            }
            for y in ya as usize..=yb as usize {
                for x in xa as usize..=xb as usize {
                    let r2 = (x as f32 - cx).powi(2) + (y as f32 - cy).powi(2);
                    let v = if l.disk {
                        if r2 <= l.width_px * l.width_px {
                            1.0
                        } else {
                            0.0
                        }
                    } else {
                        (-0.5 * r2 / (l.width_px * l.width_px)).exp()
                    };
                    light[y * w + x] += l.peak_luma * v / samples as f32;
                }
            }
        }
    }
    for &(x, y) in &case.hot_pixels {
        let (x, y) = ((x * size.0) as usize, (y * size.1) as usize);
        light[y.min(h - 1) * w + x.min(w - 1)] = 255.0;
    }
    let gain = match case.events[index] {
        Event::Gain(g) => g,
        _ => 1.0,
    };
    light
        .iter()
        .map(|&v| {
            let v = v * gain + f32::from(case.noise_luma) * noise.next();
            v.round().clamp(0.0, 255.0) as u8
        })
        .map(|v| match case.events[index] {
            Event::Level(level) => level,
            _ => v,
        })
        .collect()
}

/// `luma` packed as `format`, the chroma bytes anything.
fn pack(luma: &[u8], format: PixelFormat, noise: &mut Noise) -> Vec<u8> {
    match format {
        PixelFormat::Grey => luma.to_vec(),
        PixelFormat::Yuyv => luma
            .iter()
            .flat_map(|&y| [y, (noise.next() * 127.0 + 128.0) as u8])
            .collect(),
        PixelFormat::Uyvy => luma
            .iter()
            .flat_map(|&y| [(noise.next() * 127.0 + 128.0) as u8, y])
            .collect(),
    }
}

/// The pipeline `case` asks for.
fn pipeline(case: &Case, size: FrameSize) -> Pipeline {
    let config = PipelineConfig {
        detector: case.detector,
        tracker: TrackerConfig {
            exposure_us: case.exposure_us,
        },
    };
    let mut pipeline = if case.robots > 1 {
        let tracks = MultiTracker::new(case.robots, config.tracker).unwrap();
        Pipeline::several(size, config, tracks).unwrap()
    } else {
        Pipeline::new(size, config).unwrap()
    };
    if let Some(stage) = case.floor.and_then(|f| floor_stage(f, size)) {
        pipeline = pipeline.with_floor(stage);
    }
    if let Some(row_time_us) = case.row_time_us {
        pipeline = pipeline.with_rolling_shutter(RollingShutter::new(row_time_us).unwrap());
    }
    pipeline
}

/// The floor stage of `floor` for frames of `size`; `None` where glint would refuse the
/// calibration (four points in a line or two at one place, a lens that folds the picture
/// over, a pose that cannot be formed).
fn floor_stage(floor: Floor, size: FrameSize) -> Option<FloorStage> {
    let (w, h) = (size.width() as f64, size.height() as f64);
    match floor {
        Floor::Corners(corners) => {
            let floor = [(0.0, 0.0), (100.0, 0.0), (100.0, 100.0), (0.0, 100.0)]
                .map(|(x, y)| Point::new(x, y));
            let screen = corners.map(|(x, y)| Point::new(f64::from(x) * w, f64::from(y) * h));
            let mapping = FloorMapping::fit(&floor, &screen).ok()?;
            FloorStage::new(mapping, FloorUnit::Cm).ok()
        }
        Floor::Camera {
            k1,
            k2,
            focal,
            centre_cm: (x, y, z),
            led_height_cm,
        } => {
            let lens = Lens {
                k1,
                k2,
                ..Lens::ideal(focal * w, focal * w, 0.5 * (w - 1.0), 0.5 * (h - 1.0))
            };
            lens.check(size).ok()?;
            let pose = Pose::looking_at(Vector3::new(x, y, z), Vector3::zeros()).ok()?;
            FloorStage::from_camera(CameraModel { lens, pose }, FloorUnit::Cm)
                .with_led_height(led_height_cm)
                .ok()
        }
    }
}

/// What may be said of one report's numbers, whatever the frame showed.
struct Bounds {
    /// How far outside the frame a position may lie: as far as the widest spot reaches (its
    /// light still falls in the frame), two frames' worth of the fastest light (an LED driving
    /// out of view is placed by its track's motion), and a few pixels.
    margin_px: f64,
    size: (f64, f64),
    /// The fastest speed a frame can show: the frame's diagonal and the margin, crossed within
    /// the shorter of the exposure and the frame interval.
    max_speed_px_s: f64,
    diagonal_px: f64,
}

impl Bounds {
    fn of(case: &Case) -> Bounds {
        let size = (f64::from(case.size.0), f64::from(case.size.1));
        let fastest_px = case
            .lights
            .iter()
            .map(|l| f64::from(l.step_px.0.hypot(l.step_px.1)))
            .fold(0.0, f64::max);
        let widest_px = case
            .lights
            .iter()
            .map(|l| f64::from(l.width_px))
            .fold(0.0, f64::max);
        let margin_px = 2.0 * fastest_px + 4.0 * widest_px + 8.0;
        let diagonal_px = size.0.hypot(size.1);
        let shortest_s = case
            .exposure_us
            .map_or(1.0 / FPS, |e| (f64::from(e) * 1e-6).min(1.0 / FPS));
        Bounds {
            margin_px,
            size,
            max_speed_px_s: (diagonal_px + 2.0 * margin_px) / shortest_s,
            diagonal_px,
        }
    }

    /// The numbers of one robot's entry (a line's own, or one of its `tracks`).
    fn check(&self, entry: &Value, what: &str) -> Result<(), TestCaseError> {
        let num = |k: &str| entry.get(k).and_then(Value::as_f64);
        for (k, side) in [("x", 0), ("y", 1), ("mid_x", 0), ("mid_y", 1)] {
            if let Some(v) = num(k) {
                let extent = if side == 0 { self.size.0 } else { self.size.1 };
                prop_assert!(
                    (-self.margin_px..=extent + self.margin_px).contains(&v),
                    "{what}: {k} {v} beyond {} px of the frame",
                    self.margin_px
                );
            }
        }
        if let (Some(vx), Some(vy)) = (num("vx"), num("vy")) {
            prop_assert!(
                vx.hypot(vy) <= self.max_speed_px_s,
                "{what}: speed {} px/s above {}",
                vx.hypot(vy),
                self.max_speed_px_s
            );
        }
        for k in ["len_px", "path_px"] {
            if let Some(v) = num(k) {
                prop_assert!(
                    (0.0..=2.0 * self.diagonal_px).contains(&v),
                    "{what}: {k} {v} beyond twice the diagonal"
                );
            }
        }
        if let Some(v) = num("fit_px") {
            prop_assert!(v >= 0.0, "{what}: fit_px {v} negative");
        }
        Ok(())
    }
}

/// What the sequences exercised, so that the test fails if its frames stop reaching the parts
/// it is meant to check.
#[derive(Debug, Default)]
struct Coverage {
    frames: usize,
    found: usize,
    heads: usize,
    fitted: usize,
    streak_speeds: usize,
    cut_by_edge: usize,
    several: usize,
    on_the_floor: usize,
    beyond_horizon: usize,
    /// Frames of sequences whose floor calibration has a lens (which the detector is given).
    through_a_lens: usize,
}

impl Coverage {
    fn count(&mut self, line: &Value) {
        self.frames += 1;
        let entries = match line.get("tracks").and_then(Value::as_array) {
            Some(tracks) => {
                self.several += 1;
                tracks.iter().collect()
            }
            None => vec![line],
        };
        for e in entries {
            let has = |k: &str| e.get(k).is_some();
            let is = |k: &str, v: &str| e.get(k).and_then(Value::as_str) == Some(v);
            self.found += usize::from(e.get("found") == Some(&Value::Bool(true)));
            self.heads += usize::from(is("pos_method", "head"));
            self.fitted += usize::from(has("fit_px"));
            self.streak_speeds += usize::from(is("v_method", "streak"));
            self.cut_by_edge += usize::from(has("cut_by_edge"));
            self.on_the_floor += usize::from(has("floor_x"));
            self.beyond_horizon += usize::from(has("beyond_horizon"));
        }
    }
}

fn run(case: &Case, coverage: &RefCell<Coverage>) -> Result<(), TestCaseError> {
    let size = FrameSize::new(case.size.0, case.size.1).unwrap();
    let mut pipeline = pipeline(case, size);
    if pipeline.floor().is_some_and(|f| f.camera().is_some()) {
        coverage.borrow_mut().through_a_lens += case.events.len();
    }
    let mut noise = Noise(case.seed | 1);
    let bounds = Bounds::of(case);
    let mut out = Vec::new();
    let mut sink = JsonLinesSink::new(&mut out, false);
    let mut t_us = 0u64;
    for index in 0..case.events.len() {
        if index > 0 {
            t_us += case.gaps_us[index];
        }
        let luma = render_luma(case, index, &mut noise);
        let bytes = pack(&luma, case.format, &mut noise);
        let frame =
            Frame::new_checked_as(&bytes, size, size.row_bytes_as(case.format), case.format)
                .unwrap();
        let meta = FrameMeta {
            index: index as u64,
            sequence: index as u64,
            dropped: 0,
            timestamp_us: t_us,
            monotonic_us: t_us,
        };
        let report = pipeline.process(&frame, meta);
        sink.write(&report).unwrap();
    }
    sink.finish().unwrap();
    let out = String::from_utf8(out).unwrap();
    prop_assert_eq!(out.lines().count(), case.events.len());
    let lines: Vec<&str> = out.lines().collect();
    for (index, line) in lines.iter().enumerate() {
        let what = format!(
            "frame {index}: {line}\n(the lines before: {:?})",
            &lines[..index]
        );
        let v: Value = serde_json::from_str(line)
            .map_err(|e| TestCaseError::fail(format!("{what}: not JSON ({e})")))?;
        bounds.check(&v, &what)?;
        coverage.borrow_mut().count(&v);
        if let Some(tracks) = v.get("tracks").and_then(Value::as_array) {
            for t in tracks {
                bounds.check(t, &what)?;
            }
        }
        // (Background difference finds a change, and a frame of one level is one where the
        // background had anything in it: the seed's method, meant so.)
        let saturation = case.detector.method == MaskMethod::Saturation;
        if let (Event::Level(_), true) = (case.events[index], saturation) {
            prop_assert_eq!(
                v.get("found").and_then(Value::as_bool),
                Some(false),
                "{}: a frame of one level has nothing in it",
                what
            );
        }
    }
    Ok(())
}

/// `case` run once, its coverage not counted.
fn run_one(case: &Case) {
    if let Err(e) = run(case, &RefCell::new(Coverage::default())) {
        panic!("{e}");
    }
}

/// The sequences proptest found failing, kept as they were reported (with the noise's seed;
/// their detectors are glint's default, saturation at the automatic level, but for the fields
/// named): each failed before its fix.
mod found {
    use super::*;

    /// Two still lights that blink, each on while the other is off, 190 px apart: the second
    /// was taken as the first moving 5,700 px/s between frames, and its round spot's head
    /// carried half an exposure of that ahead, 42 px past its light and out of the frame.
    #[test]
    fn a_light_that_jumps_has_its_head_in_its_light() {
        let still = |width_px, peak_luma, start, off_mask| Light {
            disk: false,
            width_px,
            peak_luma,
            start,
            step_px: (0.0, 0.0),
            turn_rad: 0.0,
            exposed: 1.0,
            off_mask,
        };
        run_one(&Case {
            size: (320, 240),
            format: PixelFormat::Yuyv,
            floor_luma: 0,
            noise_luma: 0,
            window: None,
            hot_pixels: vec![],
            lights: vec![
                still(1.697_287_3, 2_555.164, (0.1, 0.1), 23_026),
                still(2.251_156_8, 4_939.726, (0.1, 0.893_816_35), 13_497),
            ],
            events: vec![Event::Plain, Event::Plain],
            gaps_us: vec![PERIOD_US; 2],
            detector: DetectorConfig {
                min_area_px: 1,
                streak_model: StreakModel::Ramps,
                ..DetectorConfig::default()
            },
            exposure_us: Some(14_867),
            row_time_us: None,
            robots: 1,
            floor: None,
            seed: 0,
        });
    }

    /// A circling LED beside a window's sill that a room light lifts into the clip for a
    /// frame: the LED's blob merged with the sill was read as a 109 px streak, the next frame's
    /// nearest light to that was another, 100 px away, and the middles' motion across those
    /// jumps carried its short fitted streak's head 90 px past its light, out of the frame.
    #[test]
    fn a_motion_across_jumps_leaves_the_head_in_its_light() {
        run_one(&Case {
            size: (320, 240),
            format: PixelFormat::Yuyv,
            floor_luma: 0,
            noise_luma: 0,
            window: Some(Window {
                corner: (0.394_496_7, 0.535_539_2),
                size: (0.340_402_48, 0.0),
                luma: 200,
            }),
            hot_pixels: vec![],
            lights: vec![
                Light {
                    disk: true,
                    width_px: 2.872_616_5,
                    peak_luma: 2_635.89,
                    start: (0.359_427_54, 0.745_700_7),
                    step_px: (-11.700_347, -3.297_763_3),
                    turn_rad: 0.489_820_3,
                    exposed: 1.0,
                    off_mask: 0,
                },
                Light {
                    disk: false,
                    width_px: 0.340_104_7,
                    peak_luma: 3_451.124,
                    start: (0.793_832_36, 0.153_483_23),
                    step_px: (9.343_834, -0.302_527_07),
                    turn_rad: 0.0,
                    exposed: 1.0,
                    off_mask: 0,
                },
            ],
            events: [
                [Event::Plain; 5].as_slice(),
                &[Event::Gain(1.236_883_9), Event::Plain],
            ]
            .concat(),
            gaps_us: vec![PERIOD_US; 7],
            detector: DetectorConfig {
                skeleton: SkeletonMethod::Morphological,
                min_area_px: 1,
                streak_model: StreakModel::Auto,
                ..DetectorConfig::default()
            },
            exposure_us: Some(27_834),
            row_time_us: None,
            robots: 1,
            floor: None,
            seed: 0,
        });
    }

    /// A frame of one level after a light: the automatic level follows the frame's top, so
    /// all of it is saturated, but three erosions left a band 2 px wide of its 8, under the
    /// blinded fraction, and that band was reported as the LED.
    #[test]
    fn a_frame_of_one_level_is_blinded_however_eroded() {
        run_one(&Case {
            size: (8, 28),
            format: PixelFormat::Yuyv,
            floor_luma: 0,
            noise_luma: 0,
            window: None,
            hot_pixels: vec![],
            lights: vec![Light {
                disk: false,
                width_px: 5.096_647,
                peak_luma: 2_609.5,
                start: (0.1, 0.1),
                step_px: (0.0, 0.0),
                turn_rad: 0.0,
                exposed: 1.0,
                off_mask: 0,
            }],
            events: vec![Event::Plain, Event::Level(230)],
            gaps_us: vec![PERIOD_US; 2],
            detector: DetectorConfig {
                erosions: 3,
                min_area_px: 1,
                streak_model: StreakModel::Auto,
                ..DetectorConfig::default()
            },
            exposure_us: None,
            row_time_us: None,
            robots: 1,
            floor: None,
            seed: 0,
        });
    }

    /// A disk 69 px across, clipped 19 times over, turning as it moves 7.6 px a frame: the
    /// fitted path's ends were uncertain by an infinite deviation (its curvature overflowed
    /// f32), and the line said `"fit_px":inf`, which is not JSON.
    #[test]
    fn a_fit_whose_deviation_overflows_is_no_fit() {
        run_one(&Case {
            size: (320, 240),
            format: PixelFormat::Yuyv,
            floor_luma: 31,
            noise_luma: 9,
            window: None,
            hot_pixels: vec![(0.466_787_13, 0.432_724_7)],
            lights: vec![Light {
                disk: true,
                width_px: 34.371_73,
                peak_luma: 4_887.487,
                start: (0.552_570_76, 0.584_253_25),
                step_px: (-7.598_060_6, 0.916_156_2),
                turn_rad: 0.892_096_8,
                exposed: 1.0,
                off_mask: 0,
            }],
            events: vec![Event::Plain, Event::Plain],
            gaps_us: vec![PERIOD_US; 2],
            detector: DetectorConfig {
                erosions: 1,
                erosion_kernel: Kernel::Cross,
                min_area_px: 1,
                streak_model: StreakModel::Fit,
                ..DetectorConfig::default()
            },
            exposure_us: None,
            row_time_us: None,
            robots: 1,
            floor: None,
            seed: 3_453_686_255_343_432_332,
        });
    }
}

#[test]
fn any_sequence_of_frames_gives_sane_lines() {
    let config = ProptestConfig {
        cases: std::env::var("GLINT_HOSTILE_CASES")
            .ok()
            .and_then(|v| v.parse().ok())
            .unwrap_or(500),
        // The sequences are costly to run: no file of failures to replay, the minimal case
        // printed on failure is enough.
        failure_persistence: None,
        ..ProptestConfig::default()
    };
    let coverage = RefCell::new(Coverage::default());
    let result = TestRunner::new(config).run(&case(), |c| run(&c, &coverage));
    if let Err(e) = result {
        panic!("{e}");
    }
    let c = coverage.into_inner();
    eprintln!("{c:?}");
    // Each part reached in at least one frame in a hundred (over 20,000 sequences, 169,955
    // frames: found 14.7 %, a head 6.8 %, fitted 6.8 %, a streak's speed 2.5 %, cut by the
    // edge 2.4 %, several robots 25.5 %, a floor position 8.4 %, through a lens 24 %).
    for (what, n) in [
        ("found", c.found),
        ("a head", c.heads),
        ("a fitted streak", c.fitted),
        ("a streak's speed", c.streak_speeds),
        ("a light cut by the edge", c.cut_by_edge),
        ("several robots", c.several),
        ("a floor position", c.on_the_floor),
        ("a lens", c.through_a_lens),
    ] {
        assert!(100 * n >= c.frames, "{what} in {n} of {} frames", c.frames);
    }
}
