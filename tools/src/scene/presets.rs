//! The named scenes glint's accuracy tests render. Names and parameters are stable: tests
//! and README figures depend on them. All are 640×480 at 30 fps unless said otherwise.

use super::camera::{Camera, Range};
use super::distractor::{Companion, StaticLight};
use super::floor::Floor;
use super::occlusion::Occluder;
use super::optics::{Glare, Led, Spot};
use super::squeeze::Squeeze;
use super::trajectory::{Point, Trajectory};
use super::view::{Knock, Lens, View};
use super::SceneConfig;
use crate::markers::{reference_camera, PlacedMarker};
use glint::detect::aruco::Dictionary;

/// Preset names, in the order `glint-scene --list` prints them.
pub(crate) const NAMES: &[&str] = &[
    "slow-line",
    "fast-line",
    "speed-ramp",
    "circles",
    "figure-eight",
    "stop-go",
    "glare",
    "leave-occlude",
    "dim-noisy",
    "studio",
    "hd-720",
    "marker",
    "marker-map",
    "lens-wide",
    "lens-mild",
    "led-mast",
    "knocked",
    "rest-glare",
    "hot-pixel",
    "window",
    "three-leds",
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

/// A floor with little texture, so that an unclipped LED's top level is known to a few levels.
const UNCLIPPED_FLOOR_CONTRAST: f64 = 0.02;
/// LED radiance over the floor that brings its top to about 237 of 255: visible, not clipped.
const UNCLIPPED_LED_PEAK: f64 = 0.55;
/// A hot pixel that reads 247.
const HOT_PIXEL_RADIANCE: f64 = 247.0 / 255.0;

/// An LED the camera does not clip: no glow, radiance `peak` above the floor.
fn unclipped_led(peak: f64) -> Led {
    Led {
        radius_px: LED_RADIUS_PX,
        spot: Spot::Disk,
        squeeze: Squeeze::NONE,
        peak,
        glow_peak: 0.0,
        glow_radius_px: 0.0,
    }
}

/// Another LED on the same body, without glow.
fn companion_led(peak: f64) -> Led {
    Led {
        radius_px: LED_RADIUS_PX,
        spot: Spot::Disk,
        squeeze: Squeeze::NONE,
        peak,
        glow_peak: 0.0,
        glow_radius_px: 0.0,
    }
}

fn led(radius_px: f64) -> Led {
    Led {
        radius_px,
        spot: Spot::Disk,
        squeeze: Squeeze::NONE,
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
        row_time_us: 0.0,
        frame_count,
        seed: DEFAULT_SEED,
        trajectory,
        led: led(LED_RADIUS_PX),
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
        view: None,
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

/// Side of the map's markers, cm.
const MAP_MARKER_CM: f64 = 18.0;
/// Top-left corners (cm) of the six markers of the marker map: three near the top of the
/// reference camera's picture and three near the bottom, spread to its corners, so that a
/// calibration sees how the lens bends the whole picture.
const MAP_ORIGINS_CM: [(f64, f64); 6] = [
    (93.0, 54.0),
    (1.0, 59.0),
    (-91.0, 54.0),
    (65.0, -62.0),
    (1.0, -65.0),
    (-64.0, -62.0),
];
/// Ids of the map's markers (DICT_6X6_250).
const MAP_IDS: [u16; 6] = [1, 2, 3, 4, 5, 6];

fn marker_at(id: u16, size_cm: f64, (x, y): (f64, f64)) -> PlacedMarker {
    PlacedMarker {
        dictionary: Dictionary::Aruco6x6_250,
        id,
        size_cm,
        origin_cm: glint::geometry::Point::new(x, y),
        rotation_deg: 0.0,
    }
}

/// The six-marker map.
fn marker_map() -> Vec<PlacedMarker> {
    MAP_IDS
        .iter()
        .zip(MAP_ORIGINS_CM)
        .map(|(&id, origin)| marker_at(id, MAP_MARKER_CM, origin))
        .collect()
}

/// The reference camera (1.3 m up, looking obliquely down) with `lens` and `markers`.
fn view(lens: Lens, markers: Vec<PlacedMarker>) -> View {
    let camera = reference_camera();
    View {
        camera,
        lens,
        led_height_cm: 0.0,
        knock: None,
        bump: None,
        markers,
    }
}

/// A short exposure, as a tracker sets its camera for a bright LED: the tours' streaks are
/// under a pixel or two.
const TOUR_EXPOSURE_US: u32 = 2_000;

/// An LED touring the whole picture of the reference camera for five seconds.
fn tour(name: &str, summary: &str, view: View) -> SceneConfig {
    let mut config = base(
        name,
        summary,
        TOUR_EXPOSURE_US,
        150,
        Trajectory::Lissajous {
            centre_px: Point::new(320.0, 240.0),
            amplitude_px: Point::new(300.0, 225.0),
            freq_hz: Point::new(0.23, 0.31),
            phase_rad: Point::new(0.4, 0.0),
        },
    );
    config.view = Some(view);
    config
}

/// The wide-angle webcam lens of the accuracy targets: strong barrel distortion.
pub(crate) fn wide_lens() -> Lens {
    Lens::ideal(&reference_camera()).with_distortion(-0.30, 0.09, 0.0, 0.0, 0.0)
}

/// A milder lens, its distortion slightly decentred (tangential terms, and the principal
/// point a few pixels off the picture's centre).
pub(crate) fn mild_lens() -> Lens {
    let ideal = Lens::ideal(&reference_camera());
    Lens {
        cx: ideal.cx + 6.0,
        cy: ideal.cy - 4.0,
        ..ideal.with_distortion(-0.12, 0.0, 0.0, 0.001, -0.001)
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
        "speed-ramp" => {
            // One raised-cosine move of 640 px in 0.8 s (mean 800 px/s, peak 1600 px/s): at
            // 25 ms the streaks grow from nothing to 40 px and shrink again, on one straight
            // line, so that every streak between 10 and 40 px long is in the scene and the
            // head is the end farther along the line.
            base(
                name,
                "LED speeding up and braking on a 640 px diagonal (raised cosine, peak 1600 px/s), 25 ms exposure (streaks up to 40 px)",
                25_000,
                60,
                Trajectory::Arrive {
                    from_px: Point::new(64.0, 432.0),
                    to_px: Point::new(576.0, 48.0),
                    move_s: 0.8,
                    arrive_s: 1.0,
                    then_velocity_px_s: Point::new(0.0, 0.0),
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
                squeeze: Squeeze::NONE,
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
        "marker" => {
            let ideal = Lens::ideal(&reference_camera());
            let mut config = tour(
                name,
                "one 20 cm marker (DICT_6X6_250 id 23) at the floor origin, camera 1.3 m up, ideal lens; an LED tours the picture",
                view(ideal, vec![marker_at(23, 20.0, (0.0, 0.0))]),
            );
            config.frame_count = 60;
            config
        }
        "marker-map" => tour(
            name,
            "six 18 cm markers (DICT_6X6_250 ids 1-6) spread over the picture, ideal lens; an LED tours the picture",
            view(Lens::ideal(&reference_camera()), marker_map()),
        ),
        "lens-wide" => tour(
            name,
            "wide-angle lens (k1 -0.30, k2 0.09) over the six-marker map; an LED tours the whole picture",
            view(wide_lens(), marker_map()),
        ),
        "lens-mild" => tour(
            name,
            "milder decentred lens (k1 -0.12, p1 0.001, p2 -0.001, principal point 6,-4 px off centre) over the marker map",
            view(mild_lens(), marker_map()),
        ),
        "led-mast" => {
            let mut v = view(Lens::ideal(&reference_camera()), marker_map());
            v.led_height_cm = 12.0;
            tour(
                name,
                "the LED on a 12 cm mast, markers on the floor, camera 1.3 m up (ideal lens)",
                v,
            )
        }
        "knocked" => {
            let mut v = view(mild_lens(), marker_map());
            v.knock = Some(Knock {
                frame: 60,
                pan_deg: 0.3,
                tilt_deg: 0.8,
                roll_deg: 0.2,
            });
            let mut config = tour(
                name,
                "the mild lens over the marker map, camera knocked 0.8° down (0.3° pan, 0.2° roll) at 2 s",
                v,
            );
            config.frame_count = 180;
            config
        }
        "rest-glare" => {
            // The robot stands still for the first second, among static lights of several
            // shapes: a small round spot, an elongated bar and a square lamp, all clipped.
            let mut config = base(
                name,
                "LED at rest for 1 s, then round a rectangle, among a small glare disk, a glare bar and a square lamp",
                8_000,
                150,
                Trajectory::StopGo {
                    waypoints_px: vec![
                        Point::new(200.0, 300.0),
                        Point::new(420.0, 300.0),
                        Point::new(420.0, 180.0),
                    ],
                    move_s: 0.8,
                    hold_s: 1.0,
                    start_s: 1.0,
                },
            );
            config.static_lights = vec![
                StaticLight::Ellipse {
                    centre_px: Point::new(110.0, 90.0),
                    radii_px: Point::new(3.0, 3.0),
                    angle_rad: 0.0,
                    peak: 3.0,
                },
                StaticLight::Ellipse {
                    centre_px: Point::new(520.0, 400.0),
                    radii_px: Point::new(14.0, 2.5),
                    angle_rad: 0.5,
                    peak: 3.0,
                },
                StaticLight::Rect {
                    left_px: 540.0,
                    top_px: 60.0,
                    width_px: 9.0,
                    height_px: 9.0,
                    peak: 2.0,
                },
            ];
            config
        }
        "hot-pixel" => {
            // An LED that the camera does not clip (top near 237) creeping round a small
            // circle, and one hot pixel that reads 247 all the time.
            let mut config = base(
                name,
                "unclipped LED (top about 237) creeping on a 6 px circle at 5 px/s, and a hot pixel at 247",
                8_000,
                150,
                Trajectory::Circle {
                    centre_px: Point::new(300.0, 220.0),
                    radius_px: 6.0,
                    rev_per_s: 0.13,
                    phase_rad: 0.0,
                },
            );
            config.floor.contrast = UNCLIPPED_FLOOR_CONTRAST;
            config.led = unclipped_led(UNCLIPPED_LED_PEAK);
            config.static_lights = vec![StaticLight::Pixel {
                x_px: 450,
                y_px: 120,
                radiance: HOT_PIXEL_RADIANCE,
            }];
            config
        }
        "window" => {
            // A window that clips, and beside it an LED that does not (top near 237).
            let mut config = base(
                name,
                "unclipped LED (top about 237) on a 3:2 Lissajous beside a large clipped window",
                8_000,
                150,
                Trajectory::Lissajous {
                    centre_px: Point::new(260.0, 260.0),
                    amplitude_px: Point::new(150.0, 120.0),
                    freq_hz: Point::new(0.3, 0.2),
                    phase_rad: Point::new(0.0, 0.5),
                },
            );
            config.floor.contrast = UNCLIPPED_FLOOR_CONTRAST;
            config.led = unclipped_led(UNCLIPPED_LED_PEAK);
            config.static_lights = vec![StaticLight::Rect {
                left_px: 450.0,
                top_px: 40.0,
                width_px: 120.0,
                height_px: 90.0,
                peak: 1.5,
            }];
            config
        }
        "three-leds" => {
            // Three LEDs of different brightness on one body, translating on a figure-eight.
            let mut config = base(
                name,
                "three LEDs (20×, 6× and 2× clip) on one rigid body on a 360×220 px figure-eight, 10 ms exposure",
                10_000,
                150,
                figure_eight(Point::new(300.0, 220.0), Point::new(180.0, 110.0), 0.25),
            );
            config.companions = vec![
                Companion {
                    offset_px: Point::new(70.0, 0.0),
                    led: companion_led(6.0),
                    dim_frames: Vec::new(),
                    dim_peak: 0.0,
                },
                Companion {
                    offset_px: Point::new(35.0, 60.0),
                    led: companion_led(2.0),
                    dim_frames: Vec::new(),
                    dim_peak: 0.0,
                },
            ];
            config
        }
        _ => return None,
    };
    Some(config)
}
