//! The re-check of the calibration's markers while tracking (`glint::geometry::recheck`), on
//! 640×480 frames of the six-marker map seen through the mild lens.
//!
//! On the tracking thread: a frame between checks, and the copy of a frame's luma that a check
//! hands to the worker thread (once every period). On the worker (`judge::Checker`, the same
//! code the worker runs): a check that confirms the pose with steady markers (no corner
//! refined), one whose every marker is refined (the first check, or after a refit), one that
//! refits the pose after a 0.8° knock, and one after a knock that also moved one marker on the
//! floor (the pose refitted, the moved marker found and left out). The whole-frame detection
//! of the six markers is measured for scale.

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, BatchSize, Criterion};
use glint::detect::aruco::Dictionary;
use glint::frame::{Frame, FrameSize};
use glint::geometry::recheck::judge::{Checker, Decision};
use glint::geometry::recheck::{copy_luma, luma_bytes, MarkerRecheck, RECHECK_PERIOD_FRAMES};
use glint::geometry::{fit_camera, FloorStage, FloorUnit, LensChoice, MarkerPlacement};
use glint_tools::scene::{Bump, Scene};

fn bench(c: &mut Criterion) {
    let mut config = Scene::preset_config("knocked").expect("preset");
    let view = config.view.clone().expect("a view");
    let knock = view.knock.expect("a knock").frame;
    // The second marker is kicked 3 cm at the knock (seen only in the frame rendered for it).
    config.view.as_mut().expect("a view").bump = Some(Bump {
        frame: knock + 1,
        marker: 1,
        dx_cm: 3.0,
        dy_cm: 0.0,
        turn_deg: 0.0,
    });
    let scene = Scene::new(config).expect("scene");
    let size = FrameSize::new(640, 480).expect("size");
    let render = |i: usize| {
        let mut bytes = vec![0u8; scene.frame_len_bytes()];
        scene.render(i, &mut bytes).expect("render");
        bytes
    };
    let (before, after, bumped) = (render(knock - 15), render(knock), render(knock + 1));
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
    let camera = fit.camera;
    let residual_px = fit.rms_residual_px;

    // The tracking thread's share.
    let mut recheck =
        MarkerRecheck::new(size, Dictionary::Aruco6x6_250, &map, residual_px).expect("thread");
    let mut stage = FloorStage::from_camera(camera, FloorUnit::Cm);
    recheck.check(&frame, 0, 0, &mut stage);
    c.bench_function("recheck: tracking thread, a frame between checks", |b| {
        b.iter(|| {
            black_box(recheck.check(
                black_box(&frame),
                RECHECK_PERIOD_FRAMES - 1,
                33_333,
                &mut stage,
            ))
        })
    });
    let mut copy = vec![0u8; luma_bytes(size)];
    c.bench_function(
        "recheck: tracking thread, a check's copy of the luma",
        |b| b.iter(|| black_box(copy_luma(black_box(&frame), &mut copy))),
    );

    // The worker's check.
    let grey = |luma: &[u8]| {
        let mut out = vec![0u8; luma_bytes(size)];
        copy_luma(
            &Frame::new_checked(luma, size, size.row_bytes()).expect("frame"),
            &mut out,
        );
        out
    };
    let (before, after, bumped) = (grey(&before), grey(&after), grey(&bumped));
    fn as_frame(luma: &[u8]) -> Frame<'_> {
        let size = FrameSize::new(640, 480).expect("size");
        Frame::new_checked_as(luma, size, size.width(), glint::frame::PixelFormat::Grey)
            .expect("frame")
    }
    let new = || Checker::new(size, Dictionary::Aruco6x6_250, &map, residual_px);
    let mut checker = new();
    checker.check(&as_frame(&before), &camera);
    c.bench_function(
        "recheck (worker): a check that confirms the pose, markers steady",
        |b| {
            b.iter(|| {
                let v = checker.check(black_box(&as_frame(&before)), &camera);
                assert_eq!(v.decision, Decision::Confirmed);
                assert_eq!(v.residual_px, None, "no marker refined");
            })
        },
    );
    let batched = |label: &str, luma: &[u8], c: &mut Criterion, refit: bool| {
        c.bench_function(label, |b| {
            b.iter_batched(
                new,
                |mut checker| {
                    let v = checker.check(black_box(&as_frame(luma)), &camera);
                    assert_eq!(matches!(v.decision, Decision::Refit { .. }), refit);
                    v
                },
                BatchSize::LargeInput,
            )
        });
    };
    batched(
        "recheck (worker): a check that confirms the pose, every marker refined",
        &before,
        c,
        false,
    );
    batched(
        "recheck (worker): a check after a knock, pose refit",
        &after,
        c,
        true,
    );
    batched(
        "recheck (worker): a check after a knock that also moved a marker",
        &bumped,
        c,
        true,
    );
    c.bench_function("recheck: whole-frame marker detection", |b| {
        b.iter(|| black_box(detector.detect(black_box(&frame), None).map(|m| m.len())))
    });
}

criterion_group!(benches, bench);
criterion_main!(benches);
