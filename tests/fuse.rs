//! `glint fuse` end to end: one arena rendered through two cameras a third of a view apart
//! (`glint_tools::scene::Arena`), each camera's frames through the real `glint calibrate`
//! (against the shared marker map) and `glint track --calib` (its capture times from the
//! dump's sidecar), and the two cameras' JSON lines through `glint fuse --input`. The fused
//! floor track is held to the renderer's exact floor truth.

mod common;

use std::path::{Path, PathBuf};
use std::time::Instant;

use common::{glint, parse_jsonl, quantile};
use glint_tools::scene::{Arena, ArenaCamera, ArenaConfig};
use serde_json::Value;

/// The goal for the fused floor error, p95 (cm).
const GOAL_P95_CM: f64 = 0.5;
/// Frames of each camera `glint calibrate` reads.
const CALIBRATION_FRAMES: usize = 4;

/// One camera's dump, calibration and reports.
struct Recorded {
    jsonl: PathBuf,
    reports: Vec<Value>,
}

fn calibrate(cam: &ArenaCamera, dump: &Path, dir: &Path) -> PathBuf {
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

/// Renders, calibrates and tracks one camera; its JSON lines are written to `NAME.jsonl`.
fn record(arena: &Arena, cam: &ArenaCamera, dir: &Path) -> Recorded {
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
        .args(["--led-height-cm", &arena.config.led_height_cm.to_string()])
        .output()
        .unwrap();
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    let jsonl = dir.join(format!("{}.jsonl", cam.name));
    std::fs::write(&jsonl, &run.stdout).unwrap();
    Recorded {
        jsonl,
        reports: parse_jsonl(&run.stdout),
    }
}

/// `glint fuse` on the recorded lines; its steps and standard error.
fn fuse(inputs: &[(&str, &Path)], extra: &[&str]) -> (Vec<Value>, String) {
    let mut cmd = glint();
    cmd.arg("fuse");
    for (name, path) in inputs {
        cmd.arg("--input").arg(format!("{name}={}", path.display()));
    }
    let run = cmd.args(extra).output().unwrap();
    let stderr = String::from_utf8_lossy(&run.stderr).into_owned();
    assert!(run.status.success(), "{stderr}");
    (parse_jsonl(&run.stdout), stderr)
}

fn num(v: &Value, key: &str) -> f64 {
    v[key].as_f64().unwrap_or_else(|| panic!("no {key} in {v}"))
}

/// Floor error (cm) of a camera's own found reports against the truth.
fn camera_errors(arena: &Arena, cam: &ArenaCamera, reports: &[Value]) -> Vec<f64> {
    reports
        .iter()
        .enumerate()
        .filter(|(_, r)| r["found"] == true)
        .map(|(frame, r)| {
            let truth = arena.floor_truth_cm(cam.true_time_s(frame));
            (num(r, "floor_x") - truth.x).hypot(num(r, "floor_y") - truth.y)
        })
        .collect()
}

#[test]
fn two_cameras_make_one_track_across_the_arena() {
    let started = Instant::now();
    let dir = tempfile::tempdir().unwrap();
    let arena = Arena::new(ArenaConfig::standard()).unwrap();
    let [a, b] = &arena.cameras;
    let (ra, rb) = (record(&arena, a, dir.path()), record(&arena, b, dir.path()));
    eprintln!(
        "rendered and tracked in {:.1} s",
        started.elapsed().as_secs_f64()
    );
    for (cam, r) in [(a, &ra), (b, &rb)] {
        let e = camera_errors(&arena, cam, &r.reports);
        eprintln!(
            "{}: {} found, floor error median {:.3} p95 {:.3} max {:.3} cm",
            cam.name,
            e.len(),
            quantile(&e, 0.5),
            quantile(&e, 0.95),
            quantile(&e, 1.0)
        );
    }
    let size = format!("{}x{}", a.scene.width_px(), a.scene.height_px());
    let (steps, stderr) = fuse(&[("a", &ra.jsonl), ("b", &rb.jsonl)], &["--size", &size]);
    eprintln!("{stderr}");
    let mut errors = Vec::new();
    for s in &steps {
        let t = Arena::true_time_s(num(s, "t") * 1e6);
        let track = &s["tracks"][0];
        if track["found"] != true {
            eprintln!("lost at {t}");
            continue;
        }
        let truth = arena.floor_truth_cm(t);
        let e = (num(track, "floor_x") - truth.x).hypot(num(track, "floor_y") - truth.y);
        errors.push(e);
    }
    eprintln!(
        "fused: {} steps, error median {:.3} p95 {:.3} max {:.3} cm; {:.1} s in all",
        steps.len(),
        quantile(&errors, 0.5),
        quantile(&errors, 0.95),
        quantile(&errors, 1.0),
        started.elapsed().as_secs_f64()
    );
    assert!(quantile(&errors, 0.95) <= GOAL_P95_CM);
}
