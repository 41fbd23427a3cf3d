//! Hostile input never panics the detector or the homography: random frames, sizes, regions
//! and point sets either work or give a typed error.

use glint::detect::aruco::{Detector, DetectorConfig, Dictionary, Roi};
use glint::frame::{Frame, FrameSize};
use glint::geometry::{FloorMapping, Homography, Point};
use proptest::prelude::*;

/// A frame of random blocks: large dark and light areas make contours, unlike pure noise.
fn blocky_luma(seed: &[u8], w: usize, h: usize, block: usize) -> Vec<u8> {
    (0..w * h)
        .map(|i| {
            let (x, y) = (i % w / block, i / w / block);
            let k = (x * 31 + y * 17) % seed.len().max(1);
            seed.get(k).copied().unwrap_or(0)
        })
        .collect()
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn random_frames_and_regions_never_panic(
        half_w in 1usize..60,
        h in 1usize..90,
        block in 1usize..9,
        seed in proptest::collection::vec(any::<u8>(), 1..64),
        roi in (0usize..140, 0usize..100, 0usize..140, 0usize..100),
        dict in 0usize..5,
    ) {
        let w = 2 * half_w;
        let luma = blocky_luma(&seed, w, h, block);
        let bytes: Vec<u8> = luma.iter().flat_map(|&l| [l, 128]).collect();
        let size = FrameSize::new(w as u32, h as u32).unwrap();
        let frame = Frame::new_checked(&bytes, size, 2 * w).unwrap();
        let mut detector = Detector::new(size, DetectorConfig::new(Dictionary::ALL[dict]));
        let _ = detector.detect(&frame, None).unwrap();
        let roi = Roi { x_px: roi.0, y_px: roi.1, width_px: roi.2, height_px: roi.3 };
        if let Ok(markers) = detector.detect(&frame, Some(roi)) {
            for m in markers {
                prop_assert!(m.corners.iter().all(|p| p.x.is_finite() && p.y.is_finite()));
            }
        }
    }

    #[test]
    fn random_point_sets_fit_or_refuse(
        coords in proptest::collection::vec(-1e3f64..1e3, 16),
        n in 4usize..8,
    ) {
        let pts: Vec<Point> = coords.chunks(2).map(|c| Point::new(c[0], c[1])).collect();
        let (src, dst) = (&pts[..n.min(4)], &pts[4..4 + n.min(4)]);
        if let Ok(h) = Homography::fit(src, dst) {
            for (s, d) in src.iter().zip(dst) {
                if let Ok(q) = h.apply(s) {
                    prop_assert!((q - d).norm() <= 1e-4 * (1.0 + d.coords.norm()));
                }
            }
        }
        if let Ok(map) = FloorMapping::fit(src, dst) {
            for p in &pts {
                let _ = map.screen_to_floor(p);
                let _ = map.floor_to_screen(p);
            }
        }
    }
}

#[test]
fn a_frame_of_another_size_is_refused() {
    let size = FrameSize::new(64, 48).unwrap();
    let other = FrameSize::new(32, 48).unwrap();
    let bytes = vec![0u8; other.frame_bytes()];
    let frame = Frame::new_checked(&bytes, other, 64).unwrap();
    let mut detector = Detector::new(size, DetectorConfig::new(Dictionary::Aruco6x6_250));
    let err = detector.detect(&frame, None).unwrap_err();
    assert_eq!(
        err.to_string(),
        "frame is 32x48 but the marker detector was built for 64x48"
    );
}
