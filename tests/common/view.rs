//! What the tests that start from a calibrated camera share: a rendered frame, the camera
//! glint fits to a rendered view's first frame, and each frame's capture metadata at the
//! scenes' 30 fps.

use glint::detect::aruco::{Detector, DetectorConfig, Dictionary};
use glint::frame::{Frame, FrameSize};
use glint::geometry::{fit_camera, CameraFit, LensChoice, MarkerPlacement};
use glint::source::FrameMeta;
use glint_tools::scene::{Scene, View};

/// Frame `index` of `scene`, rendered into a buffer of its own.
pub fn rendered(scene: &Scene, index: usize) -> Vec<u8> {
    let mut bytes = vec![0u8; scene.frame_len_bytes()];
    scene.render(index, &mut bytes).unwrap();
    bytes
}

/// The map of `view`'s markers, and the camera (lens and pose) glint fits to the corners it
/// detects in frame 0 of `scene`, where every marker of the map must be seen.
pub fn fit_first_frame(scene: &Scene, view: &View) -> (Vec<MarkerPlacement>, CameraFit) {
    let size = FrameSize::new(scene.width_px(), scene.height_px()).unwrap();
    let bytes = rendered(scene, 0);
    let frame = Frame::new_checked(&bytes, size, size.row_bytes()).unwrap();
    let map: Vec<MarkerPlacement> = view.markers.iter().map(|m| m.placement()).collect();
    let mut detector = Detector::new(size, DetectorConfig::new(Dictionary::Aruco6x6_250));
    let seen = detector.detect(&frame, None).unwrap().to_vec();
    let (mut floor, mut screen) = (Vec::new(), Vec::new());
    for p in &map {
        let m = seen
            .iter()
            .find(|m| m.id == p.id)
            .unwrap_or_else(|| panic!("marker {} seen in frame 0", p.id));
        floor.extend(p.corners());
        screen.extend(m.corners);
    }
    let fit = fit_camera(&floor, &screen, size, LensChoice::Fit).unwrap();
    (map, fit)
}

/// Frame `index`'s metadata at 30 fps, with nothing dropped.
pub fn meta_at_30_fps(index: usize) -> FrameMeta {
    let t_us = index as u64 * 33_333;
    FrameMeta {
        index: index as u64,
        sequence: index as u64,
        dropped: 0,
        timestamp_us: t_us,
        monotonic_us: t_us,
    }
}
