//! Synthetic scenes with exact ground truth, for testing glint's accuracy.
//!
//! A scene is a camera looking down on a textured floor while a bright LED moves along an
//! analytic trajectory. Each frame is rendered physically, in linear units where 1.0 is the
//! sensor's clip level: the floor's radiance, plus the LED disk (several times the clip level)
//! integrated over the pixel area AND over the exposure window `[t - exposure, t]`, so fast
//! motion makes real streaks; further LEDs on the same rigid body; static glare and static
//! lights of other shapes (bars, windows, hot pixels); opaque occluders on top; then sensor noise,
//! clipping and 8-bit quantisation to packed YUYV 4:2:2.
//!
//! The ground truth ([`Truth`]) is computed from the trajectory's formulas, not from the
//! pixels. Everything is deterministic for a seed, and any single frame can be rendered on
//! its own.
//!
//! This module does not use glint: glint's own tests render their scenes with it.

mod arena;
mod camera;
mod distractor;
mod fleet;
mod floor;
mod occlusion;
mod optics;
mod presets;
mod rng;
mod squeeze;
mod sweep;
mod trajectory;
mod truth;
mod view;

use std::fmt;

pub use arena::{Arena, ArenaCamera, ArenaConfig, ARENA_EPOCH_US};
pub use camera::{Camera, Range};
pub use distractor::{Companion, StaticLight};
pub use fleet::Fleet;
pub use floor::Floor;
pub use occlusion::Occluder;
pub use optics::{Glare, Led, Spot};
pub use squeeze::Squeeze;
pub use sweep::{SpotKind, SweepPath, SweepPoint};
pub use trajectory::{Motion, Point, Trajectory};
pub use truth::{read_truth_csv, write_truth_csv, Truth, TruthCsvError, Visibility, CSV_HEADER};
pub use view::{Bump, Knock, Lens, View};

use optics::Patch;
use rng::{mix64, SplitMix64};
use view::PoseImage;

/// At most this much LED motion between two time samples of an exposure, so a streak is a
/// continuous smear rather than a row of separate disks.
const MAX_DISK_STEP_PX: f64 = 0.1;
/// The glow is smooth and wide, so it needs far fewer time samples than the disk.
const MAX_GLOW_STEP_PX: f64 = 0.5;
/// Caps the time samples of one exposure (a 2000 px streak at the disk step), so an absurd
/// custom speed costs a bounded time instead of hanging.
const MAX_TIME_STEPS: usize = 20_000;
/// Largest accepted frame side, which bounds the scene's memory.
const MAX_SIDE_PX: u32 = 4096;
/// Most frames a scene may have (55 minutes at 30 fps), which bounds a dump's size.
const MAX_FRAMES: usize = 100_000;
/// Separates the per-frame noise streams from the floor texture's seed.
const NOISE_SALT: u64 = 0x0015_E1CE_0015_E1CE;
const MICROS_PER_S: f64 = 1e6;
/// Fixed-point steps for the time the LED is in a rolling shutter's row: each shrinks the
/// error by the rows the LED crosses in a row time (under 0.1 even at 1000 px/s and 100 µs).
const ROW_TIME_ITERATIONS: usize = 8;

/// Everything that defines a scene. Presets fill one in; tests may build their own.
#[derive(Clone, Debug, PartialEq)]
pub struct SceneConfig {
    /// Stable name (a preset's name, or anything for a custom scene).
    pub name: String,
    /// One line saying what the scene shows.
    pub summary: String,
    /// Frame width, even (YUYV packs pixel pairs).
    pub width_px: u32,
    /// Frame height.
    pub height_px: u32,
    /// Frames per second; frame `i` ends its exposure at `i / fps`.
    pub fps: f64,
    /// Exposure time, at most one frame period.
    pub exposure_us: u32,
    /// A rolling shutter's time from one row's exposure to the next row's, µs: row `y`'s
    /// exposure ends `y × row_time_us` after row 0's, which ends at the frame's time. 0 for a
    /// global shutter, which exposes every row at once. Drawn for scenes without a view or
    /// companion LEDs.
    pub row_time_us: f64,
    /// Number of frames in a dump of the scene.
    pub frame_count: usize,
    /// Seed of the floor texture and the sensor noise.
    pub seed: u64,
    /// How the LED moves.
    pub trajectory: Trajectory,
    /// The LED's size and brightness.
    pub led: Led,
    /// Static saturated spots.
    pub glare: Vec<Glare>,
    /// Static lights of other shapes (bars, windows, hot pixels).
    pub static_lights: Vec<StaticLight>,
    /// Further LEDs on the tracked LED's rigid body.
    pub companions: Vec<Companion>,
    /// Frames in which the LED is hidden by something that hides it alone (a part of the
    /// robot, a hand), while its companions stay in view: it sends no light and its truth
    /// reads hidden.
    pub led_hidden_frames: Vec<core::ops::Range<usize>>,
    /// Opaque rectangles drawn over everything, the LED included.
    pub occluders: Vec<Occluder>,
    /// The floor's texture.
    pub floor: Floor,
    /// Noise and output range.
    pub camera: Camera,
    /// A real camera (lens, pose over the floor, markers, LED height, knock), or `None` for
    /// an ideal camera whose pixels are the scene's own. With a view, the trajectory and the
    /// floor texture are in the view's reference pixels, glare and occluders in the picture's.
    pub view: Option<View>,
}

/// Why a scene cannot be built or rendered.
#[derive(Clone, Debug, PartialEq)]
pub enum SceneError {
    /// A configuration value is out of range.
    Invalid {
        /// The offending field.
        field: &'static str,
        /// What is wrong with it.
        reason: &'static str,
    },
    /// The output buffer does not hold exactly one frame.
    BufferLength {
        /// `width * height * 2`.
        expected: usize,
        /// The buffer's length.
        actual: usize,
    },
}

impl fmt::Display for SceneError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SceneError::Invalid { field, reason } => write!(f, "invalid scene {field}: {reason}"),
            SceneError::BufferLength { expected, actual } => write!(
                f,
                "frame buffer holds {actual} bytes, a YUYV frame of this scene needs {expected}"
            ),
        }
    }
}

impl std::error::Error for SceneError {}

/// A validated scene, ready to render any frame.
#[derive(Clone)]
pub struct Scene {
    config: SceneConfig,
    /// Radiance of everything that does not move (floor, glare, occluders), row-major.
    static_radiance: Vec<f32>,
    /// With a view: the static picture in each of the camera's poses.
    poses: Vec<PoseImage>,
}

/// Shows the configuration only: the precomputed radiance map is a frame's worth of floats.
impl fmt::Debug for Scene {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Scene")
            .field("config", &self.config)
            .finish_non_exhaustive()
    }
}

/// When, and how finely, one frame's exposure is sampled.
#[derive(Clone, Copy)]
struct Exposure {
    end_s: f64,
    duration_s: f64,
}

impl Exposure {
    /// Mid-point sample times: for motion at constant velocity their mean position is
    /// exactly the position at the middle of the exposure.
    fn sample_times(&self, steps: usize) -> impl Iterator<Item = f64> + '_ {
        let dt = self.duration_s / steps as f64;
        let start = self.end_s - self.duration_s;
        (0..steps).map(move |k| start + (k as f64 + 0.5) * dt)
    }

    /// The same exposure `delay_s` later (a rolling shutter's later row).
    fn delayed(&self, delay_s: f64) -> Exposure {
        Exposure {
            end_s: self.end_s + delay_s,
            duration_s: self.duration_s,
        }
    }

    fn steps_for(streak_px: f64, max_step_px: f64) -> usize {
        let steps = (streak_px / max_step_px).ceil();
        if steps.is_finite() && steps >= 1.0 {
            (steps as usize).min(MAX_TIME_STEPS)
        } else {
            1
        }
    }
}

impl Scene {
    /// Validates a configuration and precomputes the static part of the image.
    pub fn new(config: SceneConfig) -> Result<Scene, SceneError> {
        validate(&config)?;
        let (width, height) = (config.width_px as usize, config.height_px as usize);
        if let Some(view) = &config.view {
            let mut poses: Vec<PoseImage> = (0..view.image_count())
                .map(|image| view.render_static(&config.floor, config.seed, width, height, image))
                .collect();
            for pose in &mut poses {
                add_glare_and_occluders(&config, &mut pose.radiance, width);
            }
            return Ok(Scene {
                config,
                static_radiance: Vec::new(),
                poses,
            });
        }
        let mut static_radiance = config.floor.render(width, height, config.seed);
        add_glare_and_occluders(&config, &mut static_radiance, width);
        Ok(Scene {
            config,
            static_radiance,
            poses: Vec::new(),
        })
    }

    /// The floor point (cm) under the LED at the end of frame `frame`'s exposure, when the
    /// scene has a view and the LED is over the floor.
    pub fn floor_truth_cm(&self, frame: usize) -> Option<glint::geometry::Point> {
        let view = self.config.view.as_ref()?;
        let t = self.exposure(frame).end_s;
        view.floor_under(self.config.trajectory.motion(t).position_px)
    }

    /// The LED's floor velocity (cm/s) at the end of frame `frame`'s exposure, when the scene
    /// has a view (central differences in time of [`Scene::floor_truth_cm`]'s formula).
    pub fn floor_velocity_truth_cm_s(&self, frame: usize) -> Option<glint::geometry::Point> {
        const DT_S: f64 = 1e-5;
        let view = self.config.view.as_ref()?;
        let t = self.exposure(frame).end_s;
        let at = |t: f64| view.floor_under(self.config.trajectory.motion(t).position_px);
        let (a, b) = (at(t - DT_S)?, at(t + DT_S)?);
        Some(glint::geometry::Point::from((b - a) / (2.0 * DT_S)))
    }
}

/// Adds the glare spots and static lights, and paints the occluders over a static radiance map.
fn add_glare_and_occluders(config: &SceneConfig, static_radiance: &mut [f32], width: usize) {
    let height = static_radiance.len() / width.max(1);
    for glare in &config.glare {
        let mut patch = Patch::around(
            glare.centre_px,
            glare.centre_px,
            glare.radius_px + 1.0,
            width,
            height,
        );
        patch.add_disk(glare.centre_px, glare.radius_px, glare.peak);
        add_patch(static_radiance, width, &patch);
    }
    for light in &config.static_lights {
        light.add_to(static_radiance, width);
    }
    for occluder in &config.occluders {
        for (y, row) in static_radiance.chunks_exact_mut(width).enumerate() {
            for (x, value) in row.iter_mut().enumerate() {
                if occluder.covers(x, y) {
                    *value = occluder.radiance as f32;
                }
            }
        }
    }
}

impl Scene {
    /// Replaces the LED's trajectory (checked as [`Scene::new`] checks it) and keeps the
    /// static picture: a renderer driven from outside frame by frame (the robot-in-the-loop rig)
    /// moves the LED as it goes without rendering the floor again.
    pub fn set_trajectory(&mut self, trajectory: Trajectory) -> Result<(), SceneError> {
        trajectory
            .validate()
            .map_err(|reason| SceneError::Invalid {
                field: "trajectory",
                reason,
            })?;
        self.config.trajectory = trajectory;
        Ok(())
    }

    /// A preset by its stable name (see [`Scene::names`]).
    pub fn preset(name: &str) -> Option<Scene> {
        Scene::new(presets::config(name)?).ok()
    }

    /// A preset's configuration, to change (frames, seed, noise...) before [`Scene::new`].
    pub fn preset_config(name: &str) -> Option<SceneConfig> {
        presets::config(name)
    }

    /// The preset names, in a stable order.
    pub fn names() -> &'static [&'static str] {
        presets::NAMES
    }

    /// The configuration this scene was built from.
    pub fn config(&self) -> &SceneConfig {
        &self.config
    }

    /// The scene's name.
    pub fn name(&self) -> &str {
        &self.config.name
    }

    /// Frame width.
    pub fn width_px(&self) -> u32 {
        self.config.width_px
    }

    /// Frame height.
    pub fn height_px(&self) -> u32 {
        self.config.height_px
    }

    /// Frames per second.
    pub fn fps(&self) -> f64 {
        self.config.fps
    }

    /// Exposure time per frame.
    pub fn exposure_us(&self) -> u32 {
        self.config.exposure_us
    }

    /// Number of frames in [`Scene::render_dump`].
    pub fn frame_count(&self) -> usize {
        self.config.frame_count
    }

    /// The LED disk's radius.
    pub fn led_radius_px(&self) -> f64 {
        self.config.led.radius_px
    }

    /// Luma of a saturated pixel (255 in full range, 235 in studio range).
    pub fn white_luma(&self) -> u8 {
        self.config.camera.range.white_luma()
    }

    /// Bytes in one packed YUYV frame: `width * height * 2` (stride = `2 * width`).
    pub fn frame_len_bytes(&self) -> usize {
        self.config.width_px as usize * self.config.height_px as usize * 2
    }

    fn exposure(&self, frame: usize) -> Exposure {
        Exposure {
            end_s: frame as f64 / self.config.fps,
            duration_s: f64::from(self.config.exposure_us) / MICROS_PER_S,
        }
    }

    /// The ground truth of frame `frame`, without rendering it.
    pub fn truth(&self, frame: usize) -> Truth {
        let exposure = self.led_exposure(frame);
        let trajectory = &self.config.trajectory;
        let streak_px =
            trajectory.path_length_px(exposure.end_s - exposure.duration_s, exposure.end_s);
        let steps = Exposure::steps_for(streak_px, MAX_DISK_STEP_PX);
        let start_s = exposure.end_s - exposure.duration_s;
        let times = [start_s, exposure.end_s]
            .into_iter()
            .chain(exposure.sample_times(steps));
        let visible = if self.led_hidden(frame) {
            Visibility::Hidden
        } else {
            occlusion::classify(
                times.map(|t| self.picture_px(trajectory.motion(t).position_px, frame)),
                self.config.led.radius_px,
                self.config.width_px,
                self.config.height_px,
                &self.config.occluders,
            )
        };
        let end = trajectory.motion(exposure.end_s);
        let mid = trajectory
            .motion(exposure.end_s - 0.5 * exposure.duration_s)
            .position_px;
        let known = |v: f64| (visible != Visibility::Hidden).then_some(v);
        let path_mid = self.path_middle_px(frame, start_s, exposure.duration_s, steps);
        let (end, mid, streak_px) = match &self.config.view {
            None => (end, mid, streak_px),
            Some(view) => {
                let velocity_px_s = view
                    .velocity_to_output(end.position_px, end.velocity_px_s, frame)
                    .unwrap_or(Point::new(f64::NAN, f64::NAN));
                // The streak's length on the picture: the mapped path, finely sampled.
                let path: Vec<Point> = (0..=steps)
                    .map(|k| start_s + exposure.duration_s * k as f64 / steps as f64)
                    .map(|t| self.picture_px(trajectory.motion(t).position_px, frame))
                    .collect();
                let length = path
                    .windows(2)
                    .map(|w| Point::new(w[1].x - w[0].x, w[1].y - w[0].y).norm())
                    .sum();
                (
                    Motion {
                        position_px: self.picture_px(end.position_px, frame),
                        velocity_px_s,
                    },
                    self.picture_px(mid, frame),
                    length,
                )
            }
        };
        Truth {
            frame,
            t_s: self.exposure(frame).end_s,
            visible,
            x_px: known(end.position_px.x),
            y_px: known(end.position_px.y),
            mid_x_px: known(mid.x),
            mid_y_px: known(mid.y),
            vx_px_s: known(end.velocity_px_s.x),
            vy_px_s: known(end.velocity_px_s.y),
            streak_px: known(streak_px),
            path_mid_x_px: known(path_mid.x),
            path_mid_y_px: known(path_mid.y),
        }
    }

    /// The point halfway along the LED's path on the picture from `start_s` over
    /// `duration_s`, the path sampled `steps` times (steps of at most
    /// [`MAX_DISK_STEP_PX`]): the streak's middle in space.
    fn path_middle_px(&self, frame: usize, start_s: f64, duration_s: f64, steps: usize) -> Point {
        let at = |k: usize| {
            let t = start_s + duration_s * k as f64 / steps as f64;
            self.picture_px(self.config.trajectory.motion(t).position_px, frame)
        };
        let step_px = |k: usize| {
            let (a, b) = (at(k), at(k + 1));
            Point::new(b.x - a.x, b.y - a.y).norm()
        };
        let half_px = 0.5 * (0..steps).map(step_px).sum::<f64>();
        let mut walked_px = 0.0;
        for k in 0..steps {
            let step = step_px(k);
            if step > 0.0 && walked_px + step >= half_px {
                let (a, b) = (at(k), at(k + 1));
                let f = (half_px - walked_px) / step;
                return Point::new(a.x + f * (b.x - a.x), a.y + f * (b.y - a.y));
            }
            walked_px += step;
        }
        // No length at all: the LED stood still.
        at(0)
    }

    /// Whether frame `frame` is one of [`SceneConfig::led_hidden_frames`].
    fn led_hidden(&self, frame: usize) -> bool {
        self.config
            .led_hidden_frames
            .iter()
            .any(|r| r.contains(&frame))
    }

    /// Where a scene pixel is seen in the picture at `frame` (itself without a view).
    fn picture_px(&self, p: Point, frame: usize) -> Point {
        match &self.config.view {
            None => p,
            Some(view) => view
                .to_output(p, frame)
                .unwrap_or(Point::new(f64::NAN, f64::NAN)),
        }
    }

    /// The LED's light on the sensor during frame `frame`'s exposure, before occluders,
    /// noise and clipping: linear radiance over the LED's bounding box.
    fn led_radiance(&self, frame: usize) -> Patch {
        let (width, height) = (
            self.config.width_px as usize,
            self.config.height_px as usize,
        );
        self.led_radiance_in(frame, Point::default(), width, height)
    }

    /// [`Scene::led_radiance`] in scene pixels shifted by `-origin`, clipped to
    /// `width × height` (a view's picture sees beyond the scene's own frame).
    fn led_radiance_in(&self, frame: usize, origin: Point, width: usize, height: usize) -> Patch {
        let exposure = self.exposure(frame);
        let trajectory = &self.config.trajectory;
        let led = &self.config.led;
        if self.led_hidden(frame) {
            return Patch::around(Point::default(), Point::default(), 0.0, 0, 0);
        }
        let shift = |p: Point| Point::new(p.x - origin.x, p.y - origin.y);
        // The rows' exposures, from the first row's to the last one's (one exposure for a
        // global shutter): where the LED may light a row.
        let readout_s = self.row_delay_s(height.saturating_sub(1));
        let rows = Exposure {
            end_s: exposure.end_s + readout_s,
            duration_s: exposure.duration_s + readout_s,
        };
        let rows_px = trajectory.path_length_px(rows.end_s - rows.duration_s, rows.end_s);
        let positions: Vec<Point> = rows
            .sample_times(Exposure::steps_for(rows_px, MAX_DISK_STEP_PX))
            .map(|t| shift(trajectory.motion(t).position_px))
            .collect();
        let glow_reach_px = if led.glow_peak > 0.0 {
            led.glow_radius_px
        } else {
            0.0
        };
        let (min, max) = bounds(&positions);
        let mut patch = Patch::around(
            min,
            max,
            led.spot.reach_px(led.radius_px).max(glow_reach_px) + 1.0,
            width,
            height,
        );
        if patch.values.is_empty() {
            return patch;
        }
        if self.config.row_time_us == 0.0 {
            self.add_led_light(&mut patch, exposure, shift);
            return patch;
        }
        // A rolling shutter: each row sees the LED over its own exposure.
        let mut line = Patch {
            height: 1,
            values: vec![0.0; patch.width],
            ..patch
        };
        for (row, values) in patch.values.chunks_exact_mut(line.width).enumerate() {
            line.top = patch.top + row;
            line.values.fill(0.0);
            let row_exposure = exposure.delayed(self.row_delay_s(line.top));
            self.add_led_light(&mut line, row_exposure, shift);
            values.copy_from_slice(&line.values);
        }
        patch
    }

    /// Adds the LED's light over `exposure` to `patch`, its positions moved by `shift`.
    fn add_led_light(&self, patch: &mut Patch, exposure: Exposure, shift: impl Fn(Point) -> Point) {
        let trajectory = &self.config.trajectory;
        let led = &self.config.led;
        let streak_px =
            trajectory.path_length_px(exposure.end_s - exposure.duration_s, exposure.end_s);
        let disk_steps = Exposure::steps_for(streak_px, MAX_DISK_STEP_PX);
        match led.spot {
            Spot::Disk => {
                let weight = led.peak / disk_steps as f64;
                for t in exposure.sample_times(disk_steps) {
                    let centre = shift(trajectory.motion(t).position_px);
                    patch.add_squeezed_disk(centre, led.radius_px, led.squeeze, weight);
                }
            }
            spot => {
                for (sigma_px, ratio) in spot.gaussians() {
                    if ratio <= 0.0 {
                        continue;
                    }
                    // A wide Gaussian is smooth: it needs fewer time samples.
                    let steps =
                        Exposure::steps_for(streak_px, MAX_DISK_STEP_PX.max(0.25 * sigma_px));
                    let weight = ratio * led.peak / steps as f64;
                    for t in exposure.sample_times(steps) {
                        patch.add_squeezed_gaussian(
                            shift(trajectory.motion(t).position_px),
                            sigma_px,
                            led.squeeze,
                            weight,
                        );
                    }
                }
            }
        }
        if led.glow_peak > 0.0 {
            let glow_steps = Exposure::steps_for(streak_px, MAX_GLOW_STEP_PX);
            let weight = led.glow_peak / glow_steps as f64;
            for t in exposure.sample_times(glow_steps) {
                patch.add_squeezed_glow(
                    shift(trajectory.motion(t).position_px),
                    led.glow_radius_px,
                    led.squeeze,
                    weight,
                );
            }
        }
    }

    /// How much later than row 0's the exposure of row `row` ends (0 for a global shutter).
    fn row_delay_s(&self, row: usize) -> f64 {
        row as f64 * self.config.row_time_us / MICROS_PER_S
    }

    /// The exposure in which frame `frame` sees the LED: the frame's for a global shutter;
    /// with a rolling shutter, from the start of the exposure of the row the LED is in then
    /// to the end of the exposure of the row it is in then.
    fn led_exposure(&self, frame: usize) -> Exposure {
        let exposure = self.exposure(frame);
        if self.config.row_time_us == 0.0 {
            return exposure;
        }
        // `t = t_row0 + y(t) × row time`, by fixed-point iteration: it contracts by the
        // rows the LED crosses per row time, a small fraction for any robot.
        let in_its_row = |t_row0_s: f64| {
            let mut t_s = t_row0_s;
            for _ in 0..ROW_TIME_ITERATIONS {
                let y_px = self.config.trajectory.motion(t_s).position_px.y;
                t_s = t_row0_s + y_px.max(0.0) * self.config.row_time_us / MICROS_PER_S;
            }
            t_s
        };
        let end_s = in_its_row(exposure.end_s);
        Exposure {
            end_s,
            duration_s: end_s - in_its_row(exposure.end_s - exposure.duration_s),
        }
    }

    /// Renders frame `frame` as packed YUYV into `out` (exactly [`Scene::frame_len_bytes`]
    /// long) and returns its ground truth.
    pub fn render(&self, frame: usize, out: &mut [u8]) -> Result<Truth, SceneError> {
        let expected = self.frame_len_bytes();
        if out.len() != expected {
            return Err(SceneError::BufferLength {
                expected,
                actual: out.len(),
            });
        }
        self.render_into(frame, out);
        Ok(self.truth(frame))
    }

    /// The light of each companion LED during frame `frame`'s exposure.
    fn companion_radiance(&self, frame: usize) -> impl Iterator<Item = Patch> + '_ {
        let exposure = self.exposure(frame);
        let trajectory = &self.config.trajectory;
        let streak_px =
            trajectory.path_length_px(exposure.end_s - exposure.duration_s, exposure.end_s);
        let steps = Exposure::steps_for(streak_px, MAX_DISK_STEP_PX);
        let positions: Vec<Point> = exposure
            .sample_times(steps)
            .map(|t| trajectory.motion(t).position_px)
            .collect();
        let (width, height) = (
            self.config.width_px as usize,
            self.config.height_px as usize,
        );
        self.config.companions.iter().map(move |c| {
            let (min, max) = bounds(&positions);
            let shift = |p: Point| Point::new(p.x + c.offset_px.x, p.y + c.offset_px.y);
            let mut patch =
                Patch::around(shift(min), shift(max), c.led.radius_px + 1.0, width, height);
            if !patch.values.is_empty() {
                let led = c.led_in(frame);
                distractor::add_swept_disk(&mut patch, &positions, c.offset_px, &led);
            }
            patch
        })
    }

    /// The camera's noise stream for `frame` (`None` for a noiseless camera): seeded per frame,
    /// so that any frame renders alike alone or in sequence.
    fn noise_rng(&self, frame: usize) -> Option<SplitMix64> {
        self.config
            .camera
            .is_noisy()
            .then(|| SplitMix64::new(mix64(self.config.seed ^ mix64(frame as u64 ^ NOISE_SALT))))
    }

    /// Renders into a buffer of the right length (shorter buffers get whole rows only).
    fn render_into(&self, frame: usize, out: &mut [u8]) {
        let width = self.config.width_px as usize;
        if let Some(view) = &self.config.view {
            return self.render_view_into(view, frame, out);
        }
        let mut patches: Vec<Patch> = core::iter::once(self.led_radiance(frame))
            .chain(self.companion_radiance(frame))
            .collect();
        for patch in &mut patches {
            for occluder in &self.config.occluders {
                hide(patch, occluder);
            }
        }
        let mut rng = self.noise_rng(frame);
        let mut row = vec![0.0f32; width];
        for (y, (out_row, static_row)) in out
            .chunks_exact_mut(2 * width)
            .zip(self.static_radiance.chunks_exact(width))
            .enumerate()
        {
            row.copy_from_slice(static_row);
            for patch in &patches {
                if let Some(led_row) = patch_row(patch, y) {
                    if let Some(dst) = row.get_mut(patch.left..patch.left + led_row.len()) {
                        for (d, s) in dst.iter_mut().zip(led_row) {
                            *d += s;
                        }
                    }
                }
            }
            self.config.camera.expose_row(&row, &mut rng, out_row);
        }
    }

    /// Renders through a view: the LED's patch is made in reference pixels and sampled
    /// (bilinearly) where each output pixel looks; occluders hide it in the picture.
    fn render_view_into(&self, view: &View, frame: usize, out: &mut [u8]) {
        let width = self.config.width_px as usize;
        let Some(pose) = self.poses.get(view.image_at(frame)) else {
            return;
        };
        // The patch's frame: everything the picture sees, with room for the bilinear taps.
        let origin = Point::new(
            pose.reference_min.x.floor() - 2.0,
            pose.reference_min.y.floor() - 2.0,
        );
        let extent = |lo: f64, hi: f64| ((hi - lo).max(0.0).ceil() as usize).saturating_add(5);
        let patch = self.led_radiance_in(
            frame,
            origin,
            extent(pose.reference_min.x, pose.reference_max.x),
            extent(pose.reference_min.y, pose.reference_max.y),
        );
        let mut rng = self.noise_rng(frame);
        let mut row = vec![0.0f32; width];
        for (y, ((out_row, static_row), refs)) in out
            .chunks_exact_mut(2 * width)
            .zip(pose.radiance.chunks_exact(width))
            .zip(pose.reference_px.chunks_exact(width))
            .enumerate()
        {
            row.copy_from_slice(static_row);
            if !patch.values.is_empty() {
                for (x, (d, r)) in row.iter_mut().zip(refs).enumerate() {
                    if self.config.occluders.iter().any(|o| o.covers(x, y)) {
                        continue;
                    }
                    let local = Point::new(
                        f64::from(r[0]) - origin.x - patch.left as f64,
                        f64::from(r[1]) - origin.y - patch.top as f64,
                    );
                    *d += bilinear(&patch, local);
                }
            }
            self.config.camera.expose_row(&row, &mut rng, out_row);
        }
    }

    /// Renders every frame back to back (a raw YUYV dump) with their truths. The whole dump
    /// is held in memory (`frame_count × frame_len_bytes`); stream with [`Scene::render`]
    /// for long scenes.
    pub fn render_dump(&self) -> (Vec<u8>, Vec<Truth>) {
        let len = self.frame_len_bytes();
        let mut dump = vec![0u8; len.saturating_mul(self.config.frame_count)];
        let truths = dump
            .chunks_exact_mut(len.max(1))
            .enumerate()
            .map(|(frame, out)| {
                self.render_into(frame, out);
                self.truth(frame)
            })
            .collect();
        (dump, truths)
    }
}

/// Smallest box holding all points (a degenerate box at the origin when there are none).
fn bounds(points: &[Point]) -> (Point, Point) {
    let mut iter = points.iter();
    let Some(&first) = iter.next() else {
        return (Point::default(), Point::default());
    };
    iter.fold((first, first), |(lo, hi), p| {
        (
            Point::new(lo.x.min(p.x), lo.y.min(p.y)),
            Point::new(hi.x.max(p.x), hi.y.max(p.y)),
        )
    })
}

/// A patch's value at a point in its own pixel coordinates (0 outside).
fn bilinear(patch: &Patch, p: Point) -> f32 {
    if !(p.x > -1.0 && p.y > -1.0) {
        return 0.0;
    }
    let (x0, y0) = (p.x.floor(), p.y.floor());
    let (fx, fy) = ((p.x - x0) as f32, (p.y - y0) as f32);
    let at = |x: f64, y: f64| -> f32 {
        if x < 0.0 || y < 0.0 || x >= patch.width as f64 || y >= patch.height as f64 {
            return 0.0;
        }
        patch
            .values
            .get(y as usize * patch.width + x as usize)
            .copied()
            .unwrap_or(0.0)
    };
    let top = at(x0, y0) * (1.0 - fx) + at(x0 + 1.0, y0) * fx;
    let bottom = at(x0, y0 + 1.0) * (1.0 - fx) + at(x0 + 1.0, y0 + 1.0) * fx;
    top * (1.0 - fy) + bottom * fy
}

/// Row `y` (frame coordinates) of a patch, if the patch covers it.
fn patch_row(patch: &Patch, y: usize) -> Option<&[f32]> {
    let row = y.checked_sub(patch.top)?;
    if row >= patch.height {
        return None;
    }
    patch.values.get(row * patch.width..(row + 1) * patch.width)
}

/// Adds a patch into a full-frame radiance map of width `width`.
fn add_patch(map: &mut [f32], width: usize, patch: &Patch) {
    for (row_index, src) in patch.values.chunks_exact(patch.width.max(1)).enumerate() {
        let start = (patch.top + row_index) * width + patch.left;
        if let Some(dst) = map.get_mut(start..start + src.len()) {
            for (d, s) in dst.iter_mut().zip(src) {
                *d += s;
            }
        }
    }
}

/// Removes the light an occluder blocks.
fn hide(patch: &mut Patch, occluder: &Occluder) {
    let (left, top, width) = (patch.left, patch.top, patch.width.max(1));
    for (row_index, row) in patch.values.chunks_exact_mut(width).enumerate() {
        for (col, value) in row.iter_mut().enumerate() {
            if occluder.covers(left + col, top + row_index) {
                *value = 0.0;
            }
        }
    }
}

fn invalid(field: &'static str, reason: &'static str) -> SceneError {
    SceneError::Invalid { field, reason }
}

fn finite_at_least(value: f64, min: f64) -> bool {
    value.is_finite() && value >= min
}

fn validate(c: &SceneConfig) -> Result<(), SceneError> {
    if c.width_px == 0 || !c.width_px.is_multiple_of(2) || c.width_px > MAX_SIDE_PX {
        return Err(invalid(
            "width_px",
            "must be even, non-zero and at most 4096",
        ));
    }
    if c.height_px == 0 || c.height_px > MAX_SIDE_PX {
        return Err(invalid("height_px", "must be non-zero and at most 4096"));
    }
    if !(c.fps.is_finite() && c.fps > 0.0) {
        return Err(invalid("fps", "must be positive"));
    }
    if c.frame_count > MAX_FRAMES {
        return Err(invalid("frame_count", "must be at most 100000"));
    }
    let frame_period_us = MICROS_PER_S / c.fps;
    if c.exposure_us == 0 || f64::from(c.exposure_us) > frame_period_us {
        return Err(invalid(
            "exposure_us",
            "must be positive and at most one frame period",
        ));
    }
    // A sensor reads its rows out within a frame period.
    if !finite_at_least(c.row_time_us, 0.0)
        || c.row_time_us * f64::from(c.height_px) > frame_period_us
    {
        return Err(invalid(
            "row_time_us",
            "must be at least 0, its rows read within one frame period",
        ));
    }
    if c.row_time_us > 0.0 && (c.view.is_some() || !c.companions.is_empty()) {
        return Err(invalid(
            "row_time_us",
            "a rolling shutter is drawn for scenes without a view or companions",
        ));
    }
    c.trajectory
        .validate()
        .map_err(|reason| invalid("trajectory", reason))?;
    let led = &c.led;
    if !(finite_at_least(led.radius_px, 0.0) && led.radius_px > 0.0) {
        return Err(invalid("led.radius_px", "must be positive"));
    }
    if !finite_at_least(led.peak, 0.0) || !finite_at_least(led.glow_peak, 0.0) {
        return Err(invalid(
            "led",
            "peak and glow_peak must be finite and not negative",
        ));
    }
    let spot_ok = led.spot.gaussians().iter().all(|&(sigma_px, ratio)| {
        (ratio == 0.0 || (sigma_px > 0.0 && sigma_px <= optics::MAX_SPOT_SIGMA_PX))
            && finite_at_least(ratio, 0.0)
    });
    if !spot_ok {
        return Err(invalid(
            "led.spot",
            "standard deviations must be positive and at most 25 px, the glow ratio not negative",
        ));
    }
    if !led.squeeze.is_valid() {
        return Err(invalid(
            "led.squeeze",
            "the ratio must be in (0, 1] and the axis finite",
        ));
    }
    if led.glow_peak > 0.0 && !(led.glow_radius_px.is_finite() && led.glow_radius_px > 0.0) {
        return Err(invalid(
            "led.glow_radius_px",
            "must be positive when there is a glow",
        ));
    }
    let glare_ok = c.glare.iter().all(|g| {
        g.centre_px.is_finite()
            && g.radius_px.is_finite()
            && g.radius_px > 0.0
            && finite_at_least(g.peak, 0.0)
    });
    if !glare_ok {
        return Err(invalid(
            "glare",
            "centres must be finite, radii positive, peaks not negative",
        ));
    }
    if !c.static_lights.iter().all(StaticLight::is_valid) {
        return Err(invalid(
            "static_lights",
            "sizes must be positive and finite, radiances not negative",
        ));
    }
    if !c.companions.iter().all(Companion::is_valid) {
        return Err(invalid(
            "companions",
            "offsets finite, radii positive, peaks not negative, no glow",
        ));
    }
    let occluders_ok = c.occluders.iter().all(|o| {
        u64::from(o.left) + u64::from(o.width) <= u64::from(c.width_px)
            && u64::from(o.top) + u64::from(o.height) <= u64::from(c.height_px)
            && finite_at_least(o.radiance, 0.0)
    });
    if !occluders_ok {
        return Err(invalid(
            "occluders",
            "must lie inside the frame with a radiance of at least 0",
        ));
    }
    if !(c.floor.mean.is_finite() && c.floor.contrast.is_finite()) {
        return Err(invalid("floor", "mean and contrast must be finite"));
    }
    if !(c.camera.gamma.is_finite() && c.camera.gamma > 0.0) {
        return Err(invalid("camera.gamma", "must be positive"));
    }
    if let Some(view) = &c.view {
        view.validate(c.width_px, c.height_px)
            .map_err(|reason| invalid("view", reason))?;
    }
    if !finite_at_least(c.camera.noise_sigma, 0.0) {
        return Err(invalid(
            "camera.noise_sigma",
            "must be finite and not negative",
        ));
    }
    if !finite_at_least(c.camera.post_noise_luma, 0.0) {
        return Err(invalid(
            "camera.post_noise_luma",
            "must be finite and not negative",
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests;
