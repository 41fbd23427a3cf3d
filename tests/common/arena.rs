//! The two-camera arena (`glint_tools::scene::Arena`) as `glint fuse` tests use it: small
//! settings, and each camera calibrated by the real `glint calibrate` against the shared map.

use std::path::{Path, PathBuf};

use glint_tools::scene::{ArenaCamera, ArenaConfig};

use super::glint;

/// Frames of each camera `glint calibrate` reads.
pub const CALIBRATION_FRAMES: usize = 4;

/// Two 320×240 cameras at the standard arena's geometry, 3 s of the robot crossing.
pub fn small(config: ArenaConfig) -> ArenaConfig {
    ArenaConfig {
        width_px: 320,
        height_px: 240,
        frame_count: 90,
        ..config
    }
}

/// Calibrates camera `cam` from the first frames of its dump, against the shared marker map;
/// returns the calibration file.
pub fn calibrate(cam: &ArenaCamera, dump: &Path, dir: &Path) -> PathBuf {
    let bytes = std::fs::read(dump).unwrap();
    let first = dir.join(format!("{}-calibration.yuv", cam.name));
    std::fs::write(
        &first,
        &bytes[..CALIBRATION_FRAMES * cam.scene.frame_len_bytes()],
    )
    .unwrap();
    let out = dir.join(format!("{}.toml", cam.name));
    let size = format!("{}x{}", cam.scene.width_px(), cam.scene.height_px());
    let mut cmd = glint();
    cmd.args(["calibrate", "--input"])
        .arg(&first)
        .args(["--size", &size, "--lens", "ideal", "--out"])
        .arg(&out);
    for m in cam.marker_args() {
        cmd.args(["--marker", &m]);
    }
    let run = cmd.output().unwrap();
    assert!(
        run.status.success(),
        "{}: {}",
        cam.name,
        String::from_utf8_lossy(&run.stderr)
    );
    out
}

/// Renders camera `cam`'s dump into `dir`, calibrates it ([`calibrate`]) and runs `glint track`
/// on it with its calibration and `extra` arguments; returns the JSON lines it printed.
pub fn track(cam: &ArenaCamera, dir: &Path, extra: &[&str]) -> Vec<u8> {
    let dump = cam.write_dump(dir).unwrap();
    let calib = calibrate(cam, &dump, dir);
    let size = format!("{}x{}", cam.scene.width_px(), cam.scene.height_px());
    let run = glint()
        .args(["track", "--input"])
        .arg(&dump)
        .args(["--size", &size, "--exposure-us"])
        .arg(cam.scene.exposure_us().to_string())
        .arg("--calib")
        .arg(&calib)
        .args(extra)
        .output()
        .unwrap();
    assert!(
        run.status.success(),
        "{}: {}",
        cam.name,
        String::from_utf8_lossy(&run.stderr)
    );
    run.stdout
}
