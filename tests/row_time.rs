//! `glint row-time` on scenes that glint's own renderer did not make: the independent renderer
//! (`tests/independent/render_streaks.py`) draws a rolling shutter (each row's exposure `τ`
//! after the row above's) under a room light flickering at 100 or 120 Hz, with its own
//! sensor, tone curves, vignetted floor and a moving LED in its glow, into real files that
//! the real binary reads.
//!
//! Across row times (25–62.5 µs), flicker depths (15–50 %), both mains frequencies, frame
//! rates of 30 and 25, two picture sizes and the exposures the renderer draws (4–30 ms, some
//! near a whole number of flicker periods, which wash the bands out), every row time given
//! is within [`MAX_ERROR`] of the truth, and every scene whose bands the physics says are at
//! least [`MEASURABLE_DEPTH`] deep is measured. Where nothing says the row time (a steady
//! light, a global shutter, bands that stand still from frame to frame, a picture read from
//! the bottom up, frame times that do not match the light's clock) no number is given. A dump
//! cut inside a frame is measured on its whole frames, and the cut reported.

mod common;

use std::path::Path;

use common::glint;
use common::peers::render_independent;
use glint::frame::{FrameSize, PixelFormat};
use glint::source::sidecar::{FrameTiming, Sidecar, SIDECAR_VERSION};
use serde_json::Value;

/// The farthest a row time given may be from the truth, as a fraction of it.
const MAX_ERROR: f64 = 0.02;

/// Bands at least this deep (the light's flicker averaged over a row's exposure, as a
/// fraction of its mean) are always measured.
const MEASURABLE_DEPTH: f64 = 0.01;

/// Frames of each scene: an LED on an arc throughout.
const FRAMES: &str = "24";

/// One set of scenes: the renderer's seed, scene count and camera.
struct Set {
    seed: u64,
    count: usize,
    row_time_us: f64,
    flicker: f64,
    flicker_hz: f64,
    fps: f64,
    size: &'static str,
}

impl Set {
    fn render(&self, dir: &Path) -> Vec<Value> {
        let args = [
            ("--seed", self.seed.to_string()),
            ("--count", self.count.to_string()),
            ("--row-time-us", self.row_time_us.to_string()),
            ("--flicker", self.flicker.to_string()),
            ("--flicker-hz", self.flicker_hz.to_string()),
            ("--fps", self.fps.to_string()),
            ("--size", self.size.to_string()),
            ("--motion", "arc".to_string()),
            ("--frames", FRAMES.to_string()),
        ];
        let args: Vec<String> = args
            .into_iter()
            .flat_map(|(name, value)| [name.to_string(), value])
            .collect();
        render_independent(dir, &args)
    }

    /// The depth of the bands in `scene`: the flicker averaged over a row's exposure,
    /// `d |sinc(π f e)|`.
    fn depth(&self, scene: &Value) -> f64 {
        let exposure_s = scene["exposure_us"].as_f64().expect("exposure") * 1e-6;
        let x = std::f64::consts::PI * self.flicker_hz * exposure_s;
        self.flicker * (x.sin() / x).abs()
    }
}

/// `glint row-time` on `dump` (its frames `fps` a second, or as its sidecar says): the row
/// time it gives, or its message when it gives none.
fn row_time(dump: &Path, size: &str, fps: Option<f64>, extra: &[&str]) -> Result<f64, String> {
    let fps = fps.map(|f| ["--fps".to_string(), f.to_string()]);
    let out = glint()
        .arg("row-time")
        .arg("--input")
        .arg(dump)
        .args(["--size", size, "--format-in", "grey"])
        .args(fps.iter().flatten())
        .args(extra)
        .output()
        .expect("run glint row-time");
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr).trim().to_string();
    if !out.status.success() {
        assert!(stdout.is_empty(), "a refusal printed {stdout}");
        assert!(
            stderr.starts_with("glint: no row time"),
            "not a refusal: {stderr}"
        );
        return Err(stderr);
    }
    Ok(given(&stdout).unwrap_or_else(|| panic!("no row time in {stdout}")))
}

/// The row time `glint row-time` printed (its first line, `row time N µs ...`).
fn given(stdout: &str) -> Option<f64> {
    stdout
        .strip_prefix("row time ")
        .and_then(|rest| rest.split_whitespace().next())
        .and_then(|v| v.parse().ok())
}

/// The first scene of the 120 Hz set at 25 fps, on its own.
fn one_120_hz_scene() -> Set {
    Set {
        seed: 23,
        count: 1,
        row_time_us: 40.0,
        flicker: 0.5,
        flicker_hz: 120.0,
        fps: 25.0,
        size: "640x480",
    }
}

fn dump(dir: &Path, scene: &Value) -> std::path::PathBuf {
    dir.join(format!("scene_{}.grey", scene["scene"]))
}

#[test]
fn the_row_time_is_measured_from_a_flickering_light_s_bands() {
    let sets = [
        Set {
            seed: 21,
            count: 4,
            row_time_us: 25.0,
            flicker: 0.3,
            flicker_hz: 100.0,
            fps: 30.0,
            size: "640x480",
        },
        Set {
            seed: 22,
            count: 4,
            row_time_us: 62.5,
            flicker: 0.15,
            flicker_hz: 100.0,
            fps: 30.0,
            size: "640x480",
        },
        // At 25 fps a 100 Hz light's bands stand still and a 120 Hz light's move.
        Set {
            seed: 23,
            count: 4,
            row_time_us: 40.0,
            flicker: 0.5,
            flicker_hz: 120.0,
            fps: 25.0,
            size: "640x480",
        },
        Set {
            seed: 24,
            count: 2,
            row_time_us: 30.0,
            flicker: 0.3,
            flicker_hz: 100.0,
            fps: 30.0,
            size: "1280x720",
        },
    ];
    let mut failures = Vec::new();
    for set in &sets {
        let dir = tempfile::tempdir().unwrap();
        for scene in set.render(dir.path()) {
            let depth = set.depth(&scene);
            let label = format!(
                "seed {} scene {} ({} at {} fps, {} µs rows, {} Hz light {:.1} % deep over the \
                 exposure of {} µs)",
                set.seed,
                scene["scene"],
                set.size,
                set.fps,
                set.row_time_us,
                set.flicker_hz,
                100.0 * depth,
                scene["exposure_us"]
            );
            match row_time(&dump(dir.path(), &scene), set.size, Some(set.fps), &[]) {
                Ok(measured) => {
                    let error = measured / set.row_time_us - 1.0;
                    eprintln!("{label}: {measured:.2} µs ({:+.2} %)", 100.0 * error);
                    if error.abs() > MAX_ERROR {
                        failures.push(format!("{label}: {measured:.2} µs"));
                    }
                }
                Err(message) => {
                    eprintln!("{label}: {message}");
                    if depth >= MEASURABLE_DEPTH {
                        failures.push(format!("{label}: not measured: {message}"));
                    }
                }
            }
        }
    }
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

#[test]
fn nothing_is_measured_where_nothing_says_the_row_time() {
    let base = Set {
        seed: 25,
        count: 2,
        row_time_us: 40.0,
        flicker: 0.5,
        flicker_hz: 100.0,
        fps: 30.0,
        size: "640x480",
    };
    let sets = [
        (
            "a steady light",
            Set {
                flicker: 0.0,
                ..base
            },
        ),
        (
            "a global shutter",
            Set {
                seed: 26,
                row_time_us: 0.0,
                ..base
            },
        ),
        (
            "120 Hz at exactly 30 fps (bands that stand still)",
            Set {
                seed: 27,
                flicker_hz: 120.0,
                ..base
            },
        ),
    ];
    for (what, set) in &sets {
        let dir = tempfile::tempdir().unwrap();
        for scene in set.render(dir.path()) {
            let result = row_time(&dump(dir.path(), &scene), set.size, Some(set.fps), &[]);
            assert!(
                result.is_err(),
                "{what}, scene {}: {result:?}",
                scene["scene"]
            );
        }
    }
}

#[test]
fn a_picture_read_bottom_up_or_at_the_wrong_frame_rate_gives_no_row_time_and_a_cut_one_its_frames()
{
    let set = one_120_hz_scene();
    let dir = tempfile::tempdir().unwrap();
    let scene = &set.render(dir.path())[0];
    let path = dump(dir.path(), scene);
    // As rendered it is measured (else the refusals below show nothing).
    let measured = row_time(&path, set.size, Some(set.fps), &[]).expect("the scene as rendered");
    assert!((measured / set.row_time_us - 1.0).abs() <= MAX_ERROR);
    // Its frames taken as 30 a second: the bands do not keep that clock.
    let wrong_rate = row_time(&path, set.size, Some(30.0), &[]);
    assert!(wrong_rate.is_err(), "at 30 fps: {wrong_rate:?}");
    // A 100 Hz light would keep its bands still at 25 fps.
    let wrong_light = row_time(&path, set.size, Some(set.fps), &["--flicker-hz", "100"]);
    assert!(wrong_light.is_err(), "as 100 Hz: {wrong_light:?}");
    let (width, height) = (640, 480);
    let bytes = std::fs::read(&path).unwrap();
    // Cut inside its last frame: the whole frames before the cut are measured, and the cut is
    // said after, with exit status 1.
    let cut_path = dir.path().join("cut.grey");
    std::fs::write(&cut_path, &bytes[..bytes.len() - width * height / 2]).unwrap();
    let cut = glint()
        .arg("row-time")
        .arg("--input")
        .arg(&cut_path)
        .args(["--size", set.size, "--format-in", "grey", "--fps", "25"])
        .output()
        .unwrap();
    let (stdout, stderr) = (
        String::from_utf8_lossy(&cut.stdout),
        String::from_utf8_lossy(&cut.stderr),
    );
    assert_eq!(cut.status.code(), Some(1), "{stderr}");
    let frames = bytes.len() / (width * height) - 1;
    assert!(
        stderr.contains(&format!(
            "after {frames} whole frames: input ends inside frame {frames}"
        )),
        "{stderr}"
    );
    let cut_measured = given(&stdout).unwrap_or_else(|| panic!("no row time in {stdout}"));
    assert!((cut_measured / set.row_time_us - 1.0).abs() <= MAX_ERROR);
    // Upside down: the rows are read from the bottom up.
    let flipped: Vec<u8> = bytes
        .chunks_exact(width * height)
        .flat_map(|frame| frame.chunks_exact(width).rev().flatten().copied())
        .collect();
    let flipped_path = dir.path().join("flipped.grey");
    std::fs::write(&flipped_path, flipped).unwrap();
    let upside_down = row_time(&flipped_path, set.size, Some(set.fps), &[]);
    assert!(
        upside_down
            .as_ref()
            .is_err_and(|m| m.contains("from the bottom up")),
        "upside down: {upside_down:?}"
    );
}

/// A recording whose stamps jitter by up to 2.5 ms either way (a USB camera's frames stamped
/// by a busy host) and which lost a frame: read with its sidecar, the row time is still
/// measured. The light turns by up to 1.9 rad over 2.5 ms at 120 Hz; the camera's own frame
/// interval, measured over the run, keeps the clock.
#[test]
fn stamps_that_jitter_and_a_dropped_frame_keep_the_light_s_clock() {
    let set = one_120_hz_scene();
    let dir = tempfile::tempdir().unwrap();
    let scene = &set.render(dir.path())[0];
    let (width, height) = (640usize, 480usize);
    let bytes = std::fs::read(dump(dir.path(), scene)).unwrap();
    let (mut kept, mut frames) = (Vec::new(), Vec::new());
    // A fixed pseudo-random delay of 0 to 5 ms: 2.5 ms late, give or take 2.5 ms.
    let mut state = 0x2545_f491_u64;
    for (n, frame) in bytes.chunks_exact(width * height).enumerate() {
        if n == 10 {
            continue;
        }
        state = state
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(1);
        let jitter_us = (state >> 33) % 5001;
        let t_us = (n as f64 * 1e6 / set.fps) as u64 + jitter_us;
        kept.extend_from_slice(frame);
        frames.push(FrameTiming {
            seq: n as u64,
            t_us,
        });
    }
    let recording = dir.path().join("recorded.grey");
    std::fs::write(&recording, kept).unwrap();
    let size = FrameSize::new(width as u32, height as u32).unwrap();
    let sidecar = Sidecar {
        version: SIDECAR_VERSION,
        format: "GREY".into(),
        width_px: size.width() as u32,
        height_px: size.height() as u32,
        stride_bytes: size.row_bytes_as(PixelFormat::Grey),
        driver_stride_bytes: size.row_bytes_as(PixelFormat::Grey),
        fps: Some(set.fps),
        device: None,
        frames,
    };
    sidecar
        .write(std::fs::File::create(Sidecar::path_for(&recording)).unwrap())
        .unwrap();
    let measured = row_time(&recording, set.size, None, &[]).expect("measured");
    assert!(
        (measured / set.row_time_us - 1.0).abs() <= MAX_ERROR,
        "{measured} µs"
    );
}

/// Hostile inputs get one line on standard error and exit status 1: nothing on standard
/// output, no panic.
#[test]
fn hostile_inputs_get_one_line_and_no_row_time() {
    let dir = tempfile::tempdir().unwrap();
    let empty = dir.path().join("empty.grey");
    std::fs::write(&empty, b"").unwrap();
    // Noise, cut inside its tenth frame.
    let mut state = 0x1234_5678_9abc_def1_u64;
    let noise: Vec<u8> = (0..9 * 640 * 480 + 1000)
        .map(|_| {
            state ^= state << 13;
            state ^= state >> 7;
            state ^= state << 17;
            (state >> 56) as u8
        })
        .collect();
    let noisy = dir.path().join("noise.grey");
    std::fs::write(&noisy, noise).unwrap();
    let missing = dir.path().join("missing.grey");
    for (input, says) in [
        (empty.as_path(), "no frames: the input is empty"),
        (
            noisy.as_path(),
            "after 9 whole frames: input ends inside frame 9",
        ),
        (missing.as_path(), "cannot open"),
        (dir.path(), "is a directory"),
    ] {
        let out = glint()
            .arg("row-time")
            .arg("--input")
            .arg(input)
            .args(["--size", "640x480", "--format-in", "grey"])
            .output()
            .unwrap();
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(1), "{}: {stderr}", input.display());
        assert!(out.stdout.is_empty(), "{}", input.display());
        assert_eq!(stderr.lines().count(), 1, "{stderr}");
        assert!(stderr.contains(says), "{}: {stderr}", input.display());
    }
}
