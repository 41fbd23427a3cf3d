//! `glint calibrate` end to end: rendered marker frames in a dump file, the real binary, and the
//! TOML it writes checked against the renderer's ground truth.

mod common;

use common::{glint, repack};
use glint::frame::{FrameSize, PixelFormat};
use glint::geometry::Point;
use glint::source::sidecar::{FrameTiming, Sidecar};
use glint_tools::markers::{reference_camera, MarkerScene, PlacedMarker};

fn marker(id: u16, x_cm: f64, y_cm: f64) -> PlacedMarker {
    PlacedMarker {
        dictionary: glint::detect::aruco::Dictionary::Aruco6x6_250,
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
    // Marker arguments, then any other options as given.
    let options_at = markers
        .iter()
        .position(|m| m.starts_with("--"))
        .unwrap_or(markers.len());
    let (markers, options) = markers.split_at(options_at);
    if options.is_empty() {
        // One or two markers near the centre cannot determine a lens.
        cmd.args(["--lens", "ideal"]);
    }
    cmd.args(options);
    for m in markers {
        cmd.args(["--marker", m]);
    }
    cmd.output().unwrap()
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
    assert_eq!(t["version"].as_integer(), Some(2));
    assert_eq!(t["lens"]["source"].as_str(), Some("ideal"));
    assert_eq!(t["residuals"]["corners"].as_integer(), Some(8));
    assert!(t["residuals"]["rms_px"].as_float().unwrap() < 0.05);
    let markers = t["marker"].as_array().unwrap();
    assert_eq!(markers.len(), 2);
    assert_eq!(
        markers[1]["origin_cm"].as_array().unwrap()[0].as_float(),
        Some(55.0)
    );

    // The written camera, over the 1.6 m × 1.4 m area, against the truth.
    let size = glint::frame::FrameSize::new(640, 480).unwrap();
    let calibration = glint::geometry::CalibrationFile::parse(&text, size).unwrap();
    let camera = calibration.floor.camera().copied().unwrap();
    let (mut worst_cm, mut worst_px): (f64, f64) = (0.0, 0.0);
    for yi in 0..=14 {
        for xi in 0..=16 {
            let truth = Point::new(-70.0 + 10.0 * f64::from(xi), -60.0 + 10.0 * f64::from(yi));
            let screen = scene.camera.project(truth).unwrap();
            let floor = calibration.floor.screen_to_floor(&screen).unwrap();
            worst_cm = worst_cm.max((floor - truth).norm());
            worst_px = worst_px.max((camera.project(&truth, 0.0).unwrap() - screen).norm());
        }
    }
    eprintln!("worst over the area: {worst_cm:.3} cm, {worst_px:.3} px");
    assert!(worst_cm < 0.3, "{worst_cm} cm");
    assert!(worst_px < 0.25, "{worst_px} px");
    // The camera is where the renderer put it, 1.3 m up.
    let height = camera.pose.height();
    assert!((height - 130.0).abs() < 3.0, "{height} cm");
}

#[test]
fn map_markers_this_camera_does_not_see_are_listed_and_left_out() {
    let scene = MarkerScene::new(reference_camera(), vec![marker(23, 0.0, 0.0)]);
    let (dir, path) = dump(&scene, 1);
    let out = dir.path().join("calib.toml");
    let run = calibrate(&path, &out, &["23:20", "7:20@100,0"]);
    let stdout = String::from_utf8_lossy(&run.stdout);
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    assert!(stdout.contains("not seen (left out): marker 7"), "{stdout}");
    let t: toml::Value = toml::from_str(&std::fs::read_to_string(&out).unwrap()).unwrap();
    assert_eq!(t["unseen"].as_array().unwrap()[0].as_integer(), Some(7));
    assert_eq!(t["marker"].as_array().unwrap().len(), 1);

    // None of them seen: nothing to calibrate from.
    let out = dir.path().join("none.toml");
    let run = calibrate(&path, &out, &["7:20@100,0", "8:20@0,100"]);
    assert!(!run.status.success());
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert_eq!(stderr.trim_end().lines().count(), 1, "{stderr}");
    assert!(
        stderr.contains(
            "none of the named markers was seen in any of 1 frames with DICT_6X6_250 (markers seen: 23)"
        ),
        "{stderr}"
    );
    assert!(!out.exists(), "no file is written for a failed calibration");
}

#[test]
fn overlapping_markers_on_the_map_are_one_clear_error() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("empty.yuv");
    std::fs::write(&path, []).unwrap();
    let out = dir.path().join("calib.toml");
    let run = calibrate(&path, &out, &["23:20", "7:20@10,10"]);
    assert!(!run.status.success());
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert_eq!(stderr.trim_end().lines().count(), 1, "{stderr}");
    assert!(
        stderr.contains("markers 23 and 7 overlap on the map (23:20@0,0 and 7:20@10,10)"),
        "{stderr}"
    );
    // Touching edges is not overlapping.
    let run = calibrate(&path, &out, &["23:20", "7:20@20,0"]);
    assert!(String::from_utf8_lossy(&run.stderr).contains("holds no whole frame"));
}

#[test]
fn a_lens_the_markers_cannot_determine_is_refused_with_where_to_add_markers() {
    let scene = MarkerScene::new(
        reference_camera(),
        vec![marker(23, 0.0, 0.0), marker(101, 25.0, -20.0)],
    );
    let (dir, path) = dump(&scene, 2);
    let out = dir.path().join("calib.toml");
    let run = calibrate(&path, &out, &["23:20", "101:20@25,-20", "--lens", "fit"]);
    assert!(!run.status.success());
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert_eq!(stderr.trim_end().lines().count(), 1, "{stderr}");
    assert!(
        stderr.contains("the markers do not determine the lens"),
        "{stderr}"
    );
    assert!(
        stderr.contains("top left") && stderr.contains("--lens ideal"),
        "{stderr}"
    );
    assert!(!out.exists());
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

#[test]
fn a_mono_camera_s_grey_dump_calibrates_as_its_yuyv_does() {
    let scene = MarkerScene::new(
        reference_camera(),
        vec![marker(23, 0.0, 0.0), marker(101, 55.0, 45.0)],
    );
    let (dir, yuyv) = dump(&scene, 3);
    let markers = ["23:20", "101:20@55,45", "--lens", "ideal"];
    let written = |run: std::process::Output, out: &std::path::Path| {
        assert!(
            run.status.success(),
            "{}",
            String::from_utf8_lossy(&run.stderr)
        );
        std::fs::read_to_string(out).unwrap()
    };
    let out = dir.path().join("yuyv.toml");
    let reference = written(calibrate(&yuyv, &out, &markers), &out);
    let grey = dir.path().join("markers.grey");
    std::fs::write(
        &grey,
        repack(&std::fs::read(&yuyv).unwrap(), PixelFormat::Grey),
    )
    .unwrap();

    // The same luma, read in place from GREY: the same calibration, to the last digit.
    let out = dir.path().join("grey.toml");
    let with_format = [&markers[..], &["--format-in", "grey"]].concat();
    assert_eq!(
        written(calibrate(&grey, &out, &with_format), &out),
        reference
    );

    // Read as YUYV, three GREY frames are a frame and a half.
    let run = calibrate(&grey, &out, &markers);
    assert!(!run.status.success());
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(
        stderr.contains(
            "921600 bytes is not a whole number of 640x480 frames (614400 bytes each as yuyv)"
        ),
        "{stderr}"
    );

    // A dump `glint record` wrote says its format in its sidecar: no --format-in needed, and
    // one that contradicts it is refused.
    let size = FrameSize::new(640, 480).unwrap();
    let timings = (0..3)
        .map(|i| FrameTiming {
            seq: i,
            t_us: i * 33_333,
        })
        .collect();
    let sidecar = Sidecar::new(size, 640, timings).with_format(PixelFormat::Grey);
    let mut text = Vec::new();
    sidecar.write(&mut text).unwrap();
    std::fs::write(Sidecar::path_for(&grey), text).unwrap();
    let out = dir.path().join("sidecar.toml");
    assert_eq!(written(calibrate(&grey, &out, &markers), &out), reference);
    let with_yuyv = [&markers[..], &["--format-in", "yuyv"]].concat();
    let run = calibrate(&grey, &out, &with_yuyv);
    assert!(!run.status.success());
    let stderr = String::from_utf8_lossy(&run.stderr);
    assert!(
        stderr.contains("says the frames are grey, but --format-in is yuyv"),
        "{stderr}"
    );
}
