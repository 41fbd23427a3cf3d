//! `glint track --calib` end to end: `glint calibrate` on rendered marker frames of a known
//! camera, then `glint track` on a rendered LED scene seen by that camera, and the floor
//! positions and speeds it reports compared with the truth mapped through the true camera.
//! Then the calibration files that must be refused.

mod common;

use std::path::{Path, PathBuf};

use common::{glint, parse_jsonl, quantile, render, temp_file, track, Rendered};
use glint::detect::aruco::Dictionary;
use glint::geometry::Point;
use glint_tools::markers::{reference_camera, Camera, MarkerScene, PlacedMarker};
use glint_tools::scene::Visibility;
use serde_json::Value;

/// Calibration error alone (glint's floor position of its own pixel position against the true
/// camera's): the target, 95th percentile over the tracked area.
const MAPPING_P95_MAX_CM: f64 = 0.3;
/// Whole error against the truth: the LED's pixel error (≤ 0.5 px median, 1.5 px p95 in the
/// replay tests) times the floor a pixel covers here (about 0.4 cm) plus the mapping error.
const FLOOR_MEDIAN_MAX_CM: f64 = 0.4;
const FLOOR_P95_MAX_CM: f64 = 0.9;
/// Floor velocity against the true camera's Jacobian applied to glint's own pixel velocity:
/// only the mapping's error.
const VELOCITY_MAPPING_MAX_RELATIVE: f64 = 0.01;
/// Floor speed against the true floor speed.
const SPEED_MEDIAN_MAX_RELATIVE: f64 = 0.05;

fn marker(id: u16, size_cm: f64, x_cm: f64, y_cm: f64) -> PlacedMarker {
    PlacedMarker {
        dictionary: Dictionary::Aruco6x6_250,
        id,
        size_cm,
        origin_cm: Point::new(x_cm, y_cm),
        rotation_deg: 0.0,
    }
}

/// Runs `glint calibrate` on three noisy renderings of `scene`; returns the file written.
fn calibrate(scene: &MarkerScene, dir: &Path, markers: &[&str]) -> PathBuf {
    let mut bytes = Vec::new();
    for seed in 0..3 {
        let mut s = scene.clone();
        s.noise_seed = 7 + seed;
        bytes.extend(s.render_yuyv());
    }
    let dump = dir.join("markers.yuv");
    std::fs::write(&dump, bytes).unwrap();
    let out = dir.join("calib.toml");
    let mut cmd = glint();
    cmd.args(["calibrate", "--input"])
        .arg(&dump)
        .args(["--size", "640x480", "--lens", "ideal", "--out"])
        .arg(&out);
    for m in markers {
        cmd.args(["--marker", m]);
    }
    let run = cmd.output().unwrap();
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    out
}

fn tracked_with(r: &Rendered, calib: &Path, extra: &[&str]) -> Vec<Value> {
    let mut args = vec!["--calib", calib.to_str().unwrap()];
    args.extend(extra);
    let out = track(r, &args);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    parse_jsonl(&out.stdout)
}

fn xy(v: &Value, kx: &str, ky: &str) -> Option<Point> {
    Some(Point::new(v[kx].as_f64()?, v[ky].as_f64()?))
}

/// The true camera's floor motion per pixel at `p`, by central differences.
fn true_jacobian(camera: &Camera, p: Point) -> nalgebra::Matrix2<f64> {
    const STEP_PX: f64 = 1e-3;
    let d = |dx: f64, dy: f64| {
        let a = camera.unproject(Point::new(p.x - dx, p.y - dy)).unwrap();
        let b = camera.unproject(Point::new(p.x + dx, p.y + dy)).unwrap();
        (b - a) / (2.0 * STEP_PX)
    };
    let (cx, cy) = (d(STEP_PX, 0.0), d(0.0, STEP_PX));
    nalgebra::Matrix2::new(cx.x, cy.x, cx.y, cy.y)
}

/// Errors of one tracked scene on the floor.
#[derive(Debug, Default)]
struct FloorErrors {
    /// |floor − true camera's floor of glint's own pixel position|: the mapping alone, cm.
    mapping_cm: Vec<f64>,
    /// |floor − true floor position|, cm.
    floor_cm: Vec<f64>,
    /// Relative difference of the floor velocity from the true Jacobian applied to glint's own
    /// pixel velocity: the velocity mapping alone.
    velocity_mapping: Vec<f64>,
    /// Relative floor speed error.
    floor_speed: Vec<f64>,
    /// Relative pixel speed error of the same frames, for comparison.
    pixel_speed: Vec<f64>,
}

fn floor_errors(reports: &[Value], r: &Rendered, camera: &Camera) -> FloorErrors {
    assert_eq!(reports.len(), r.truths.len());
    let mut e = FloorErrors::default();
    for (rep, truth) in reports.iter().zip(&r.truths) {
        if rep["found"] != true {
            assert!(rep.get("floor_x").is_none(), "no floor without a position");
            continue;
        }
        assert_eq!(rep["floor_unit"], "cm");
        assert!(
            rep.get("beyond_horizon").is_none(),
            "the whole view is floor"
        );
        let floor = xy(rep, "floor_x", "floor_y").expect("every found frame has floor_x, floor_y");
        let px = xy(rep, "x", "y").unwrap();
        e.mapping_cm
            .push((floor - camera.unproject(px).unwrap()).norm());
        if truth.visible != Visibility::Visible {
            continue;
        }
        let true_px = Point::new(truth.x_px.unwrap(), truth.y_px.unwrap());
        e.floor_cm
            .push((floor - camera.unproject(true_px).unwrap()).norm());
        let (Some(v_floor), Some(v_px)) = (xy(rep, "floor_vx", "floor_vy"), xy(rep, "vx", "vy"))
        else {
            assert!(rep.get("floor_speed").is_none());
            continue;
        };
        assert!((v_floor.coords.norm() - rep["floor_speed"].as_f64().unwrap()).abs() < 1e-2);
        let own = true_jacobian(camera, px) * v_px.coords;
        e.velocity_mapping
            .push((v_floor.coords - own).norm() / own.norm());
        let true_v_px = nalgebra::Vector2::new(truth.vx_px_s.unwrap(), truth.vy_px_s.unwrap());
        let true_v = true_jacobian(camera, true_px) * true_v_px;
        e.floor_speed
            .push((v_floor.coords.norm() - true_v.norm()).abs() / true_v.norm());
        e.pixel_speed
            .push((v_px.coords.norm() - true_v_px.norm()).abs() / true_v_px.norm());
    }
    assert!(
        e.floor_cm.len() * 10 >= r.truths.len() * 9,
        "most frames tracked"
    );
    assert!(
        e.floor_speed.len() * 2 >= e.floor_cm.len(),
        "velocity known in most frames"
    );
    eprintln!(
        "{} on the floor: mapping error p95 {:.3} cm (max {:.3}); position error median {:.3} \
         cm, p95 {:.3} cm; velocity mapping worst {:.3} %; floor speed error median {:.2} %, \
         p95 {:.2} % (pixel speed: median {:.2} %, p95 {:.2} %) over {} frames",
        r.scene.name(),
        quantile(&e.mapping_cm, 0.95),
        quantile(&e.mapping_cm, 1.0),
        quantile(&e.floor_cm, 0.5),
        quantile(&e.floor_cm, 0.95),
        100.0 * quantile(&e.velocity_mapping, 1.0),
        100.0 * quantile(&e.floor_speed, 0.5),
        100.0 * quantile(&e.floor_speed, 0.95),
        100.0 * quantile(&e.pixel_speed, 0.5),
        100.0 * quantile(&e.pixel_speed, 0.95),
        e.floor_speed.len()
    );
    let m95 = quantile(&e.mapping_cm, 0.95);
    assert!(m95 <= MAPPING_P95_MAX_CM, "mapping p95 {m95:.3} cm");
    let vm = quantile(&e.velocity_mapping, 1.0);
    assert!(
        vm <= VELOCITY_MAPPING_MAX_RELATIVE,
        "velocity mapping {vm:.4}"
    );
    e
}

fn two_marker_calibration(dir: &Path) -> PathBuf {
    let scene = MarkerScene::new(
        reference_camera(),
        vec![marker(23, 20.0, 0.0, 0.0), marker(101, 20.0, 55.0, 45.0)],
    );
    calibrate(&scene, dir, &["23:20", "101:20@55,45"])
}

#[test]
fn floor_speed_from_single_frame_streaks_matches_the_true_camera() {
    let dir = tempfile::tempdir().unwrap();
    let calib = two_marker_calibration(dir.path());
    let r = render("fast-line");
    let e = floor_errors(&tracked_with(&r, &calib, &[]), &r, &reference_camera());
    let s50 = quantile(&e.floor_speed, 0.5);
    assert!(s50 <= SPEED_MEDIAN_MAX_RELATIVE, "speed median {s50:.4}");
}

#[test]
fn floor_positions_of_a_tracked_led_match_the_true_camera() {
    let camera = reference_camera();
    let dir = tempfile::tempdir().unwrap();
    let calib = two_marker_calibration(dir.path());
    let r = render("figure-eight");
    let reports = tracked_with(&r, &calib, &[]);
    let e = floor_errors(&reports, &r, &camera);
    let (f50, f95) = (quantile(&e.floor_cm, 0.5), quantile(&e.floor_cm, 0.95));
    assert!(f50 <= FLOOR_MEDIAN_MAX_CM, "floor median {f50:.3} cm");
    assert!(f95 <= FLOOR_P95_MAX_CM, "floor p95 {f95:.3} cm");

    // The CSV carries the same floor numbers, and empty cells where JSON has none.
    let out = track(&r, &["--calib", calib.to_str().unwrap(), "--format", "csv"]);
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    let mut lines = text.lines();
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    for (line, j) in lines.zip(&reports) {
        let row: Vec<&str> = line.split(',').collect();
        assert_eq!(row.len(), header.len(), "{line}");
        for key in ["floor_x", "floor_y", "floor_vx", "floor_vy", "floor_speed"] {
            match j.get(key).and_then(Value::as_f64) {
                Some(v) => assert!((row[col(key)].parse::<f64>().unwrap() - v).abs() < 1e-9),
                None => assert_eq!(row[col(key)], "", "{key}"),
            }
        }
        let unit = if j.get("floor_x").is_some() { "cm" } else { "" };
        assert_eq!(row[col("floor_unit")], unit);
        assert_eq!(row[col("beyond_horizon")], "false");
    }
}

/// A low camera whose view holds the horizon: the upper part of the picture is not floor.
fn horizon_camera() -> Camera {
    Camera {
        width_px: 640,
        height_px: 480,
        focal_px: 460.0,
        position_cm: [10.0, -70.0, 60.0],
        look_at_cm: [10.0, 200.0, 0.0],
    }
}

#[test]
fn positions_beyond_the_horizon_get_a_flag_and_no_floor_numbers() {
    let camera = horizon_camera();
    let scene = MarkerScene::new(camera, vec![marker(23, 40.0, -10.0, 50.0)]);
    let dir = tempfile::tempdir().unwrap();
    let calib = calibrate(&scene, dir.path(), &["23:40@-10,50"]);
    // The horizon is a horizontal line on the picture of this level camera.
    let (mut beyond, mut floor) = (0, 0);
    let r = render("figure-eight");
    for rep in tracked_with(&r, &calib, &[]) {
        let Some(px) = xy(&rep, "x", "y") else {
            continue;
        };
        let margin_px = 3.0;
        let truly_floor = |dy: f64| camera.unproject(Point::new(px.x, px.y + dy)).is_some();
        if truly_floor(-margin_px) {
            assert!(rep.get("floor_x").is_some(), "{rep}");
            assert!(rep.get("beyond_horizon").is_none(), "{rep}");
            floor += 1;
        } else if !truly_floor(margin_px) {
            assert_eq!(rep["beyond_horizon"], true, "{rep}");
            for key in ["floor_x", "floor_y", "floor_vx", "floor_vy", "floor_speed"] {
                assert!(rep.get(key).is_none(), "{key} in {rep}");
            }
            beyond += 1;
        }
    }
    eprintln!("{floor} frames on the floor, {beyond} beyond the horizon");
    assert!(floor >= 20 && beyond >= 20, "{floor} / {beyond}");
}

/// One line on standard error naming `needle`, a failure exit, no panic, no output.
fn assert_refused(out: &std::process::Output, needle: &str) {
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "must fail: {stderr}");
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert_eq!(stderr.trim_end().lines().count(), 1, "one line: {stderr}");
    assert!(stderr.contains(needle), "{needle:?} in {stderr}");
    assert!(out.stdout.is_empty(), "no reports with a bad calibration");
}

#[test]
fn bad_calibration_files_are_refused_with_one_line() {
    let scene = MarkerScene::new(reference_camera(), vec![marker(23, 20.0, 0.0, 0.0)]);
    let dir = tempfile::tempdir().unwrap();
    let calib = calibrate(&scene, dir.path(), &["23:20"]);
    let good = std::fs::read_to_string(&calib).unwrap();
    let r = render("slow-line");
    let run = |text: &str| {
        let (_d, path) = temp_file("calib.toml", text.as_bytes());
        track(&r, &["--calib", path.to_str().unwrap()])
    };
    assert!(run(&good).status.success(), "the file as written is good");

    let missing = track(&r, &["--calib", "/nonexistent/calib.toml"]);
    assert_refused(&missing, "cannot read calibration /nonexistent/calib.toml");

    let without = |key: &str| -> String {
        good.lines()
            .filter(|l| !l.starts_with(key))
            .map(|l| format!("{l}\n"))
            .collect()
    };
    assert_refused(&run(&without("height_px")), "missing field `height_px`");
    assert_refused(&run(&without("fx")), "missing field `fx`");
    assert_refused(&run(&without("rms_px")), "missing field `rms_px`");
    assert_refused(&run("this is not toml"), "line 1");
    assert_refused(
        &run(&good.replace("width_px = 640", "width_px = 320")),
        "made for 320x480 frames, but the frames are 640x480",
    );
    assert_refused(
        &run(&good.replace("units = \"cm\"", "units = \"parsecs\"")),
        "parsecs",
    );
    assert_refused(
        &run(&good.replace("units = \"cm\"", "units = \"mm\"")),
        "units must be \"cm\"",
    );
    assert_refused(
        &run(&good.replace("version = 2", "version = 3")),
        "version 3 is not one this glint reads",
    );

    // A rotation that is not one: its first row doubled.
    let line = good.lines().find(|l| l.starts_with("rotation")).unwrap();
    let rows: Vec<&str> = line.split("], [").collect();
    let first = rows[0].trim_start_matches("rotation = [[");
    let doubled: Vec<String> = first
        .split(", ")
        .map(|v| format!("{:?}", 2.0 * v.parse::<f64>().unwrap()))
        .collect();
    let edited = good.replace(line, &line.replacen(first, &doubled.join(", "), 1));
    assert_refused(
        &run(&edited),
        "[pose]: the rotation matrix is not a rotation",
    );
    // A finite, plausible, wrong number.
    let fx = good.lines().find(|l| l.starts_with("fx")).unwrap();
    let edited = good.replace(fx, "fx = 480.0");
    assert_refused(&run(&edited), "were the numbers edited?");
    assert_refused(
        &run(&good.replace("[[marker]]", "[[unused]]")),
        "unknown field `unused`",
    );
    let marker_at = good.find("[[marker]]").unwrap();
    assert_refused(&run(&good[..marker_at]), "no [[marker]] entries");
}

#[test]
fn an_led_height_needs_a_pose_below_the_camera() {
    let scene = MarkerScene::new(reference_camera(), vec![marker(23, 20.0, 0.0, 0.0)]);
    let dir = tempfile::tempdir().unwrap();
    let calib = calibrate(&scene, dir.path(), &["23:20"]);
    let r = render("slow-line");
    let c = calib.to_str().unwrap();
    let ok = track(&r, &["--calib", c, "--led-height-cm", "12"]);
    assert!(
        ok.status.success(),
        "{}",
        String::from_utf8_lossy(&ok.stderr)
    );
    assert_refused(
        &track(&r, &["--calib", c, "--led-height-cm", "500"]),
        "the LED must be below the camera, which is 130.",
    );
    let out = track(&r, &["--led-height-cm", "12"]);
    assert!(String::from_utf8_lossy(&out.stderr).contains("--calib"));
    let out = track(&r, &["--calib", c, "--led-height-cm", "-3"]);
    assert!(String::from_utf8_lossy(&out.stderr).contains("is not a height between 0 and 1000"));

    // A calibration from an older glint (a homography only) has no pose to raise the LED with.
    let h = "[[2.1, 0.3, 320.0], [-0.2, 1.4, 240.0], [0.0004, 0.0021, 1.0]]";
    let inv = nalgebra::Matrix3::new(2.1, 0.3, 320.0, -0.2, 1.4, 240.0, 0.0004, 0.0021, 1.0)
        .try_inverse()
        .unwrap();
    let inv = (0..3)
        .map(|i| format!("[{:?}, {:?}, {:?}]", inv[(i, 0)], inv[(i, 1)], inv[(i, 2)]))
        .collect::<Vec<_>>()
        .join(", ");
    let corners: Vec<String> = [(0.0, 0.0), (20.0, 0.0), (20.0, 20.0), (0.0, 20.0)]
        .iter()
        .map(|&(x, y)| {
            let w = 0.0004 * x + 0.0021 * y + 1.0;
            format!(
                "[{:?}, {:?}]",
                (2.1 * x + 0.3 * y + 320.0) / w,
                (-0.2 * x + 1.4 * y + 240.0) / w
            )
        })
        .collect();
    let v1 = format!(
        "width_px = 640\nheight_px = 480\nunits = \"cm\"\n[homography]\nfloor_to_screen = {h}\n\
         screen_to_floor = [{inv}]\n[[marker]]\nid = 23\nsize_cm = 20.0\norigin_cm = [0.0, 0.0]\n\
         corners_px = [{}]\nresiduals_px = [0.0, 0.0, 0.0, 0.0]\n",
        corners.join(", ")
    );
    let (_d, old) = temp_file("old.toml", v1.as_bytes());
    let o = old.to_str().unwrap();
    let loads = track(&r, &["--calib", o]);
    assert!(
        loads.status.success(),
        "{}",
        String::from_utf8_lossy(&loads.stderr)
    );
    assert_refused(
        &track(&r, &["--calib", o, "--led-height-cm", "12"]),
        "an LED height needs the camera's pose",
    );

    // The settings key of glint run.
    let settings = format!("calib = {c:?}\nled-height-cm = 500\n");
    let (_s, config) = temp_file("glint.toml", settings.as_bytes());
    let run = glint()
        .args(["run", "--config"])
        .arg(&config)
        .args(["--input"])
        .arg(&r.dump)
        .args(["--size", "640x480"])
        .output()
        .unwrap();
    assert!(!run.status.success());
    assert!(
        String::from_utf8_lossy(&run.stderr).contains("the LED must be below the camera"),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
}
