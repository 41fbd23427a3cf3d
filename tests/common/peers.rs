//! What the tests against independent implementations share: the Python venv that holds them
//! (pymavlink, eclipse-zenoh, ...), and a calibration that gives reports floor positions.

use std::path::{Path, PathBuf};

use glint::detect::aruco::Dictionary;
use glint::geometry::Point;
use glint_tools::markers::{reference_camera, MarkerScene, PlacedMarker};

use super::glint;

/// The venv's python, or a failure that says how to make it.
pub fn python() -> PathBuf {
    let venv = std::env::var_os("GLINT_PY_VENV")
        .map(PathBuf::from)
        .unwrap_or_else(|| {
            PathBuf::from(std::env::var_os("HOME").expect("HOME")).join(".cache/glint-py")
        });
    let python = venv.join("bin/python");
    assert!(
        python.exists(),
        "no Python venv at {}: run tools/setup-python.sh (tools/test.sh does)",
        venv.display()
    );
    python
}

fn marker(id: u16, x_cm: f64, y_cm: f64) -> PlacedMarker {
    PlacedMarker {
        dictionary: Dictionary::Aruco6x6_250,
        id,
        size_cm: 20.0,
        origin_cm: Point::new(x_cm, y_cm),
        rotation_deg: 0.0,
    }
}

/// `glint calibrate` (ideal lens) on rendered frames of two 20 cm markers, ids 23 at the
/// origin and 101 at (55, 45) cm, seen by the reference camera; the calibration file's path.
pub fn calibrate_two_markers(dir: &Path) -> PathBuf {
    let scene = MarkerScene::new(
        reference_camera(),
        vec![marker(23, 0.0, 0.0), marker(101, 55.0, 45.0)],
    );
    let dump = dir.join("markers.yuv");
    std::fs::write(&dump, scene.render_yuyv()).unwrap();
    let out = dir.join("calib.toml");
    let run = glint()
        .args(["calibrate", "--input"])
        .arg(&dump)
        .args(["--size", "640x480", "--out"])
        .arg(&out)
        .args(["--marker", "23:20", "--marker", "101:20@55,45"])
        .args(["--lens", "ideal"])
        .output()
        .unwrap();
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    out
}
