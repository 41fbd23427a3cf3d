//! `glint track --detector aruco --marker ID` end to end: a robot carrying a marker, rendered
//! turning and moving across the floor with exact ground truth, tracked by the real binary,
//! with and without a floor calibration; then the marker absent, the wrong id, the id twice,
//! and bad options.

mod common;

use std::path::{Path, PathBuf};
use std::process::Output;

use common::{glint, parse_jsonl, quantile};
use glint::detect::aruco::Dictionary;
use glint::geometry::Point;
use glint_tools::markers::{reference_camera, MarkerScene, PlacedMarker};
use serde_json::Value;

/// Bounds against the truth. Corners are good to about 0.1 px; the centre averages them.
const CENTRE_MAX_PX: f64 = 0.2;
const HEADING_MAX_DEG: f64 = 0.5;
/// The calibration target (one 20 cm marker, extrapolated ~50 cm to the robot).
const FLOOR_CENTRE_MAX_CM: f64 = 0.3;
const FLOOR_SPEED_MAX_RELATIVE: f64 = 0.02;

const FPS: f64 = 30.0;
const ROBOT_ID: u16 = 7;
const ROBOT_SIZE_CM: f64 = 15.0;
const FRAMES: usize = 10;

fn placed(id: u16, size_cm: f64, centre: Point, rotation_deg: f64) -> PlacedMarker {
    PlacedMarker {
        dictionary: Dictionary::Aruco6x6_250,
        id,
        size_cm,
        origin_cm: Point::new(centre.x - 0.5 * size_cm, centre.y - 0.5 * size_cm),
        rotation_deg,
    }
}

/// The calibration marker: 20 cm, printed top-left corner at (−60, 50) cm.
fn calibration_marker() -> PlacedMarker {
    placed(23, 20.0, Point::new(-50.0, 60.0), 0.0)
}

/// Frame `i` of the robot's drive: a straight line at constant speed while turning.
fn robot(i: usize) -> PlacedMarker {
    let t = i as f64;
    let centre = Point::new(-20.0 + 4.0 * t, -15.0 + 2.5 * t);
    placed(ROBOT_ID, ROBOT_SIZE_CM, centre, -75.0 + 37.0 * t)
}

/// Renders scenes (one frame each) into a dump file.
fn dump(dir: &Path, name: &str, scenes: &[MarkerScene]) -> PathBuf {
    let mut bytes = Vec::new();
    for (i, s) in scenes.iter().enumerate() {
        let mut s = s.clone();
        s.noise_seed = 31 + i as u64;
        bytes.extend(s.render_yuyv());
    }
    let path = dir.join(name);
    std::fs::write(&path, bytes).unwrap();
    path
}

fn scene(markers: Vec<PlacedMarker>) -> MarkerScene {
    MarkerScene::new(reference_camera(), markers)
}

fn track(dump: &Path, extra: &[&str]) -> Output {
    glint()
        .args(["track", "--input"])
        .arg(dump)
        .args(["--size", "640x480", "--fps", &FPS.to_string()])
        .args(extra)
        .output()
        .unwrap()
}

fn reports(out: &Output) -> Vec<Value> {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    parse_jsonl(&out.stdout)
}

fn xy(v: &Value, kx: &str, ky: &str) -> Point {
    Point::new(v[kx].as_f64().unwrap(), v[ky].as_f64().unwrap())
}

/// Difference of two angles in degrees, in [−180, 180).
fn angle_diff_deg(a: f64, b: f64) -> f64 {
    (a - b + 180.0).rem_euclid(360.0) - 180.0
}

#[test]
fn a_turning_robot_is_tracked_on_the_screen_and_on_the_floor() {
    let dir = tempfile::tempdir().unwrap();
    let camera = reference_camera();
    // Calibrate from the fixed marker, alone in view.
    let cal_dump = dump(dir.path(), "cal.yuv", &[scene(vec![calibration_marker()])]);
    let calib = dir.path().join("calib.toml");
    let run = glint()
        .args(["calibrate", "--input"])
        .arg(&cal_dump)
        .args([
            "--size",
            "640x480",
            "--marker",
            "23:20@-60,50",
            "--lens",
            "ideal",
        ])
        .arg("--out")
        .arg(&calib)
        .output()
        .unwrap();
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );

    // The robot drives past the calibration marker; frame FRAMES has no robot in view.
    let mut scenes: Vec<MarkerScene> = (0..FRAMES)
        .map(|i| scene(vec![calibration_marker(), robot(i)]))
        .collect();
    scenes.push(scene(vec![calibration_marker()]));
    let drive = dump(dir.path(), "drive.yuv", &scenes);
    let id = ROBOT_ID.to_string();

    let screen_only = reports(&track(&drive, &["--detector", "aruco", "--marker", &id]));
    let with_floor = reports(&track(
        &drive,
        &[
            "--detector",
            "aruco",
            "--marker",
            &id,
            "--calib",
            calib.to_str().unwrap(),
        ],
    ));
    assert_eq!(screen_only.len(), FRAMES + 1);
    assert_eq!(with_floor.len(), FRAMES + 1);
    let (mut centre_px, mut heading_deg, mut floor_cm, mut floor_heading_deg, mut speed) =
        (vec![], vec![], vec![], vec![], vec![]);
    for (i, (s, f)) in screen_only.iter().zip(&with_floor).enumerate().take(FRAMES) {
        assert_eq!(s["found"], true, "frame {i}");
        assert_eq!(s["pos_method"], "marker");
        assert!(s.get("floor_x").is_none(), "no floor without --calib");
        let truth = robot(i);
        let true_px = camera.project(truth.centre_cm()).unwrap();
        let c = xy(s, "x", "y");
        assert_eq!(c, xy(s, "mid_x", "mid_y"), "the middle is the centre");
        centre_px.push((c - true_px).norm());
        // On the screen, the truth is the heading of the projected corners.
        let corners = truth.corners_cm().map(|p| camera.project(p).unwrap());
        let top = (corners[0].coords + corners[1].coords) / 2.0;
        let bottom = (corners[3].coords + corners[2].coords) / 2.0;
        let d = top - bottom;
        let true_heading = d.y.atan2(d.x).to_degrees();
        heading_deg.push(angle_diff_deg(s["heading_deg"].as_f64().unwrap(), true_heading).abs());

        // The same screen numbers with --calib, plus the floor's.
        assert_eq!(f["x"], s["x"]);
        assert_eq!(f["heading_deg"], s["heading_deg"]);
        assert_eq!(f["floor_unit"], "cm");
        floor_cm.push((xy(f, "floor_x", "floor_y") - truth.centre_cm()).norm());
        // On the floor map the printed top points along −y when unturned: −90° + rotation.
        let true_floor_heading = -90.0 + truth.rotation_deg;
        floor_heading_deg.push(
            angle_diff_deg(f["floor_heading_deg"].as_f64().unwrap(), true_floor_heading).abs(),
        );
        if i > 0 {
            let true_speed = (robot(i).centre_cm() - robot(i - 1).centre_cm()).norm() * FPS;
            let got = f["floor_speed"]
                .as_f64()
                .expect("speed from the previous frame");
            speed.push((got - true_speed).abs() / true_speed);
        } else {
            assert!(
                f.get("floor_speed").is_none(),
                "no speed in the first frame"
            );
        }
    }
    for r in [&screen_only[FRAMES], &with_floor[FRAMES]] {
        assert_eq!(r["found"], false, "the robot left the view: {r}");
        assert!(r.get("x").is_none() && r.get("heading_deg").is_none());
        assert!(r.get("floor_x").is_none());
    }
    let worst = |v: &[f64]| quantile(v, 1.0);
    eprintln!(
        "marker tracking: centre worst {:.3} px, heading worst {:.3}°; floor centre worst {:.3} \
         cm, floor heading worst {:.3}°, floor speed worst {:.2} %",
        worst(&centre_px),
        worst(&heading_deg),
        worst(&floor_cm),
        worst(&floor_heading_deg),
        100.0 * worst(&speed)
    );
    assert!(worst(&centre_px) <= CENTRE_MAX_PX);
    assert!(worst(&heading_deg) <= HEADING_MAX_DEG);
    assert!(worst(&floor_cm) <= FLOOR_CENTRE_MAX_CM);
    assert!(worst(&floor_heading_deg) <= HEADING_MAX_DEG);
    assert!(worst(&speed) <= FLOOR_SPEED_MAX_RELATIVE);

    // Another id is never reported as the robot.
    let wrong = reports(&track(&drive, &["--detector", "aruco", "--marker", "8"]));
    assert!(wrong.iter().all(|r| r["found"] == false));
    // Nor is the calibration marker, whose id is in view but in another dictionary.
    let other_dict = reports(&track(
        &drive,
        &[
            "--detector",
            "aruco",
            "--marker",
            "23",
            "--dict",
            "DICT_4X4_50",
        ],
    ));
    assert!(other_dict.iter().all(|r| r["found"] == false));
}

#[test]
fn the_id_seen_twice_is_ambiguous_not_a_guess() {
    let dir = tempfile::tempdir().unwrap();
    let twins = scene(vec![
        placed(ROBOT_ID, ROBOT_SIZE_CM, Point::new(-20.0, 0.0), 0.0),
        placed(ROBOT_ID, ROBOT_SIZE_CM, Point::new(40.0, 20.0), 30.0),
    ]);
    let path = dump(dir.path(), "twins.yuv", &[twins]);
    let r = reports(&track(&path, &["--detector", "aruco", "--marker", "7"]));
    assert_eq!(r[0]["found"], false);
    assert_eq!(r[0]["ambiguous"], true);
}

#[test]
fn bad_marker_options_get_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let path = dump(dir.path(), "one.yuv", &[scene(vec![robot(0)])]);
    for (args, needle) in [
        (
            &["--detector", "aruco"][..],
            "--detector aruco needs --marker ID",
        ),
        (
            &["--marker", "7"][..],
            "--marker goes with --detector aruco",
        ),
        (
            &["--dict", "DICT_4X4_50"][..],
            "--dict goes with --detector aruco",
        ),
        (
            &["--detector", "aruco", "--marker", "250"][..],
            "marker id 250 is not in DICT_6X6_250, whose ids are 0..=249",
        ),
        (
            &["--detector", "aruco", "--marker", "7", "--dict", "DICT_9X9"][..],
            "DICT_9X9",
        ),
        (&["--detector", "aruco", "--marker", "-1"][..], "-1"),
    ] {
        let out = track(&path, args);
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{args:?}");
        assert!(!stderr.contains("panicked"), "{stderr}");
        assert_eq!(stderr.trim_end().lines().count(), 1, "{args:?}: {stderr}");
        assert!(stderr.contains(needle), "{args:?}: {needle:?} in {stderr}");
    }
}
