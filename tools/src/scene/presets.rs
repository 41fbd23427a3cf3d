//! The named scenes glint's accuracy tests render. Names and parameters are stable: tests
//! and README figures depend on them. All are 640×480 at 30 fps unless said otherwise.

use super::camera::{Camera, Range};
use super::floor::Floor;
use super::occlusion::Occluder;
use super::optics::{Glare, Led, Spot};
use super::trajectory::{Point, Trajectory};
use super::SceneConfig;

/// Preset names, in the order `glint-scene --list` prints them.
pub(crate) const NAMES: &[&str] = &[
    "slow-line",
    "fast-line",
    "circles",
    "figure-eight",
    "stop-go",
    "glare",
    "leave-occlude",
    "dim-noisy",
    "studio",
    "hd-720",
];

const VGA_WIDTH_PX: u32 = 640;
const VGA_HEIGHT_PX: u32 = 480;
const FPS: f64 = 30.0;
const DEFAULT_SEED: u64 = 1;
/// "An LED a few pixels wide".
const LED_RADIUS_PX: f64 = 4.0;
/// A strong LED: twenty times the clip level, so even a 60 px streak saturates its core.
const LED_PEAK: f64 = 20.0;
/// Faint lens glow; with the brightest floor and noise it stays well below clip.
const LED_GLOW_PEAK: f64 = 0.1;
const LED_GLOW_RADIUS_PER_RADIUS: f64 = 3.0;
/// A mid-grey floor with visible texture, far below clip.
const FLOOR_MEAN: f64 = 0.38;
const FLOOR_CONTRAST: f64 = 0.18;
const FLOOR_TILE_PX: u32 = 64;
/// About 2.5 luma levels of read noise.
const NOISE_SIGMA: f64 = 0.01;

fn led(radius_px: f64) -> Led {
    Led {
        radius_px,
        spot: Spot::Disk,
        peak: LED_PEAK,
        glow_peak: LED_GLOW_PEAK,
        glow_radius_px: LED_GLOW_RADIUS_PER_RADIUS * radius_px,
    }
}

/// The common defaults; each preset (and each sweep point) overrides what it is about.
pub(crate) fn base(
    name: &str,
    summary: &str,
    exposure_us: u32,
    frame_count: usize,
    trajectory: Trajectory,
) -> SceneConfig {
    SceneConfig {
        name: name.to_owned(),
        summary: summary.to_owned(),
        width_px: VGA_WIDTH_PX,
        height_px: VGA_HEIGHT_PX,
        fps: FPS,
        exposure_us,
        frame_count,
        seed: DEFAULT_SEED,
        trajectory,
        led: led(LED_RADIUS_PX),
        glare: Vec::new(),
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
        },
    }
}

/// A figure-eight: the y frequency is twice the x frequency.
fn figure_eight(centre_px: Point, amplitude_px: Point, x_freq_hz: f64) -> Trajectory {
    Trajectory::Lissajous {
        centre_px,
        amplitude_px,
        freq_hz: Point::new(x_freq_hz, 2.0 * x_freq_hz),
        phase_rad: Point::new(0.0, 0.0),
    }
}

/// The configuration of preset `name`.
pub(crate) fn config(name: &str) -> Option<SceneConfig> {
    let config = match name {
        "slow-line" => base(
            name,
            "LED on a straight line at 60 px/s, 8 ms exposure (0.48 px streaks)",
            8_000,
            150,
            Trajectory::Line {
                start_px: Point::new(150.0, 320.0),
                velocity_px_s: Point::new(57.6, -16.8),
            },
        ),
        "fast-line" => {
            // 2400 px/s × 25 ms = 60 px streaks. The diagonal leg is 640 px, exactly 8 frame
            // periods; the turns fall in the middle of the 8.3 ms gap between exposures, so
            // every streak is straight and at constant speed, and half the legs run backwards.
            let exposure_us = 25_000;
            let gap_s = 1.0 / FPS - f64::from(exposure_us) / 1e6;
            base(
                name,
                "LED back and forth on a 640 px diagonal at 2400 px/s, 25 ms exposure (60 px streaks)",
                exposure_us,
                120,
                Trajectory::PingPong {
                    a_px: Point::new(64.0, 48.0),
                    b_px: Point::new(576.0, 432.0),
                    speed_px_s: 2400.0,
                    at_a_s: 0.5 * gap_s,
                },
            )
        }
        "circles" => base(
            name,
            "LED on a 20 px circle at 6 rev/s (754 px/s), 25 ms exposure: 54° arcs, 18.8 px long, 2.2 px sagitta",
            25_000,
            120,
            Trajectory::Circle {
                centre_px: Point::new(320.0, 240.0),
                radius_px: 20.0,
                rev_per_s: 6.0,
                phase_rad: 0.0,
            },
        ),
        "figure-eight" => base(
            name,
            "LED on a 440×300 px figure-eight, speed 245–584 px/s, 10 ms exposure",
            10_000,
            120,
            figure_eight(Point::new(320.0, 240.0), Point::new(220.0, 150.0), 0.25),
        ),
        "stop-go" => base(
            name,
            "LED round a rectangle, stopping 0.6 s at each corner; moves peak at 800 px/s, 8 ms exposure",
            8_000,
            150,
            Trajectory::StopGo {
                waypoints_px: vec![
                    Point::new(160.0, 140.0),
                    Point::new(480.0, 140.0),
                    Point::new(480.0, 340.0),
                    Point::new(160.0, 340.0),
                ],
                move_s: 0.8,
                hold_s: 0.6,
                start_s: 0.3,
            },
        ),
        "glare" => {
            let mut config = base(
                name,
                "two static saturated glare spots (r 6 and 10 px) beside an LED on a 120 px circle at 188 px/s",
                8_000,
                150,
                Trajectory::Circle {
                    centre_px: Point::new(320.0, 240.0),
                    radius_px: 120.0,
                    rev_per_s: 0.25,
                    phase_rad: 0.0,
                },
            );
            config.glare = vec![
                Glare {
                    centre_px: Point::new(120.0, 100.0),
                    radius_px: 6.0,
                    peak: 6.0,
                },
                Glare {
                    centre_px: Point::new(470.0, 262.0),
                    radius_px: 10.0,
                    peak: 4.0,
                },
            ];
            config
        }
        "leave-occlude" => {
            let mut config = base(
                name,
                "LED swings out of the right edge and back, and passes under a dark box; up to 430 px/s, 6 ms exposure",
                6_000,
                150,
                Trajectory::Lissajous {
                    centre_px: Point::new(380.0, 250.0),
                    amplitude_px: Point::new(340.0, 30.0),
                    freq_hz: Point::new(0.2, 0.4),
                    phase_rad: Point::new(0.0, 0.0),
                },
            );
            config.occluders = vec![Occluder {
                left: 150,
                top: 190,
                width: 90,
                height: 120,
                radiance: 0.05,
            }];
            config
        }
        "dim-noisy" => {
            let mut config = base(
                name,
                "small dim LED (r 2 px, 1.6× clip, no glow) under strong noise (σ ≈ 13 levels), 63 px/s circle",
                8_000,
                150,
                Trajectory::Circle {
                    centre_px: Point::new(320.0, 240.0),
                    radius_px: 100.0,
                    rev_per_s: 0.1,
                    phase_rad: 0.0,
                },
            );
            config.led = Led {
                radius_px: 2.0,
                spot: Spot::Disk,
                peak: 1.6,
                glow_peak: 0.0,
                glow_radius_px: 0.0,
            };
            config.camera.noise_sigma = 0.05;
            config
        }
        "studio" => {
            let mut config = base(
                name,
                "studio-range camera (white clips at Y = 235) watching a 3:2 Lissajous at up to ~500 px/s, 10 ms exposure",
                10_000,
                150,
                Trajectory::Lissajous {
                    centre_px: Point::new(320.0, 240.0),
                    amplitude_px: Point::new(240.0, 160.0),
                    freq_hz: Point::new(0.3, 0.2),
                    phase_rad: Point::new(0.0, 0.5),
                },
            );
            config.camera.range = Range::Studio;
            config
        }
        "hd-720" => {
            let mut config = base(
                name,
                "1280×720: r 5 px LED on an 880×520 px figure-eight, up to 1070 px/s, 10 ms exposure",
                10_000,
                90,
                figure_eight(Point::new(640.0, 360.0), Point::new(440.0, 260.0), 0.25),
            );
            config.width_px = 1280;
            config.height_px = 720;
            config.led = led(5.0);
            config
        }
        _ => return None,
    };
    Some(config)
}
