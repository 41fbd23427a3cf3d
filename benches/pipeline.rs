//! Per-stage and whole-path timings of detection on rendered frames, at 640×480 and 1280×720.
//!
//! Stages: the threshold into the bit mask (at a fixed level, and automatic), blob labelling, streak
//! analysis (skeleton, centroid, ends), and the whole `Pipeline::process`, with the ends from
//! the ramps (the default) and from the fitted streak model (`--streak-model fit`). The frames are
//! rendered scenes with a moving LED streak on a textured floor. The threshold is also timed on
//! the same frames repacked as UYVY and as GREY (mono cameras).

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use std::hint::black_box;

use glint::detect::bitimage::BitImage;
use glint::detect::blobs::Labeler;
use glint::detect::streak::StreakModel;
use glint::detect::threshold;
use glint::detect::threshold::static_map::StaticMap;
use glint::detect::threshold::steady::SteadyPixels;
use glint::detect::{Detector, DetectorConfig};
use glint::frame::{Frame, FrameSize, PixelFormat};
use glint::pipeline::{Pipeline, PipelineConfig};
use glint::source::FrameMeta;
use glint_tools::scene::Scene;

/// One frame of a scene, mid-way through it so the LED is streaked and in view.
fn rendered(name: &str) -> (FrameSize, Vec<u8>) {
    let scene = Scene::preset(name).expect("preset");
    let size = FrameSize::new(scene.width_px(), scene.height_px()).unwrap();
    let mut bytes = vec![0u8; size.frame_bytes()];
    scene
        .render(scene.frame_count() / 2, &mut bytes)
        .expect("render");
    (size, bytes)
}

fn stages(c: &mut Criterion) {
    for name in ["fast-line", "hd-720"] {
        let (size, bytes) = rendered(name);
        let frame = Frame::new_checked(&bytes, size, size.row_bytes()).unwrap();
        let mut group = c.benchmark_group(format!("detect/{size}"));
        group.throughput(Throughput::Elements(1));

        let mut mask = BitImage::new(size);
        group.bench_function("threshold_fixed", |b| {
            b.iter(|| threshold::threshold_into(black_box(&frame), 247, &mut mask))
        });
        group.bench_function("threshold_auto", |b| {
            b.iter(|| threshold::apply(black_box(&frame), threshold::Threshold::Auto, &mut mask))
        });

        let mut labeler = Labeler::new();
        group.bench_function("label", |b| b.iter(|| labeler.label(black_box(&mask))));

        // The static map's share of every frame: the period's OR and the clear, plus a step of
        // the counters one frame in eight (30 fps frame times).
        let mut statics = StaticMap::new(size.width(), size.height());
        let mut cut = BitImage::new(size);
        let whole = cut.full_window();
        let mut t_us = 0;
        group.bench_function("static_map", |b| {
            b.iter(|| {
                t_us += 33_333;
                statics.observe(black_box(&mask), &[], t_us);
                cut.copy_window_from(&mask, whole);
                statics.clear_static(&mut cut)
            })
        });

        // The steady pixels' share of every frame: the counters' step (30 fps frame times).
        let mut steady = SteadyPixels::new(size.width(), size.height());
        group.bench_function("steady", |b| {
            b.iter(|| {
                t_us += 33_333;
                steady.observe(black_box(&mask), t_us)
            })
        });

        let mut detector = Detector::new(size, DetectorConfig::default()).unwrap();
        group.bench_function("detect", |b| b.iter(|| detector.detect(black_box(&frame))));

        let mut pipeline = Pipeline::new(size, PipelineConfig::default()).unwrap();
        let meta = FrameMeta {
            index: 0,
            sequence: 0,
            dropped: 0,
            timestamp_us: 0,
            monotonic_us: 0,
        };
        group.bench_with_input(BenchmarkId::new("pipeline", name), &frame, |b, frame| {
            b.iter(|| pipeline.process(black_box(frame), meta))
        });

        // The same path with the streak model fitted to the pixels instead of the ramps.
        let config = PipelineConfig {
            detector: DetectorConfig {
                streak_model: StreakModel::Fit,
                ..DetectorConfig::default()
            },
            ..PipelineConfig::default()
        };
        let mut pipeline = Pipeline::new(size, config).unwrap();
        group.bench_with_input(
            BenchmarkId::new("pipeline_fit", name),
            &frame,
            |b, frame| b.iter(|| pipeline.process(black_box(frame), meta)),
        );
        group.finish();
    }
}

/// The YUYV frame `yuyv` repacked as `format`.
fn repack(yuyv: &[u8], format: PixelFormat) -> Vec<u8> {
    match format {
        PixelFormat::Yuyv => yuyv.to_vec(),
        PixelFormat::Uyvy => yuyv.chunks_exact(2).flat_map(|p| [p[1], p[0]]).collect(),
        PixelFormat::Grey => yuyv.iter().step_by(2).copied().collect(),
    }
}

/// The threshold on each pixel format, on the same pixels.
fn formats(c: &mut Criterion) {
    for name in ["fast-line", "hd-720"] {
        let (size, yuyv) = rendered(name);
        let mut group = c.benchmark_group(format!("threshold/{size}"));
        group.throughput(Throughput::Elements(1));
        let mut mask = BitImage::new(size);
        for format in PixelFormat::ALL {
            let bytes = repack(&yuyv, format);
            let stride = size.row_bytes_as(format);
            let frame = Frame::new_checked_as(&bytes, size, stride, format).unwrap();
            group.bench_function(BenchmarkId::new("fixed", format), |b| {
                b.iter(|| threshold::threshold_into(black_box(&frame), 247, &mut mask))
            });
            group.bench_function(BenchmarkId::new("auto", format), |b| {
                b.iter(|| {
                    threshold::apply(black_box(&frame), threshold::Threshold::Auto, &mut mask)
                })
            });
        }
        group.finish();
    }
}

/// A frame of saturated speckles, one pixel in ten lit: sun through foliage. Labelling stops at
/// its bounded tables, so the cost stays bounded too.
fn cluttered(c: &mut Criterion) {
    let size = FrameSize::new(640, 480).unwrap();
    let mut bytes = vec![128u8; size.frame_bytes()];
    let mut state = 0x9E37_79B9_7F4A_7C15u64;
    for luma in bytes.iter_mut().step_by(2) {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        *luma = if state.is_multiple_of(10) { 255 } else { 60 };
    }
    let frame = Frame::new_checked(&bytes, size, size.row_bytes()).unwrap();
    let mut pipeline = Pipeline::new(size, PipelineConfig::default()).unwrap();
    let meta = FrameMeta {
        index: 0,
        sequence: 0,
        dropped: 0,
        timestamp_us: 0,
        monotonic_us: 0,
    };
    c.bench_function("detect/640x480/pipeline/cluttered", |b| {
        b.iter(|| pipeline.process(black_box(&frame), meta))
    });
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .warm_up_time(std::time::Duration::from_millis(500))
        .measurement_time(std::time::Duration::from_secs(2));
    targets = stages, formats, cluttered
}
criterion_main!(benches);
