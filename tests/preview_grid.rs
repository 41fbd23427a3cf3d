//! The preview's floor grid (10 cm squares through the fitted lens), served in its state as
//! polylines of pixels: every point must be where the renderer's true camera sees a 10 cm grid
//! line of the floor, before a knock and, once the re-check has refitted the pose, after it.
//!
//! The camera is fitted by glint to the markers of a rendered frame (the mild decentred lens of
//! the `knocked` scene), the frames go through the real pipeline (with the re-check) and the
//! real preview sink, and the state is fetched over HTTP.

mod common;

use std::time::Duration;

use common::live::get;
use common::view::{fit_first_frame, meta_at_30_fps, rendered};
use glint::detect::aruco::Dictionary;
use glint::frame::{Frame, FrameSize};
use glint::geometry::recheck::MarkerRecheck;
use glint::geometry::{FloorStage, FloorUnit};
use glint::pipeline::{Pipeline, PipelineConfig};
use glint::sink::preview::PreviewSink;
use glint::sink::Sink;
use glint_tools::scene::{Point as ScenePoint, Scene, View};
use serde_json::Value;

/// The grid's spacing, cm.
const SPACING_CM: f64 = 10.0;
/// How far the grid's points may be from where the true camera sees their grid lines, pixels,
/// at p95 and at worst: the fitted camera's own error. Over the markers' area it is a few
/// tenths of a pixel; the worst is in the picture's far corners, beyond the markers, where one
/// view's fit (the principal point held at the centre, the true one 6, −4 px off) extrapolates.
const P95_OFF_PX: f64 = 0.75;
const MAX_OFF_PX: f64 = 3.0;

/// Distance (pixels) from `px` to where the true camera at `frame` sees the nearest floor grid
/// line, along that line's normal on the floor: the true floor point seen at `px` is moved onto
/// the nearest line and seen again.
fn off_grid_px(view: &View, frame: usize, px: (f64, f64)) -> f64 {
    let f = view
        .floor_seen_at(ScenePoint::new(px.0, px.1), frame)
        .expect("a grid point sees the floor");
    let snap = |v: f64| (v / SPACING_CM).round() * SPACING_CM;
    let on_line = if (f.x - snap(f.x)).abs() < (f.y - snap(f.y)).abs() {
        glint::geometry::Point::new(snap(f.x), f.y)
    } else {
        glint::geometry::Point::new(f.x, snap(f.y))
    };
    let reference = view
        .camera
        .project(on_line)
        .expect("in front of the camera");
    let seen = view
        .to_output(ScenePoint::new(reference.x, reference.y), frame)
        .expect("in front of the camera");
    (seen.x - px.0).hypot(seen.y - px.1)
}

/// The grid's points from a state.
fn grid_points(state: &Value) -> Vec<(f64, f64)> {
    state["floor_grid_px"]
        .as_array()
        .expect("a floor grid")
        .iter()
        .flat_map(|line| line.as_array().unwrap().iter())
        .map(|p| (p[0].as_f64().unwrap(), p[1].as_f64().unwrap()))
        .collect()
}

fn state(addr: std::net::SocketAddr) -> Value {
    let (status, body) = get(addr, "/state.json");
    assert_eq!(status, "HTTP/1.1 200 OK");
    serde_json::from_slice(&body).unwrap()
}

#[test]
fn the_floor_grid_reprojects_onto_the_true_floor_before_and_after_a_knock() {
    let config = Scene::preset_config("knocked").unwrap();
    let view = config.view.clone().unwrap();
    let knock = view.knock.unwrap().frame;
    let scene = Scene::new(config).unwrap();
    let size = FrameSize::new(scene.width_px(), scene.height_px()).unwrap();

    // The camera as glint fits it to the first frame's six markers.
    let (map, fit) = fit_first_frame(&scene, &view);

    let mut pipeline = Pipeline::new(size, PipelineConfig::default())
        .unwrap()
        .with_floor(FloorStage::from_camera(fit.camera, FloorUnit::Cm))
        .with_recheck(
            MarkerRecheck::new(size, Dictionary::Aruco6x6_250, &map, fit.rms_residual_px).unwrap(),
        );
    let mut preview = PreviewSink::start("127.0.0.1:0".parse().unwrap(), size, Vec::new())
        .unwrap()
        .with_floor_camera(fit.camera);
    let addr = preview.local_addr();
    let mut feed = |i: usize| {
        let bytes = rendered(&scene, i);
        let frame = Frame::new_checked(&bytes, size, size.row_bytes()).unwrap();
        let meta = meta_at_30_fps(i);
        let report = pipeline.process(&frame, meta);
        preview.write_frame(&frame, &report).unwrap();
    };

    // Watched from now on: the next frame is copied.
    state(addr);
    let before_frame = knock - 10;
    feed(before_frame);
    let before = state(addr);
    assert_eq!(before["index"], before_frame as u64);
    let before = grid_points(&before);
    assert!(before.len() > 500, "{} grid points", before.len());
    // p95 and worst.
    let off = |points: &[(f64, f64)], frame: usize| {
        let v: Vec<f64> = points
            .iter()
            .map(|&p| off_grid_px(&view, frame, p))
            .collect();
        (common::quantile(&v, 0.95), common::quantile(&v, 1.0))
    };
    let check = |label: &str, (p95, max): (f64, f64), count: usize| {
        eprintln!("{label}: {count} points, p95 {p95:.3} px off, at worst {max:.3} px");
        assert!(
            p95 <= P95_OFF_PX && max <= MAX_OFF_PX,
            "{label}: {p95:.3}, {max:.3} px"
        );
    };
    check("before the knock", off(&before, before_frame), before.len());

    // The knock, the re-check that finds it (a check every period from the first frame fed),
    // and its verdict a lag later.
    let period = glint::geometry::recheck::RECHECK_PERIOD_FRAMES as usize;
    let lag = glint::geometry::recheck::VERDICT_LAG_FRAMES as usize;
    let checked = before_frame + period * (knock - before_frame).div_ceil(period);
    for i in knock..=checked + lag {
        feed(i);
    }
    std::thread::sleep(glint::sink::preview::COPY_PERIOD + Duration::from_millis(50));
    let after_frame = checked + lag + 1;
    feed(after_frame);
    let after = state(addr);
    assert_eq!(after["index"], after_frame as u64);
    let after = grid_points(&after);
    // The grid drawn before the knock no longer fits the picture: the test can tell.
    let (stale, _) = off(&before, after_frame);
    eprintln!("the grid from before the knock, after it: p95 {stale:.3} px off");
    assert!(
        stale > 4.0 * P95_OFF_PX,
        "the knock moves the grid: {stale:.3} px"
    );
    check("after the knock", off(&after, after_frame), after.len());
}
