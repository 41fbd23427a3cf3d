//! Marker detection plus sub-pixel refinement on a 640×480 frame of a textured floor (tiles,
//! grout, specks, mottling) with one 20 cm marker about 1.5 m away; whole frame and a region of
//! interest around the marker, as a periodic re-calibration would use. Then the worst cases
//! (issue 13): adversarial 640×480 frames (a spiral, speckle, blotches, a checkerboard, a
//! field of squares) whose cost the detector's caps bound.

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion};
use glint::detect::aruco::{Detector, DetectorConfig, Dictionary, Roi};
use glint::frame::{Frame, FrameSize};
use glint::geometry::Point;
use glint_tools::markers::{reference_camera, Floor, MarkerScene, PlacedMarker};

#[path = "../tests/aruco_frames/mod.rs"]
mod aruco_frames;

fn bench(c: &mut Criterion) {
    let mut scene = MarkerScene::new(
        reference_camera(),
        vec![PlacedMarker {
            dictionary: Dictionary::Aruco6x6_250,
            id: 23,
            size_cm: 20.0,
            origin_cm: Point::new(0.0, 0.0),
            rotation_deg: 0.0,
        }],
    );
    scene.floor = Floor::Textured { seed: 7 };
    let bytes = scene.render_yuyv();
    let size = FrameSize::new(640, 480).expect("valid size");
    let frame = Frame::new_checked(&bytes, size, 1280).expect("valid frame");
    let mut detector = Detector::new(size, DetectorConfig::new(Dictionary::Aruco6x6_250));
    assert_eq!(
        detector.detect(&frame, None).map(|m| m.len()),
        Ok(1),
        "the benchmark scene must contain exactly its one marker"
    );
    c.bench_function("aruco detect+refine 640x480 textured floor", |b| {
        b.iter(|| black_box(detector.detect(black_box(&frame), None).map(|m| m.len())))
    });
    let roi = Roi {
        x_px: 240,
        y_px: 130,
        width_px: 160,
        height_px: 140,
    };
    c.bench_function("aruco detect+refine 160x140 region of interest", |b| {
        b.iter(|| {
            black_box(
                detector
                    .detect(black_box(&frame), Some(roi))
                    .map(|m| m.len()),
            )
        })
    });

    let (w, h) = (640, 480);
    let adversarial = [
        ("spiral", aruco_frames::spiral(w, h, 6.0)),
        ("speckle", aruco_frames::speckle(w, h, 9)),
        ("blotches", aruco_frames::blotches(w, h, 3, 9)),
        ("checkerboard", aruco_frames::checkerboard(w, h, 8)),
        ("squares", aruco_frames::squares(w, h, 10, 16)),
    ];
    for (name, luma) in adversarial {
        let bytes = aruco_frames::to_yuyv(&luma);
        let frame = Frame::new_checked(&bytes, size, 2 * w).expect("valid frame");
        c.bench_function(&format!("aruco worst case 640x480 {name}"), |b| {
            b.iter(|| black_box(detector.detect(black_box(&frame), None).map(|m| m.len())))
        });
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
