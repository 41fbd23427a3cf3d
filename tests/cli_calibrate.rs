//! `glint calibrate` end to end: rendered marker frames in a dump file, the real binary, and the
//! TOML it writes checked against the renderer's ground truth.

mod common;

use common::glint;
use glint::geometry::Point;
use glint_tools::markers::{reference_camera, MarkerScene, PlacedMarker};

fn marker(id: u16, x_cm: f64, y_cm: f64) -> PlacedMarker {
    PlacedMarker {
        dictionary: glint::geometry::aruco::Dictionary::Aruco6x6_250,
        id,
        size_cm: 20.0,
        origin_cm: Point::new(x_cm, y_cm),
        rotation_deg: 0.0,
    }
}

/// `frames` noisy renderings of the scene, back to back in a dump file.
fn dump(scene: &MarkerScene, frames: u64) -> (tempfile::TempDir, std::path::PathBuf) {
    let mut bytes = Vec::new();
    for seed in 0..frames {
        let mut s = scene.clone();
        s.noise_seed = 100 + seed;
        bytes.extend(s.render_yuyv());
    }
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("markers.yuv");
    std::fs::write(&path, bytes).unwrap();
    (dir, path)
}

fn calibrate(
    dump: &std::path::Path,
    out: &std::path::Path,
    markers: &[&str],
) -> std::process::Output {
    let mut cmd = glint();
    cmd.args(["calibrate", "--input"])
        .arg(dump)
        .args(["--size", "640x480", "--out"])
        .arg(out);
    for m in markers {
        cmd.args(["--marker", m]);
    }
    cmd.output().unwrap()
}

fn matrix(v: &toml::Value) -> [[f64; 3]; 3] {
    let rows = v.as_array().unwrap();
    let row = |r: usize| {
        let a = rows[r].as_array().unwrap();
        [0, 1, 2].map(|c| a[c].as_float().unwrap())
    };
    [row(0), row(1), row(2)]
}

fn apply(m: &[[f64; 3]; 3], p: Point) -> Point {
    let w = m[2][0] * p.x + m[2][1] * p.y + m[2][2];
    Point::new(
        (m[0][0] * p.x + m[0][1] * p.y + m[0][2]) / w,
        (m[1][0] * p.x + m[1][1] * p.y + m[1][2]) / w,
    )
}

#[test]
fn two_markers_over_three_frames_give_an_accurate_documented_file() {
    let scene = MarkerScene::new(
        reference_camera(),
        vec![marker(23, 0.0, 0.0), marker(101, 55.0, 45.0)],
    );
    let (dir, path) = dump(&scene, 3);
    let out = dir.path().join("calib.toml");
    let run = calibrate(&path, &out, &["23:20", "101:20@55,45"]);
    let stdout = String::from_utf8_lossy(&run.stdout);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    assert!(
        stdout.contains("marker   23 (3 frames): corner residuals"),
        "{stdout}"
    );
    assert!(stdout.contains("marker  101 (3 frames)"), "{stdout}");

    let text = std::fs::read_to_string(&out).unwrap();
    assert!(text.starts_with("# glint floor calibration"));
    let t: toml::Value = toml::from_str(&text).unwrap();
    assert_eq!(t["width_px"].as_integer(), Some(640));
    assert_eq!(t["height_px"].as_integer(), Some(480));
    assert_eq!(t["units"].as_str(), Some("cm"));
    assert_eq!(t["dictionary"].as_str(), Some("DICT_6X6_250"));
    assert_eq!(t["frames"].as_integer(), Some(3));
    assert_eq!(t["residuals"]["corners"].as_integer(), Some(8));
    assert!(t["residuals"]["rms_px"].as_float().unwrap() < 0.05);
    let markers = t["marker"].as_array().unwrap();
    assert_eq!(markers.len(), 2);
    assert_eq!(
        markers[1]["origin_cm"].as_array().unwrap()[0].as_float(),
        Some(55.0)
    );

    // The written screen-to-floor matrix, over the 1.6 m × 1.4 m area, against the truth.
    let to_floor = matrix(&t["homography"]["screen_to_floor"]);
    let to_screen = matrix(&t["homography"]["floor_to_screen"]);
    let (mut worst_cm, mut worst_px): (f64, f64) = (0.0, 0.0);
    for yi in 0..=14 {
        for xi in 0..=16 {
            let truth = Point::new(-70.0 + 10.0 * f64::from(xi), -60.0 + 10.0 * f64::from(yi));
            let screen = scene.camera.project(truth).unwrap();
            worst_cm = worst_cm.max((apply(&to_floor, screen) - truth).norm());
            worst_px = worst_px.max((apply(&to_screen, truth) - screen).norm());
        }
    }
    eprintln!("worst over the area: {worst_cm:.3} cm, {worst_px:.3} px");
    assert!(worst_cm < 0.3, "{worst_cm} cm");
    assert!(worst_px < 0.25, "{worst_px} px");
}

#[test]
fn a_named_marker_that_is_not_seen_is_refused() {
    let scene = MarkerScene::new(reference_camera(), vec![marker(23, 0.0, 0.0)]);
    let (dir, path) = dump(&scene, 1);
    let out = dir.path().join("calib.toml");
    let run = calibrate(&path, &out, &["23:20", "7:20@100,0"]);
    assert!(!run.status.success());
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert_eq!(stderr.trim_end().lines().count(), 1, "{stderr}");
    assert!(
        stderr.contains(
            "marker 7 was not seen in any of 1 frames with DICT_6X6_250 (markers seen: 23)"
        ),
        "{stderr}"
    );
    assert!(!out.exists(), "no file is written for a failed calibration");
}

#[test]
fn malformed_marker_arguments_are_usage_errors() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("empty.yuv");
    std::fs::write(&path, []).unwrap();
    let out = dir.path().join("calib.toml");
    for (arg, needle) in [
        ("23", "is not ID:SIZE_CM[@X,Y]"),
        ("23:0", "must be positive"),
        ("23:20@5", "is not ID:SIZE_CM[@X,Y]"),
        ("x:20", "is not ID:SIZE_CM[@X,Y]"),
    ] {
        let run = calibrate(&path, &out, &[arg]);
        assert_eq!(run.status.code(), Some(2), "{arg}");
        let stderr = String::from_utf8_lossy(&run.stderr);
        assert!(stderr.contains(needle), "{arg}: {stderr}");
    }
    let run = calibrate(&path, &out, &["23:20", "23:15@1,1"]);
    assert!(String::from_utf8_lossy(&run.stderr).contains("named more than once"));
    let run = calibrate(&path, &out, &["23:20"]);
    assert!(String::from_utf8_lossy(&run.stderr).contains("holds no whole frame"));
}
