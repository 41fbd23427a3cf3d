//! Helpers shared by the integration tests: render a scene to a real dump file, run the real
//! `glint` binary on it, and compare its reports with the renderer's ground truth.

#![allow(dead_code)] // each test file uses its own subset

pub mod alloc;
pub mod arena;
pub mod in_process;
pub mod live;
pub mod peers;
pub mod view;

use std::path::PathBuf;
use std::process::{Command, Output};

use glint::frame::PixelFormat;
use glint_tools::scene::{Point, Scene, SceneConfig, Trajectory, Truth, Visibility};
use serde_json::Value;

/// Whether the tests that need `what` were asked to be skipped by setting `var` to `1`. A skip
/// is announced on the terminal itself, past the test harness's output capture (which swallows
/// `eprintln!` of passing tests), once per test program, so that a skipped test never passes
/// unseen as a plain `ok`.
pub fn skipped(var: &str, what: &str) -> bool {
    use std::io::Write as _;
    static ANNOUNCED: std::sync::Once = std::sync::Once::new();
    if std::env::var(var).is_ok_and(|v| v == "1") {
        ANNOUNCED.call_once(|| {
            let _ = writeln!(
                std::io::stderr(),
                "\n*** {var}=1: SKIPPED, {what} NOT tested ***"
            );
        });
        return true;
    }
    false
}

/// Packed YUYV frames repacked as `format`: the same luma, in UYVY's odd bytes or alone as
/// GREY (what mono cameras send).
pub fn repack(yuyv: &[u8], format: PixelFormat) -> Vec<u8> {
    match format {
        PixelFormat::Yuyv => yuyv.to_vec(),
        // `Y0 U Y1 V` → `U Y0 V Y1`.
        PixelFormat::Uyvy => yuyv.chunks_exact(2).flat_map(|p| [p[1], p[0]]).collect(),
        PixelFormat::Grey => yuyv.iter().step_by(2).copied().collect(),
    }
}

/// A rendered scene written to a temporary dump file.
pub struct Rendered {
    pub scene: Scene,
    pub truths: Vec<Truth>,
    pub dump: PathBuf,
    _dir: tempfile::TempDir,
}

/// Renders preset `name` into a dump file.
pub fn render(name: &str) -> Rendered {
    render_scene(Scene::preset(name).unwrap_or_else(|| panic!("no scene preset {name}")))
}

/// Renders a scene into a dump file.
pub fn render_scene(scene: Scene) -> Rendered {
    let (bytes, truths) = scene.render_dump();
    let dir = tempfile::tempdir().expect("temp dir");
    let dump = dir.path().join(format!("{}.yuv", scene.name()));
    std::fs::write(&dump, bytes).expect("write dump");
    Rendered {
        scene,
        truths,
        dump,
        _dir: dir,
    }
}

/// Sets `config` to `frames` frames of the LED on a straight line at `velocity_px_s`, passing
/// `centre_px` halfway through them.
pub fn line_through(
    config: &mut SceneConfig,
    centre_px: Point,
    velocity_px_s: Point,
    frames: usize,
) {
    let half_s = 0.5 * frames as f64 / config.fps;
    config.trajectory = Trajectory::Line {
        start_px: Point::new(
            centre_px.x - velocity_px_s.x * half_s,
            centre_px.y - velocity_px_s.y * half_s,
        ),
        velocity_px_s,
    };
    config.frame_count = frames;
}

/// The `glint` binary built for this test run.
pub fn glint() -> Command {
    Command::new(env!("CARGO_BIN_EXE_glint"))
}

/// `glint track` on a rendered scene, with extra arguments.
pub fn track(r: &Rendered, extra: &[&str]) -> Output {
    let size = format!("{}x{}", r.scene.width_px(), r.scene.height_px());
    let fps = r.scene.fps().to_string();
    let exposure = r.scene.exposure_us().to_string();
    let mut cmd = glint();
    cmd.args(["track", "--input"])
        .arg(&r.dump)
        .args(["--size", &size, "--fps", &fps, "--exposure-us", &exposure])
        .args(extra);
    cmd.output().expect("run glint")
}

/// Parses JSON lines, one object per line.
pub fn parse_jsonl(stdout: &[u8]) -> Vec<Value> {
    std::str::from_utf8(stdout)
        .expect("utf-8 output")
        .lines()
        .map(|line| {
            serde_json::from_str(line).unwrap_or_else(|e| panic!("bad JSON line {line:?}: {e}"))
        })
        .collect()
}

/// The q-quantile (0..=1) of `values`, by nearest rank.
pub fn quantile(values: &[f64], q: f64) -> f64 {
    assert!(!values.is_empty(), "no values");
    let mut sorted = values.to_vec();
    sorted.sort_by(f64::total_cmp);
    let rank = ((q * sorted.len() as f64).ceil() as usize).clamp(1, sorted.len());
    sorted[rank - 1]
}

/// The skew a rolling shutter of `row_time_us` gives the single frame's speed of an LED moving
/// at `vy_px_s` down the picture: the picture reads `1 / (1 − v_y τ)` times the true speed.
pub fn shutter_skew(vy_px_s: f64, row_time_us: f64) -> f64 {
    1.0 / (1.0 - vy_px_s * row_time_us * 1e-6) - 1.0
}

/// The least-squares slope of `y` against `x`, and the mean of `y`: how much of a quantity
/// `x` (a rolling shutter's skew) is left in an error `y`, and the error's bias.
pub fn slope_and_mean(x: &[f64], y: &[f64]) -> (f64, f64) {
    let n = x.len() as f64;
    let (mx, my) = (x.iter().sum::<f64>() / n, y.iter().sum::<f64>() / n);
    let sxx: f64 = x.iter().map(|a| (a - mx).powi(2)).sum();
    let sxy: f64 = x.iter().zip(y).map(|(a, b)| (a - mx) * (b - my)).sum();
    (sxy / sxx, my)
}

/// Per-scene comparison of reports with the truth.
#[derive(Debug, Default)]
pub struct Score {
    /// Visible frames in the truth.
    pub visible: usize,
    /// Visible frames reported found.
    pub detected: usize,
    /// Frames in which the LED is hidden.
    pub hidden: usize,
    /// Hidden frames reported found.
    pub false_reports: usize,
    /// Visible frames not found because several candidates could not yet be told apart.
    pub ambiguous: usize,
    /// Relative error of the single-frame speed, in frames whose velocity came from the streak.
    pub streak_speed_errors: Vec<f64>,
    /// Distances between reported and true streak middles (the LED at mid-exposure), in
    /// visible frames found.
    pub mid_errors_px: Vec<f64>,
    /// Distances between reported streak middles and the points halfway along the true
    /// paths (the streak's middle in space), in visible frames found.
    pub path_mid_errors_px: Vec<f64>,
    /// Distances between reported and true current positions.
    pub pos_errors_px: Vec<f64>,
}

/// Compares `reports` with `truths`, frame by frame.
pub fn score(reports: &[Value], truths: &[Truth]) -> Score {
    assert_eq!(reports.len(), truths.len(), "one report per frame");
    let mut s = Score::default();
    for (r, t) in reports.iter().zip(truths) {
        assert_eq!(r["frame"].as_u64(), Some(t.frame as u64), "frames in order");
        let found = r["found"].as_bool().expect("found is a bool");
        match t.visible {
            Visibility::Visible => {
                s.visible += 1;
                s.ambiguous += usize::from(r["ambiguous"] == true);
                if found {
                    s.detected += 1;
                    if r["v_method"] == "streak" {
                        let speed = r["vx"].as_f64().unwrap().hypot(r["vy"].as_f64().unwrap());
                        let truth = t.vx_px_s.unwrap().hypot(t.vy_px_s.unwrap());
                        s.streak_speed_errors.push((speed - truth).abs() / truth);
                    }
                    let d = |kx: &str, ky: &str, tx: Option<f64>, ty: Option<f64>| {
                        let (x, y) = (r[kx].as_f64().unwrap(), r[ky].as_f64().unwrap());
                        (x - tx.unwrap()).hypot(y - ty.unwrap())
                    };
                    s.mid_errors_px
                        .push(d("mid_x", "mid_y", t.mid_x_px, t.mid_y_px));
                    s.path_mid_errors_px.push(d(
                        "mid_x",
                        "mid_y",
                        t.path_mid_x_px,
                        t.path_mid_y_px,
                    ));
                    s.pos_errors_px.push(d("x", "y", t.x_px, t.y_px));
                }
            }
            Visibility::Hidden => {
                s.hidden += 1;
                s.false_reports += usize::from(found);
            }
            Visibility::Partial => {}
        }
    }
    s
}

/// Writes `bytes` to a new file in a fresh temporary directory.
pub fn temp_file(name: &str, bytes: &[u8]) -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().expect("temp dir");
    let path = dir.path().join(name);
    std::fs::write(&path, bytes).expect("write");
    (dir, path)
}
