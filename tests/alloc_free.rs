//! The per-frame path allocates nothing: a counting global allocator watches a whole replay
//! (dump source → detection → JSON lines sink) of rendered scenes after start-up.

mod common;

use common::alloc::{allocations_during, Counting};
use std::io::{self, BufWriter, Cursor};

use glint::frame::FrameSize;
use glint::pipeline::{self, Pipeline, PipelineConfig};
use glint::sink::{CsvSink, JsonLinesSink};
use glint::source::dump::DumpSource;
use glint_tools::scene::Scene;

#[global_allocator]
static GLOBAL: Counting = Counting;

/// Rendered frames of several scenes at 640×480, blank frames between them.
fn frames() -> (FrameSize, Vec<u8>, usize) {
    let mut bytes = Vec::new();
    let mut count = 0;
    for name in ["glare", "fast-line", "circles", "leave-occlude"] {
        let scene = Scene::preset(name).unwrap();
        assert_eq!((scene.width_px(), scene.height_px()), (640, 480));
        let (dump, truths) = scene.render_dump();
        bytes.extend(dump);
        count += truths.len();
    }
    let size = FrameSize::new(640, 480).unwrap();
    bytes.extend(vec![255u8; size.frame_bytes()]);
    bytes.extend(vec![0u8; size.frame_bytes()]);
    (size, bytes, count + 2)
}

#[test]
fn replay_allocates_nothing_per_frame() {
    let (size, bytes, count) = frames();
    assert!(count >= 100, "at least 100 frames, got {count}");

    // Start-up allocations happen here, outside the count.
    let mut source = DumpSource::new(Cursor::new(&bytes), size, 30.0);
    let mut pipeline = Pipeline::new(size, PipelineConfig::default()).unwrap();
    let mut sink = JsonLinesSink::new(BufWriter::with_capacity(64 * 1024, io::sink()), false);
    let mut summary = None;
    let allocations = allocations_during(|| {
        let (s, result) = pipeline::run(&mut source, &mut pipeline, &mut sink);
        result.unwrap();
        summary = Some(s);
    });
    let summary = summary.unwrap();
    assert_eq!(summary.frames, count as u64);
    assert!(
        summary.found > summary.frames / 2,
        "the scenes were tracked: {summary:?}"
    );
    assert_eq!(allocations, 0, "allocations during {count} frames");

    // The CSV sink and the seed's morphological skeleton keep the promise too.
    let config = PipelineConfig {
        detector: glint::detect::DetectorConfig {
            skeleton: glint::detect::skeleton::SkeletonMethod::Morphological,
            erosions: 1,
            ..Default::default()
        },
        tracker: glint::track::TrackerConfig {
            exposure_us: Some(25_000),
        },
    };
    let mut source = DumpSource::new(Cursor::new(&bytes), size, 30.0);
    let mut pipeline = Pipeline::new(size, config).unwrap();
    let mut sink = CsvSink::new(BufWriter::with_capacity(64 * 1024, io::sink()), false);
    let allocations = allocations_during(|| {
        pipeline::run(&mut source, &mut pipeline, &mut sink)
            .1
            .unwrap();
    });
    assert_eq!(allocations, 0);

    // So does the background-difference detector, learning included.
    let config = PipelineConfig {
        detector: glint::detect::DetectorConfig {
            method: glint::detect::MaskMethod::BackgroundDifference {
                diff_luma: 60,
                frames: 9,
            },
            ..Default::default()
        },
        ..Default::default()
    };
    let mut source = DumpSource::new(Cursor::new(&bytes), size, 30.0);
    let mut pipeline = Pipeline::new(size, config).unwrap();
    let mut sink = JsonLinesSink::new(BufWriter::with_capacity(64 * 1024, io::sink()), false);
    let allocations = allocations_during(|| {
        let (s, result) = pipeline::run(&mut source, &mut pipeline, &mut sink);
        result.unwrap();
        assert!(s.found > s.frames / 2, "{s:?}");
    });
    assert_eq!(allocations, 0);
}
