//! The marker detector's cost caps (issue 13): on frames built to make contour tracing and
//! candidate decoding explode (a spiral, speckle, a checkerboard, a field of squares), the
//! detector stops at its caps and says so; a real marker placed among a thousand squares is
//! still found, and an ordinary frame does not hit the caps. Time is measured in
//! `benches/aruco.rs` and `examples/aruco_cost.rs`, never here.

mod aruco_frames;
mod common;

use glint::detect::aruco::{Detector, DetectorConfig, Dictionary, MAX_DECODES};
use glint::frame::{Frame, FrameSize};

const W: usize = 640;
const H: usize = 480;

fn detect(luma: &[u8]) -> (Vec<u16>, glint::detect::aruco::DetectionStats) {
    let bytes = aruco_frames::to_yuyv(luma);
    let size = FrameSize::new(W as u32, H as u32).unwrap();
    let frame = Frame::new_checked(&bytes, size, 2 * W).unwrap();
    let mut detector = Detector::new(size, DetectorConfig::new(Dictionary::Aruco6x6_250));
    let mut ids: Vec<u16> = detector
        .detect(&frame, None)
        .unwrap()
        .iter()
        .map(|m| m.id)
        .collect();
    ids.sort_unstable();
    (ids, detector.stats())
}

#[test]
fn adversarial_frames_hit_the_caps_and_say_so() {
    let budget = DetectorConfig::new(Dictionary::Aruco6x6_250).max_trace_steps;
    for (name, luma) in [
        ("spiral", aruco_frames::spiral(W, H, 6.0)),
        ("speckle", aruco_frames::speckle(W, H, 9)),
        ("checkerboard", aruco_frames::checkerboard(W, H, 8)),
    ] {
        let (ids, stats) = detect(&luma);
        assert!(ids.is_empty(), "{name}: {ids:?}");
        assert!(stats.capped, "{name}: {stats:?}");
        // Tracing stopped at its budget.
        assert_eq!(stats.trace_steps as usize, budget, "{name}");
    }
    // A thousand squares: too many candidates to read them all.
    let (ids, stats) = detect(&aruco_frames::squares(W, H, 10, 16));
    assert!(ids.is_empty(), "{ids:?}");
    assert!(
        stats.capped && stats.read as usize == MAX_DECODES,
        "{stats:?}"
    );
}

#[test]
fn a_real_marker_among_a_thousand_squares_is_still_found() {
    let mut luma = aruco_frames::squares(W, H, 10, 16);
    // Bottom right, where a raster scan reaches it last; 10 px cells, 100 px across.
    aruco_frames::paste_marker(&mut luma, W, Dictionary::Aruco6x6_250, 98, (470, 330), 10);
    let (ids, stats) = detect(&luma);
    assert!(stats.capped, "{stats:?}");
    assert_eq!(ids, [98]);
}

#[test]
fn an_ordinary_frame_does_not_hit_the_caps() {
    let mut luma = vec![200u8; W * H];
    aruco_frames::paste_marker(&mut luma, W, Dictionary::Aruco6x6_250, 7, (100, 80), 8);
    aruco_frames::paste_marker(&mut luma, W, Dictionary::Aruco6x6_250, 211, (400, 260), 5);
    let (ids, stats) = detect(&luma);
    assert!(!stats.capped, "{stats:?}");
    assert_eq!(ids, [7, 211]);
}

/// A dump of two frames with marker 98 bottom right: among a thousand squares, then alone.
fn busy_then_plain_dump(dir: &std::path::Path) -> std::path::PathBuf {
    let mut busy = aruco_frames::squares(W, H, 10, 16);
    aruco_frames::paste_marker(&mut busy, W, Dictionary::Aruco6x6_250, 98, (470, 330), 10);
    let mut plain = vec![200u8; W * H];
    aruco_frames::paste_marker(&mut plain, W, Dictionary::Aruco6x6_250, 98, (470, 330), 10);
    let dump = dir.join("busy.yuv");
    let mut bytes = aruco_frames::to_yuyv(&busy);
    bytes.extend(aruco_frames::to_yuyv(&plain));
    std::fs::write(&dump, bytes).unwrap();
    dump
}

#[test]
fn glint_track_reports_a_capped_frame_in_its_json() {
    let dir = tempfile::tempdir().unwrap();
    let dump = busy_then_plain_dump(dir.path());
    let out = common::glint()
        .args(["track", "--input"])
        .arg(&dump)
        .args(["--size", "640x480", "--detector", "aruco", "--marker", "98"])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let lines = common::parse_jsonl(&out.stdout);
    assert_eq!(lines.len(), 2, "{lines:?}");
    assert_eq!(lines[0]["markers_capped"], true, "{}", lines[0]);
    assert!(lines[1].get("markers_capped").is_none(), "{}", lines[1]);
    for line in &lines {
        assert_eq!(line["found"], true, "{line}");
    }
}

#[test]
fn glint_calibrate_logs_capped_frames() {
    let dir = tempfile::tempdir().unwrap();
    let dump = busy_then_plain_dump(dir.path());
    let out = common::glint()
        .args(["calibrate", "--input"])
        .arg(&dump)
        .args([
            "--size", "640x480", "--marker", "98:20", "--lens", "ideal", "--out",
        ])
        .arg(dir.path().join("calib.toml"))
        .output()
        .unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{stderr}");
    assert!(
        stderr.contains("marker detection hit its cost cap in 1 of 2 frames"),
        "{stderr}"
    );
}
