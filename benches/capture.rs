//! The cost of the capture path around the pipeline, at 640×480: lending a dequeued buffer out
//! as a frame (timeline + checked view, what `V4l2Source` does after VIDIOC_DQBUF), and the
//! monitored run (`monitor::run` with `--stats` histograms) against the bare `pipeline::run`,
//! both writing JSON lines, so the difference is the monitor's own per-frame cost.

use std::hint::black_box;
use std::io::{self, BufWriter};

use criterion::{criterion_group, criterion_main, Criterion, Throughput};

use glint::frame::{Frame, FrameError, FrameSize};
use glint::monitor::{self, Monitor, MonitorConfig};
use glint::pipeline::{self, Pipeline, PipelineConfig};
use glint::sink::JsonLinesSink;
use glint::source::v4l2::timeline::Timeline;
use glint::source::{FrameMeta, FrameSource};
use glint_tools::scene::Scene;

/// Frames per measured iteration of a run.
const FRAMES_PER_RUN: u64 = 16;

/// Lends the same frame out a number of times, as a camera whose picture does not change.
struct Repeat<'a> {
    bytes: &'a [u8],
    size: FrameSize,
    left: u64,
    timeline: Timeline,
}

impl FrameSource for Repeat<'_> {
    type Error = FrameError;

    fn next_frame(&mut self) -> Result<Option<(Frame<'_>, FrameMeta)>, FrameError> {
        if self.left == 0 {
            return Ok(None);
        }
        self.left -= 1;
        let meta = self.timeline.on_frame(self.left as u32, self.left * 33_333);
        Ok(Some((
            Frame::new_checked(self.bytes, self.size, self.size.row_bytes())?,
            meta,
        )))
    }
}

fn capture(c: &mut Criterion) {
    let scene = Scene::preset("fast-line").expect("preset");
    let size = FrameSize::new(scene.width_px(), scene.height_px()).unwrap();
    let mut bytes = vec![0u8; size.frame_bytes()];
    scene
        .render(scene.frame_count() / 2, &mut bytes)
        .expect("render");
    let mut group = c.benchmark_group(format!("capture/{size}"));

    let mut timeline = Timeline::new();
    let mut sequence = 0u32;
    group.bench_function("lend", |b| {
        b.iter(|| {
            sequence = sequence.wrapping_add(1);
            let meta = timeline.on_frame(sequence, u64::from(sequence) * 33_333);
            let frame = Frame::new_checked(black_box(&bytes), size, size.row_bytes());
            black_box((frame.map(|f| f.stride_bytes()), meta))
        })
    });

    group.throughput(Throughput::Elements(FRAMES_PER_RUN));
    let mut pipeline = Pipeline::new(size, PipelineConfig::default()).unwrap();
    let mut sink = JsonLinesSink::new(BufWriter::with_capacity(64 * 1024, io::sink()), true);
    let mut source = Repeat {
        bytes: &bytes,
        size,
        left: 0,
        timeline: Timeline::new(),
    };
    group.bench_function("pipeline_run", |b| {
        b.iter(|| {
            source.left = FRAMES_PER_RUN;
            pipeline::run(&mut source, &mut pipeline, &mut sink)
                .1
                .unwrap()
        })
    });
    let mut monitor = Monitor::new(MonitorConfig {
        stats: true,
        summary_every: None,
    });
    group.bench_function("monitor_run_stats", |b| {
        b.iter(|| {
            source.left = FRAMES_PER_RUN;
            monitor::run(&mut source, &mut pipeline, &mut sink, &mut monitor)
                .1
                .unwrap()
        })
    });
    group.finish();
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .warm_up_time(std::time::Duration::from_millis(500))
        .measurement_time(std::time::Duration::from_secs(2));
    targets = capture
}
criterion_main!(benches);
