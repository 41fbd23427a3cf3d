//! The re-check of the calibration's markers while tracking (`glint::geometry::recheck`), on
//! 640×480 frames of the six-marker map seen through the mild lens: a frame between checks,
//! a check that confirms the pose (detection of six markers), and a check after a 0.8° knock
//! that refits the pose (detection plus the pose-only bundle adjustment). Averaged over the 15
//! frames of a re-check period, the cost per frame is (check + 14 × between) / 15.

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion};
use glint::detect::aruco::Dictionary;
use glint::frame::{Frame, FrameSize};
use glint::geometry::recheck::MarkerRecheck;
use glint::geometry::{fit_camera, FloorStage, FloorUnit, LensChoice, MarkerPlacement};
use glint_tools::scene::Scene;

fn bench(c: &mut Criterion) {
    let config = Scene::preset_config("knocked").expect("preset");
    let view = config.view.clone().expect("a view");
    let knock = view.knock.expect("a knock").frame;
    let scene = Scene::new(config).expect("scene");
    let size = FrameSize::new(640, 480).expect("size");
    let render = |i: usize| {
        let mut bytes = vec![0u8; scene.frame_len_bytes()];
        scene.render(i, &mut bytes).expect("render");
        bytes
    };
    let (before, after) = (render(knock - 15), render(knock));
    let map: Vec<MarkerPlacement> = view.markers.iter().map(|m| m.placement()).collect();
    // The camera as glint calibrates it: lens and pose fitted to the first frame's markers.
    let frame = Frame::new_checked(&before, size, size.row_bytes()).expect("frame");
    let mut detector = glint::detect::aruco::Detector::new(
        size,
        glint::detect::aruco::DetectorConfig::new(Dictionary::Aruco6x6_250),
    );
    let seen = detector.detect(&frame, None).expect("detect").to_vec();
    let (mut floor, mut screen) = (Vec::new(), Vec::new());
    for p in &map {
        if let Some(m) = seen.iter().find(|m| m.id == p.id) {
            floor.extend(p.corners());
            screen.extend(m.corners);
        }
    }
    assert_eq!(floor.len(), 24, "all six markers seen");
    let fit = fit_camera(&floor, &screen, size, LensChoice::Fit).expect("fit");
    let stage = FloorStage::from_camera(fit.camera, FloorUnit::Cm);
    let new = || MarkerRecheck::new(size, Dictionary::Aruco6x6_250, &map, fit.rms_residual_px);

    let mut recheck = new();
    let mut floor_stage = stage;
    c.bench_function("recheck: frame between checks", |b| {
        b.iter(|| black_box(recheck.check(black_box(&frame), 1, 33_333, &mut floor_stage)))
    });
    let mut recheck = new();
    c.bench_function("recheck: check that confirms the pose (6 markers)", |b| {
        b.iter(|| {
            let mut s = stage;
            black_box(recheck.check(black_box(&frame), 0, 0, &mut s))
        })
    });
    let knocked = Frame::new_checked(&after, size, size.row_bytes()).expect("frame");
    let mut recheck = new();
    c.bench_function("recheck: check after a knock, pose refit", |b| {
        b.iter(|| {
            let mut s = stage;
            let status = recheck.check(black_box(&knocked), 0, 0, &mut s);
            assert_ne!(s, stage, "the pose is refitted");
            black_box(status)
        })
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
