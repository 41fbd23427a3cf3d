//! The re-check of the calibration's markers while tracking (`glint::geometry::recheck`), on
//! 640×480 frames of the six-marker map seen through the mild lens: a frame between checks, one
//! frame's search (the region around one marker, steady or with its corners refined; or one band
//! of rows of the whole-frame search made after a check that found no marker), and a whole check
//! (the six searches in a row, which in use fall on six frames) that confirms the pose (after
//! the first, with no corner refined) or, after a 0.8° knock, refits it (plus the pose-only
//! bundle adjustment). The whole-frame detection each check made before the
//! work was spread is measured for comparison.

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion};
use glint::detect::aruco::Dictionary;
use glint::frame::{Frame, FrameSize};
use glint::geometry::recheck::{MarkerRecheck, RECHECK_PERIOD_FRAMES};
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

    let period = RECHECK_PERIOD_FRAMES;
    let mut recheck = new();
    let mut floor_stage = stage;
    c.bench_function("recheck: frame between checks", |b| {
        b.iter(|| black_box(recheck.check(black_box(&frame), period - 1, 33_333, &mut floor_stage)))
    });
    // A steady marker's search: a whole check first, whose refined corners confirm the pose and
    // leave each marker's unrefined centre known; then one marker's region, again and again.
    let mut recheck = new();
    let mut s = stage;
    for i in 0..map.len() as u64 {
        recheck.check(&frame, i, 0, &mut s);
    }
    // Frame `period` is the first of a period, whose searches start afresh: each call searches
    // the marker again.
    c.bench_function(
        "recheck: one steady marker's region (one of six frames)",
        |b| {
            b.iter(|| {
                let mut s = stage;
                black_box(recheck.check(black_box(&frame), period, 0, &mut s))
            })
        },
    );
    // A marker whose corners are refined (the first check, or one that looks moved).
    let mut recheck = new();
    c.bench_function("recheck: one marker's region, corners refined", |b| {
        b.iter(|| {
            let mut s = stage;
            black_box(recheck.check(black_box(&frame), period, 0, &mut s))
        })
    });
    // After a check that found no marker (a black picture), the whole frame band by band.
    let black = vec![0u8; scene.frame_len_bytes()];
    let black = Frame::new_checked(&black, size, size.row_bytes()).expect("frame");
    let mut recheck = new();
    let mut s = stage;
    for i in 0..map.len() as u64 {
        recheck.check(&black, i, 0, &mut s);
    }
    c.bench_function("recheck: one band of the whole-frame search", |b| {
        b.iter(|| black_box(recheck.check(black_box(&frame), period + 1, 0, &mut s)))
    });
    // A whole check, its six searches in a row (in use, one per frame).
    let mut recheck = new();
    c.bench_function(
        "recheck: a whole check that confirms the pose (6 regions)",
        |b| {
            b.iter(|| {
                let mut s = stage;
                for i in 0..map.len() as u64 {
                    black_box(recheck.check(black_box(&frame), i, 0, &mut s));
                }
            })
        },
    );
    let knocked = Frame::new_checked(&after, size, size.row_bytes()).expect("frame");
    let mut recheck = new();
    c.bench_function("recheck: a whole check after a knock, pose refit", |b| {
        b.iter(|| {
            let mut s = stage;
            for i in 0..map.len() as u64 {
                black_box(recheck.check(black_box(&knocked), i, 0, &mut s));
            }
            assert_ne!(s, stage, "the pose is refitted");
        })
    });
    // For comparison: the whole-frame detection each check made before it was spread.
    c.bench_function("recheck: whole-frame marker detection", |b| {
        b.iter(|| black_box(detector.detect(black_box(&frame), None).map(|m| m.len())))
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
