//! One arena seen by two cameras: the scenes behind `glint fuse`'s tests.
//!
//! Two identical cameras hang side by side at the same height over one floor, both looking the
//! same way (towards floor −y, so their pictures are laid out like the map: x right, y down),
//! spaced so that their views share about a third of their width. One map of markers lies on
//! the floor; each camera sees its part of it, and both see the markers of the overlap. A robot
//! carries its LED at constant speed along a floor line `y = robot_y_cm`, from inside the
//! first camera's view, through the overlap, to inside the second's.
//!
//! Each camera is an ordinary [`Scene`] with a [`View`]: the LED's trajectory is given in that
//! camera's reference pixels. Because both cameras look along floor y without roll, a floor
//! line of constant y lies at one depth from each camera, so the camera maps it to a picture row
//! with constant pixel speed: the robot's straight constant-speed floor path is exactly a
//! [`Trajectory::Line`] in each picture, and each scene's floor truth is exactly the arena's.
//!
//! Time: the arena's true time `t` is the first camera's frame clock (its frame `i` ends its
//! exposure at `t = i / fps`). The second camera's frame `i` ends at `i / fps + phase_s` (its
//! frames fall between the first's), and its clock reads `clock_offset_us` more than the true
//! time. [`ArenaCamera::capture_time_us`] is what each camera's clock says at the end of each
//! exposure, counted from a shared epoch ([`ARENA_EPOCH_US`] before the run), as a recorded
//! dump's sidecar carries it.

use std::io;
use std::path::{Path, PathBuf};

use glint::detect::aruco::Dictionary;
use glint::frame::FrameSize;
use glint::geometry::Point as FloorPoint;
use glint::source::sidecar::{FrameTiming, Sidecar};

use super::camera::{Camera, Range};
use super::floor::Floor;
use super::optics::{Led, Spot};
use super::squeeze::Squeeze;
use super::trajectory::{Point, Trajectory};
use super::view::{Lens, View};
use super::{Scene, SceneConfig, SceneError};
use crate::markers::{Camera as MarkerCamera, PlacedMarker};

/// The shared clock's reading at the first camera's frame 0, µs: capture times are positive
/// whatever offset the second camera's clock has.
pub const ARENA_EPOCH_US: u64 = 10_000_000;
/// Focal length per pixel of picture width: about 70° across, as the reference camera.
const FOCAL_PER_WIDTH: f64 = 460.0 / 640.0;
/// How far ahead of the point below it each camera looks, per cm of its height: a view from
/// just in front of the camera out to about 1.5 heights away.
const LOOK_AHEAD_PER_HEIGHT: f64 = 70.0 / 130.0;
/// The LED as the presets draw it, scaled with the picture: 4 px at 640 px wide.
const LED_RADIUS_PER_WIDTH: f64 = 4.0 / 640.0;
const LED_PEAK: f64 = 20.0;
const LED_GLOW_PEAK: f64 = 0.1;
const LED_GLOW_RADIUS_PER_RADIUS: f64 = 3.0;
const FLOOR_MEAN: f64 = 0.38;
const FLOOR_CONTRAST: f64 = 0.18;
const FLOOR_TILE_PX: u32 = 64;
const NOISE_SIGMA: f64 = 0.01;
/// Side of the map's markers, cm.
const MARKER_CM: f64 = 18.0;
/// Marker rows, as a share of the distance the camera looks ahead: a near row and a far row,
/// so each camera's markers span its picture's height.
const MARKER_ROWS_PER_LOOK_AHEAD: [f64; 2] = [0.45, 1.75];
const MICROS_PER_S: f64 = 1e6;

/// What defines an arena. [`ArenaConfig::standard`] gives the one the tests start from.
#[derive(Clone, Debug, PartialEq)]
pub struct ArenaConfig {
    /// Name; the cameras' scenes are `NAME-a` and `NAME-b`.
    pub name: String,
    /// Each camera's picture, px (width even).
    pub width_px: u32,
    pub height_px: u32,
    /// Frames per second of both cameras.
    pub fps: f64,
    /// Exposure time.
    pub exposure_us: u32,
    /// Frames each camera records.
    pub frame_count: usize,
    /// Seed of the floor texture and the noise (each camera adds its own index).
    pub seed: u64,
    /// Height of both cameras over the floor, cm.
    pub camera_height_cm: f64,
    /// Share of a view's width (on the robot's line) that the other view also covers.
    pub overlap: f64,
    /// The robot's floor line, as a share of the distance the cameras look ahead (1: the line
    /// through the pictures' centres).
    pub robot_line: f64,
    /// The robot's speed along +x, cm/s.
    pub speed_cm_s: f64,
    /// Height of the LED over the floor, cm (the truth is the floor point under it).
    pub led_height_cm: f64,
    /// The second camera's frames end this long after the first's (0 to one frame period).
    pub phase_s: f64,
    /// What the second camera's clock reads more than the first's (the true time), µs.
    pub clock_offset_us: i64,
}

impl ArenaConfig {
    /// Two 640×480 cameras 1.3 m up, a third of their views shared, the robot at 60 cm/s
    /// through the middle of both pictures, clocks in step, frames in phase.
    pub fn standard() -> ArenaConfig {
        ArenaConfig {
            name: "arena".to_owned(),
            width_px: 640,
            height_px: 480,
            fps: 30.0,
            exposure_us: 2_000,
            frame_count: 120,
            seed: 1,
            camera_height_cm: 130.0,
            overlap: 1.0 / 3.0,
            robot_line: 1.0,
            speed_cm_s: 60.0,
            led_height_cm: 0.0,
            phase_s: 0.0,
            clock_offset_us: 0,
        }
    }
}

/// One camera of the arena.
#[derive(Clone, Debug)]
pub struct ArenaCamera {
    /// `NAME-a` or `NAME-b`.
    pub name: String,
    /// Its scene: render frames, get each frame's pixel truth.
    pub scene: Scene,
    /// When its frame 0 ends, in the arena's true time, s.
    pub first_frame_s: f64,
    /// What its clock reads more than the true time, µs.
    pub clock_offset_us: i64,
}

impl ArenaCamera {
    /// The true time at which frame `frame`'s exposure ends, s.
    pub fn true_time_s(&self, frame: usize) -> f64 {
        self.first_frame_s + frame as f64 / self.scene.fps()
    }

    /// The camera's own clock at the end of frame `frame`'s exposure, µs from the shared epoch
    /// (what its driver stamps and a recorded dump's sidecar holds).
    pub fn capture_time_us(&self, frame: usize) -> u64 {
        let true_us = (self.true_time_s(frame) * MICROS_PER_S).round() as i64;
        let clock_us = ARENA_EPOCH_US as i64 + true_us + self.clock_offset_us;
        u64::try_from(clock_us).unwrap_or(0)
    }

    /// Renders every frame into `DIR/NAME.yuv` with the sidecar `DIR/NAME.yuv.json` that gives
    /// each frame's capture time on the camera's clock (so `glint track` reports those times
    /// as `t`); returns the dump's path.
    pub fn write_dump(&self, dir: &Path) -> io::Result<PathBuf> {
        let dump = dir.join(format!("{}.yuv", self.name));
        let (bytes, _) = self.scene.render_dump();
        std::fs::write(&dump, bytes)?;
        let size = FrameSize::new(self.scene.width_px(), self.scene.height_px())
            .map_err(|e| io::Error::new(io::ErrorKind::InvalidInput, e.to_string()))?;
        let frames = (0..self.scene.frame_count())
            .map(|i| FrameTiming {
                seq: i as u64,
                t_us: self.capture_time_us(i),
            })
            .collect();
        let sidecar = Sidecar::new(size, size.row_bytes(), frames);
        let file = std::fs::File::create(Sidecar::path_for(&dump))?;
        sidecar
            .write(io::BufWriter::new(file))
            .map_err(|e| io::Error::other(e.to_string()))?;
        Ok(dump)
    }

    /// The markers this camera's view holds, as `glint calibrate --marker` arguments (every
    /// marker of the shared map: the ones it does not see are left out by `glint calibrate`).
    pub fn marker_args(&self) -> Vec<String> {
        self.scene
            .config()
            .view
            .as_ref()
            .map(View::marker_args)
            .unwrap_or_default()
    }
}

/// Both cameras, the shared map and the robot's floor path.
#[derive(Clone, Debug)]
pub struct Arena {
    pub config: ArenaConfig,
    /// The first camera (`-a`, on the left) and the second (`-b`, on the right).
    pub cameras: [ArenaCamera; 2],
    /// The robot's floor position at true time 0, cm.
    start_cm: FloorPoint,
    /// The second camera's x minus the first's, cm.
    pub spacing_cm: f64,
}

impl Arena {
    /// Lays the arena out and builds both cameras' scenes.
    pub fn new(config: ArenaConfig) -> Result<Arena, SceneError> {
        let c = &config;
        let invalid = |field, reason| SceneError::Invalid { field, reason };
        if !(c.camera_height_cm.is_finite() && c.camera_height_cm > 0.0) {
            return Err(invalid("camera_height_cm", "must be positive"));
        }
        if !(c.overlap.is_finite() && c.overlap > 0.0 && c.overlap < 1.0) {
            return Err(invalid("overlap", "must be between 0 and 1"));
        }
        if !(c.robot_line.is_finite() && c.robot_line > 0.2 && c.robot_line < 2.0) {
            return Err(invalid(
                "robot_line",
                "must be 0.2 to 2 look-ahead distances",
            ));
        }
        if !(c.speed_cm_s.is_finite() && c.speed_cm_s > 0.0) {
            return Err(invalid("speed_cm_s", "must be positive"));
        }
        let period_s = 1.0 / c.fps;
        if !(c.phase_s.is_finite() && c.phase_s >= 0.0 && c.phase_s < period_s) {
            return Err(invalid("phase_s", "must be 0 to one frame period"));
        }
        if !(c.led_height_cm.is_finite()
            && c.led_height_cm >= 0.0
            && c.led_height_cm < c.camera_height_cm)
        {
            return Err(invalid("led_height_cm", "must be 0 to the cameras' height"));
        }
        let h = c.camera_height_cm;
        let look_ahead_cm = LOOK_AHEAD_PER_HEIGHT * h;
        let focal_px = FOCAL_PER_WIDTH * f64::from(c.width_px);
        let robot_y_cm = -c.robot_line * look_ahead_cm;
        // The LED's depth from either camera along its optical axis, and the width of floor
        // its view covers on the robot's line (the LED's plane).
        let forward = {
            let n = look_ahead_cm.hypot(h);
            (-look_ahead_cm / n, h / n)
        };
        let depth_cm = robot_y_cm * forward.0 + (h - c.led_height_cm) * forward.1;
        let view_width_cm = f64::from(c.width_px) * depth_cm / focal_px;
        let spacing_cm = (1.0 - c.overlap) * view_width_cm;
        let xs = [0.0, spacing_cm];
        // Start a tenth of a view inside the first view's left edge, so that the LED is whole
        // from frame 0, and cross to the other side.
        let start_cm = FloorPoint::new(-0.4 * view_width_cm, robot_y_cm);
        // The floor width a view covers at each marker row's depth.
        let row_widths_cm = MARKER_ROWS_PER_LOOK_AHEAD.map(|share| {
            let depth_cm = -share * look_ahead_cm * forward.0 + h * forward.1;
            f64::from(c.width_px) * depth_cm / focal_px
        });
        let markers = marker_map(xs, look_ahead_cm, row_widths_cm);
        let make = |index: usize| -> Result<ArenaCamera, SceneError> {
            let camera = MarkerCamera {
                width_px: c.width_px as usize,
                height_px: c.height_px as usize,
                focal_px,
                position_cm: [xs[index], 0.0, h],
                look_at_cm: [xs[index], -look_ahead_cm, 0.0],
            };
            let first_frame_s = if index == 0 { 0.0 } else { c.phase_s };
            let clock_offset_us = if index == 0 { 0 } else { c.clock_offset_us };
            // The LED's reference pixels at the camera's frame times: the floor path is a
            // picture row at constant speed (see the module's documentation).
            let led_at = |t_s: f64| -> Option<Point> {
                let floor = led_floor_cm(start_cm, c.speed_cm_s, t_s);
                let seen = seen_through_led_plane(&camera, floor, c.led_height_cm);
                camera.project(seen).map(|p| Point::new(p.x, p.y))
            };
            let (Some(p0), Some(p1)) = (led_at(first_frame_s), led_at(first_frame_s + 1.0)) else {
                return Err(invalid("robot_line", "the robot's line is behind a camera"));
            };
            let view = View {
                camera,
                lens: Lens::ideal(&camera),
                led_height_cm: c.led_height_cm,
                knock: None,
                bump: None,
                markers: markers.clone(),
            };
            let radius_px = LED_RADIUS_PER_WIDTH * f64::from(c.width_px);
            let config = SceneConfig {
                name: format!("{}-{}", c.name, ["a", "b"][index]),
                summary: format!(
                    "camera {} of two over one arena, the robot crossing at {} cm/s",
                    ["a", "b"][index],
                    c.speed_cm_s
                ),
                width_px: c.width_px,
                height_px: c.height_px,
                fps: c.fps,
                exposure_us: c.exposure_us,
                row_time_us: 0.0,
                frame_count: c.frame_count,
                seed: c.seed.wrapping_mul(2).wrapping_add(index as u64),
                trajectory: Trajectory::Line {
                    start_px: p0,
                    velocity_px_s: Point::new(p1.x - p0.x, p1.y - p0.y),
                },
                led: Led {
                    radius_px,
                    spot: Spot::Disk,
                    squeeze: Squeeze::NONE,
                    peak: LED_PEAK,
                    glow_peak: LED_GLOW_PEAK,
                    glow_radius_px: LED_GLOW_RADIUS_PER_RADIUS * radius_px,
                },
                glare: Vec::new(),
                static_lights: Vec::new(),
                companions: Vec::new(),
                led_hidden_frames: Vec::new(),
                occluders: Vec::new(),
                floor: Floor {
                    mean: FLOOR_MEAN,
                    contrast: FLOOR_CONTRAST,
                    tile_px: FLOOR_TILE_PX,
                },
                camera: Camera {
                    noise_sigma: NOISE_SIGMA,
                    range: Range::Full,
                    gamma: 1.0,
                    post_noise_luma: 0.0,
                },
                view: Some(view),
            };
            Ok(ArenaCamera {
                name: config.name.clone(),
                scene: Scene::new(config)?,
                first_frame_s,
                clock_offset_us,
            })
        };
        let cameras = [make(0)?, make(1)?];
        Ok(Arena {
            config,
            cameras,
            start_cm,
            spacing_cm,
        })
    }

    /// The floor point under the LED at true time `t_s`, cm: the exact truth.
    pub fn floor_truth_cm(&self, t_s: f64) -> FloorPoint {
        led_floor_cm(self.start_cm, self.config.speed_cm_s, t_s)
    }

    /// The robot's floor velocity, cm/s (constant).
    pub fn floor_velocity_cm_s(&self) -> FloorPoint {
        FloorPoint::new(self.config.speed_cm_s, 0.0)
    }

    /// The true time (s) of a capture time on the first camera's clock, µs from the epoch.
    pub fn true_time_s(capture_time_us: f64) -> f64 {
        (capture_time_us - ARENA_EPOCH_US as f64) / MICROS_PER_S
    }
}

fn led_floor_cm(start_cm: FloorPoint, speed_cm_s: f64, t_s: f64) -> FloorPoint {
    FloorPoint::new(start_cm.x + speed_cm_s * t_s, start_cm.y)
}

/// The floor point a camera sees behind an LED `height_cm` above `floor_cm`: its picture
/// position is that of the LED.
fn seen_through_led_plane(
    camera: &MarkerCamera,
    floor_cm: FloorPoint,
    height_cm: f64,
) -> FloorPoint {
    let [cx, cy, h] = camera.position_cm;
    let scale = h / (h - height_cm);
    FloorPoint::new(
        cx + (floor_cm.x - cx) * scale,
        cy + (floor_cm.y - cy) * scale,
    )
}

/// The shared map: a near and a far row of markers on both sides of each camera's centre and
/// in the middle of the overlap, so that each camera sees markers across its picture and both
/// see those of the overlap. Positions are shares of each row's view width (`row_widths_cm`).
fn marker_map(xs: [f64; 2], look_ahead_cm: f64, row_widths_cm: [f64; 2]) -> Vec<PlacedMarker> {
    let [a, b] = xs;
    let middle = 0.5 * (a + b);
    let [near, far] = row_widths_cm;
    let rows = [
        [a - 0.3 * near, a, middle, b, b + 0.3 * near],
        [
            a - 0.3 * far,
            a - 0.05 * far,
            middle - 0.12 * far,
            middle + 0.12 * far,
            b + 0.3 * far,
        ],
    ];
    let mut markers = Vec::new();
    for (share, centres) in MARKER_ROWS_PER_LOOK_AHEAD.iter().zip(rows) {
        let y_cm = -share * look_ahead_cm - 0.5 * MARKER_CM;
        for x in centres {
            markers.push(PlacedMarker {
                dictionary: Dictionary::Aruco6x6_250,
                id: 1 + markers.len() as u16,
                size_cm: MARKER_CM,
                // Whole centimetres, as one would lay a map out with a tape measure.
                origin_cm: FloorPoint::new((x - 0.5 * MARKER_CM).round(), y_cm.round()),
                rotation_deg: 0.0,
            });
        }
    }
    markers
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scene::Visibility;

    fn arena(phase_s: f64, led_height_cm: f64) -> Arena {
        Arena::new(ArenaConfig {
            phase_s,
            led_height_cm,
            clock_offset_us: -3_000,
            ..ArenaConfig::standard()
        })
        .unwrap()
    }

    /// Each camera's pixel truth, taken back to the floor through its own view, is the arena's
    /// floor path at that camera's frame times: the robot's floor line really is a picture row
    /// at constant speed in both cameras.
    #[test]
    fn both_cameras_see_the_one_floor_path() {
        for (phase_s, height_cm) in [(0.0, 0.0), (0.013, 12.0)] {
            let a = arena(phase_s, height_cm);
            for cam in &a.cameras {
                let view = cam.scene.config().view.as_ref().unwrap();
                for frame in (0..cam.scene.frame_count()).step_by(7) {
                    let truth = cam.scene.truth(frame);
                    let expected = a.floor_truth_cm(cam.true_time_s(frame));
                    let from_scene = cam.scene.floor_truth_cm(frame).unwrap();
                    assert!(
                        (from_scene - expected).norm() < 1e-9,
                        "{from_scene} {expected}"
                    );
                    if let (Some(x), Some(y)) = (truth.x_px, truth.y_px) {
                        let seen = view.floor_seen_at(Point::new(x, y), frame).unwrap();
                        assert!((seen - expected).norm() < 1e-6, "{seen} {expected}");
                    }
                }
            }
        }
    }

    /// The robot starts in the first view only, is seen by both for a while, and ends in the
    /// second only; the shared map has markers each camera sees and markers both see.
    #[test]
    fn the_robot_crosses_from_one_view_into_the_other() {
        let a = arena(0.0, 0.0);
        let visible =
            |cam: &ArenaCamera, frame| cam.scene.truth(frame).visible == Visibility::Visible;
        let frames = a.config.frame_count;
        let [ca, cb] = &a.cameras;
        assert!(visible(ca, 0) && !visible(cb, 0));
        assert!(!visible(ca, frames - 1) && visible(cb, frames - 1));
        let both = (0..frames)
            .filter(|&f| visible(ca, f) && visible(cb, f))
            .count();
        assert!(both * 6 > frames, "{both} of {frames} frames in both views");
        assert!(
            (0..frames).all(|f| visible(ca, f) || visible(cb, f)),
            "never out of both"
        );
        let in_view = |cam: &ArenaCamera| -> Vec<u16> {
            let view = cam.scene.config().view.as_ref().unwrap();
            view.markers
                .iter()
                .filter(|m| {
                    m.corners_cm().iter().all(|&c| {
                        view.camera
                            .project(c)
                            .is_some_and(|p| view.camera.in_frame(p))
                    })
                })
                .map(|m| m.id)
                .collect()
        };
        let (seen_a, seen_b) = (in_view(ca), in_view(cb));
        assert!(
            seen_a.len() >= 4 && seen_b.len() >= 4,
            "{seen_a:?} {seen_b:?}"
        );
        assert!(seen_a.iter().filter(|id| seen_b.contains(id)).count() >= 2);
    }

    #[test]
    fn capture_times_carry_the_phase_and_the_offset() {
        let a = arena(0.010, 0.0);
        let [ca, cb] = &a.cameras;
        assert_eq!(ca.capture_time_us(3), ARENA_EPOCH_US + 100_000);
        assert_eq!(
            cb.capture_time_us(3),
            ARENA_EPOCH_US + 100_000 + 10_000 - 3_000
        );
    }
}
