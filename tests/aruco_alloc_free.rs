//! Marker detection, with refinement and a region of interest, allocates nothing once the
//! detector is built (the memory model in `lib.rs`).

mod common;

use common::alloc::{allocations_during, Counting};

use glint::detect::aruco::{Detector, DetectorConfig, Dictionary, Roi};
use glint::frame::{Frame, FrameSize};
use glint::geometry::{calibrate, Point};
use glint_tools::markers::{reference_camera, Floor, MarkerScene, PlacedMarker};

#[global_allocator]
static GLOBAL: Counting = Counting;

#[test]
fn detection_and_calibration_allocate_nothing() {
    let placed = PlacedMarker {
        dictionary: Dictionary::Aruco6x6_250,
        id: 23,
        size_cm: 20.0,
        origin_cm: Point::new(0.0, 0.0),
        rotation_deg: 0.0,
    };
    let second = PlacedMarker {
        id: 101,
        origin_cm: Point::new(55.0, 45.0),
        rotation_deg: 0.0,
        ..placed
    };
    let mut scene = MarkerScene::new(reference_camera(), vec![placed, second]);
    scene.floor = Floor::Textured { seed: 3 };
    let bytes = scene.render_yuyv();
    let size = FrameSize::new(640, 480).unwrap();
    let frame = Frame::new_checked(&bytes, size, 1280).unwrap();
    let mut detector = Detector::new(size, DetectorConfig::new(Dictionary::Aruco6x6_250));
    // Both markers: the least-squares fit (eigen-decomposition, Gauss-Newton) runs too.
    let placements = [placed.placement(), second.placement()];
    let roi = Roi {
        x_px: 60,
        y_px: 60,
        width_px: 520,
        height_px: 300,
    };

    let mut found = 0;
    let allocations = allocations_during(|| {
        for region in [None, Some(roi), None] {
            let markers = detector.detect(&frame, region).unwrap();
            found += markers.len();
            let calibration = calibrate(markers, &placements).unwrap();
            assert!(calibration.rms_residual_px.is_finite());
        }
    });
    assert_eq!(found, 6);
    assert_eq!(allocations, 0, "allocations during detection");
}

#[path = "aruco_frames/mod.rs"]
mod aruco_frames;

#[test]
fn a_frame_that_hits_the_caps_allocates_nothing() {
    // A thousand squares fill the candidate heap (the shortest give way) and the read cap.
    let mut luma = aruco_frames::squares(640, 480, 10, 16);
    aruco_frames::paste_marker(&mut luma, 640, Dictionary::Aruco6x6_250, 98, (470, 330), 10);
    let bytes = aruco_frames::to_yuyv(&luma);
    let size = FrameSize::new(640, 480).unwrap();
    let frame = Frame::new_checked(&bytes, size, 1280).unwrap();
    let mut detector = Detector::new(size, DetectorConfig::new(Dictionary::Aruco6x6_250));
    let mut found = 0;
    let allocations = allocations_during(|| {
        for _ in 0..2 {
            found += detector.detect(&frame, None).unwrap().len();
        }
    });
    assert!(detector.stats().capped);
    assert_eq!(found, 2);
    assert_eq!(allocations, 0, "allocations during capped detection");
}
