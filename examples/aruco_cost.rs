//! The marker detector's time per 640×480 frame on the adversarial frames of `benches/aruco.rs`
//! (spiral, speckle, blotches, checkerboard, a field of squares) and a textured floor with one marker,
//! measured so that a loaded machine still gives a figure: beside the wall-clock median it
//! reports the CPU time the thread actually ran (Linux's `/proc/thread-self/schedstat`), which
//! other processes do not inflate (only share caches with). Also prints whether the detector's
//! cost cap was hit.
//!
//! `cargo run --release --example aruco_cost [FRAME]` (FRAME: only frames whose name contains it)

use std::time::Instant;

use glint::detect::aruco::{Detector, DetectorConfig, Dictionary};
use glint::frame::{Frame, FrameSize};
use glint::geometry::Point;
use glint_tools::markers::{reference_camera, Floor, MarkerScene, PlacedMarker};

#[path = "../tests/aruco_frames/mod.rs"]
mod aruco_frames;

const BATCHES: usize = 40;
const PER_BATCH: usize = 5;

/// Nanoseconds this thread has run on a CPU, if the kernel says.
fn cpu_ns() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/thread-self/schedstat").ok()?;
    text.split_whitespace().next()?.parse().ok()
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let (w, h) = (640, 480);
    let size = FrameSize::new(w as u32, h as u32)?;
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
    let frames = [
        ("textured floor", scene.render_yuyv()),
        (
            "spiral",
            aruco_frames::to_yuyv(&aruco_frames::spiral(w, h, 6.0)),
        ),
        (
            "speckle",
            aruco_frames::to_yuyv(&aruco_frames::speckle(w, h, 9)),
        ),
        (
            "blotches",
            aruco_frames::to_yuyv(&aruco_frames::blotches(w, h, 3, 9)),
        ),
        (
            "checkerboard",
            aruco_frames::to_yuyv(&aruco_frames::checkerboard(w, h, 8)),
        ),
        (
            "squares",
            aruco_frames::to_yuyv(&aruco_frames::squares(w, h, 10, 16)),
        ),
    ];
    let mut detector = Detector::new(size, DetectorConfig::new(Dictionary::Aruco6x6_250));
    println!("| frame | CPU time, ms | wall median, ms | markers | capped |");
    println!("| --- | --- | --- | --- | --- |");
    let only = std::env::args().nth(1).unwrap_or_default();
    for (name, bytes) in frames.iter().filter(|(name, _)| name.contains(&only)) {
        let frame = Frame::new_checked(bytes, size, 2 * w)?;
        let cpu_start = cpu_ns();
        let mut batches_ms: Vec<f64> = (0..BATCHES)
            .map(|_| {
                let t = Instant::now();
                for _ in 0..PER_BATCH {
                    std::hint::black_box(detector.detect(&frame, None).map(|m| m.len()).ok());
                }
                t.elapsed().as_secs_f64() * 1e3 / PER_BATCH as f64
            })
            .collect();
        let cpu_ms = match (cpu_start, cpu_ns()) {
            (Some(a), Some(b)) => format!(
                "{:.2}",
                (b - a) as f64 * 1e-6 / (BATCHES * PER_BATCH) as f64
            ),
            _ => "n/a".to_owned(),
        };
        batches_ms.sort_by(f64::total_cmp);
        let markers = detector.detect(&frame, None)?.len();
        println!(
            "| {name} | {cpu_ms} | {:.2} | {markers} | {} |",
            batches_ms[BATCHES / 2],
            detector.stats().capped
        );
    }
    Ok(())
}
