//! The per-frame cost of following several robots (`--robots N`), N = 1, 4 and 16, on rendered
//! 640×480 frames with N LEDs moving in a 4 × 4 grid: the whole `Pipeline::process` (detection,
//! the assignment of candidates to tracks, each track's streak analysis and update). With
//! N = 1 the pipeline is the single-robot one that `--robots 1` runs.
//!
//! Every LED goes back and forth over 60 px once per 30 frames, and the frames are replayed in
//! a ring with time running on, so the tracks stay live across the ring's seam.

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};
use std::hint::black_box;

use glint::frame::{Frame, FrameSize};
use glint::pipeline::{Pipeline, PipelineConfig};
use glint::source::FrameMeta;
use glint::track::{MultiTracker, TrackerConfig};
use glint_tools::scene::{Fleet, Point, Scene, Trajectory};

/// Frames in the ring: one period of every LED's motion at 30 fps.
const RING_FRAMES: usize = 30;

fn fleet(robots: usize) -> Fleet {
    let mut base = Scene::preset_config("slow-line").expect("preset");
    base.frame_count = RING_FRAMES;
    let trajectories: Vec<Trajectory> = (0..robots)
        .map(|k| {
            let (col, row) = ((k % 4) as f64, (k / 4) as f64);
            let a = Point::new(60.0 + 150.0 * col, 60.0 + 110.0 * row);
            Trajectory::PingPong {
                a_px: a,
                b_px: Point::new(a.x + 60.0, a.y + 10.0),
                // Twice the leg in one second: one period per ring.
                speed_px_s: 2.0 * 60.0_f64.hypot(10.0),
                at_a_s: 0.0,
            }
        })
        .collect();
    Fleet::new(&base, &trajectories).expect("fleet")
}

fn robots(c: &mut Criterion) {
    let mut group = c.benchmark_group("robots/640x480");
    group.throughput(Throughput::Elements(1));
    for n in [1, 4, 16] {
        let fleet = fleet(n);
        let scene = fleet.robot(0).unwrap();
        let size = FrameSize::new(scene.width_px(), scene.height_px()).unwrap();
        let frames: Vec<Vec<u8>> = (0..RING_FRAMES)
            .map(|i| {
                let mut bytes = vec![0u8; size.frame_bytes()];
                fleet.render(i, &mut bytes).expect("render");
                bytes
            })
            .collect();
        let tracker = TrackerConfig {
            exposure_us: Some(scene.exposure_us()),
        };
        let config = PipelineConfig {
            tracker,
            ..PipelineConfig::default()
        };
        let mut pipeline = if n == 1 {
            Pipeline::new(size, config).unwrap()
        } else {
            Pipeline::several(size, config, MultiTracker::new(n, tracker).unwrap()).unwrap()
        };
        let frame_us = 1e6 / scene.fps();
        let mut index = 0u64;
        group.bench_with_input(BenchmarkId::new("pipeline", n), &frames, |b, frames| {
            b.iter(|| {
                let bytes = &frames[index as usize % RING_FRAMES];
                let frame = Frame::new_checked(bytes, size, size.row_bytes()).unwrap();
                let t_us = (index as f64 * frame_us) as u64;
                let meta = FrameMeta {
                    index,
                    sequence: index,
                    dropped: 0,
                    timestamp_us: t_us,
                    monotonic_us: t_us,
                };
                index += 1;
                black_box(pipeline.process(black_box(&frame), meta))
            })
        });
    }
    group.finish();
}

criterion_group!(benches, robots);
criterion_main!(benches);
