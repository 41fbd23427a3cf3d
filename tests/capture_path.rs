//! The camera's per-frame path on the host: `glint::monitor::run`, the one generic function
//! that `glint track` runs for cameras and dumps alike, fed by a replayed recording with drops
//! and irregular frame times, and by a source that lends frames out of padded rows as V4L2
//! drivers lay them out. Only the V4L2 source itself is missing (tests/vivid.rs covers it).
//! A counting global allocator holds the whole path, latency histograms included, to zero
//! allocations per frame.

mod common;

use common::alloc::{allocations_during, Counting};
use std::io::{self, Cursor};

use glint::frame::{Frame, FrameSize};
use glint::monitor::{self, Monitor, MonitorConfig};
use glint::pipeline::{Pipeline, PipelineConfig};
use glint::report::FrameReport;
use glint::sink::Sink;
use glint::source::sidecar::{FrameTiming, ReplaySource, Sidecar};
use glint::source::{FrameMeta, FrameSource};
use glint_tools::scene::{Scene, Truth};

#[global_allocator]
static GLOBAL: Counting = Counting;

/// Streak middles must be this close to the truth (tests/replay_accuracy.rs's p95 bound).
const MID_MAX_ERROR_PX: f64 = 0.5;

/// Keeps every report in a list reserved up front, so collecting allocates nothing.
struct Collect(Vec<FrameReport>);

impl Sink for Collect {
    fn write(&mut self, report: &FrameReport) -> io::Result<()> {
        if self.0.len() == self.0.capacity() {
            return Err(io::Error::other("more reports than reserved"));
        }
        self.0.push(report.clone());
        Ok(())
    }

    fn finish(&mut self) -> io::Result<()> {
        Ok(())
    }
}

fn rendered(name: &str) -> (Scene, Vec<u8>, Vec<Truth>) {
    let scene = Scene::preset(name).expect("preset");
    let (bytes, truths) = scene.render_dump();
    (scene, bytes, truths)
}

fn size_of(scene: &Scene) -> FrameSize {
    FrameSize::new(scene.width_px(), scene.height_px()).unwrap()
}

fn assert_near_truth(report: &FrameReport, truth: &Truth) {
    let p = report.position.expect("the LED is found");
    let error_px = (f64::from(p.mid_px.0) - truth.mid_x_px.unwrap())
        .hypot(f64::from(p.mid_px.1) - truth.mid_y_px.unwrap());
    assert!(
        error_px <= MID_MAX_ERROR_PX,
        "frame {}: {error_px:.3} px from the truth",
        report.meta.index
    );
}

/// A capture that lost every fourth frame, with jittered frame times, replayed from its dump
/// and sidecar through the camera path: times, sequence numbers and drops come out as recorded,
/// the LED where the scene put it, and nothing is allocated per frame.
#[test]
fn a_recording_with_drops_replays_through_the_camera_path_without_allocating() {
    let (scene, bytes, truths) = rendered("fast-line");
    let size = size_of(&scene);
    let frame_bytes = size.frame_bytes();
    let mut dump = Vec::new();
    let mut timings = Vec::new();
    for (i, frame) in bytes.chunks_exact(frame_bytes).enumerate() {
        if i % 4 == 3 {
            continue;
        }
        dump.extend_from_slice(frame);
        let jitter_us = (i as u64 * 7919) % 900;
        timings.push(FrameTiming {
            seq: 100 + i as u64,
            t_us: (truths[i].t_s * 1e6) as u64 + jitter_us,
        });
    }
    let kept = timings.len();
    let sidecar = Sidecar::new(size, size.row_bytes() + 64, timings.clone());
    sidecar.check_against(size, dump.len() as u64).unwrap();

    let mut source = ReplaySource::new(Cursor::new(&dump), size, sidecar);
    let mut pipeline = Pipeline::new(size, PipelineConfig::default()).unwrap();
    let mut sink = Collect(Vec::with_capacity(kept));
    let mut monitor = Monitor::new(MonitorConfig {
        stats: true,
        // A summary after every frame exercises the periodic path too.
        summary_every: Some(std::time::Duration::from_nanos(1)),
    });
    let mut outcome = None;
    let allocations = allocations_during(|| {
        outcome = Some(monitor::run(
            &mut source,
            &mut pipeline,
            &mut sink,
            &mut monitor,
        ));
    });
    let (summary, result) = outcome.unwrap();
    result.unwrap();
    assert_eq!(allocations, 0, "allocations during {kept} frames");
    assert_eq!(summary.frames, kept as u64);

    let reports = sink.0;
    assert_eq!(reports.len(), kept);
    for (i, (report, timing)) in reports.iter().zip(&timings).enumerate() {
        let expected_dropped = if i == 0 {
            0
        } else {
            timing.seq - timings[i - 1].seq - 1
        };
        assert_eq!(
            (report.meta.index, report.meta.sequence, report.meta.dropped),
            (i as u64, timing.seq, expected_dropped)
        );
        assert_eq!(report.meta.timestamp_us, timing.t_us);
        assert_near_truth(report, &truths[(timing.seq - 100) as usize]);
    }
    let totals = monitor.totals();
    let gaps: u64 = timings.windows(2).map(|p| p[1].seq - p[0].seq - 1).sum();
    assert!(gaps > 0);
    assert_eq!(totals.dropped, gaps);
    assert_eq!(totals.found, kept as u64);
    assert_eq!(monitor.stats().map(|s| s.frames()), Some(kept as u64));
}

/// Lends frames out of padded rows, as a V4L2 driver with a `bytesperline` above `2 × width`
/// does, with saturated bytes in the padding: reading past a row's end would find "LEDs" there.
struct PaddedSource {
    bytes: Vec<u8>,
    size: FrameSize,
    stride_bytes: usize,
    frames: usize,
    next: usize,
}

impl PaddedSource {
    fn new(unpadded: &[u8], size: FrameSize, padding_bytes: usize) -> Self {
        let stride_bytes = size.row_bytes() + padding_bytes;
        let frames = unpadded.len() / size.frame_bytes();
        let mut bytes = Vec::with_capacity(frames * stride_bytes * size.height());
        for row in unpadded.chunks_exact(size.row_bytes()) {
            bytes.extend_from_slice(row);
            bytes.extend(std::iter::repeat_n(255u8, padding_bytes));
        }
        PaddedSource {
            bytes,
            size,
            stride_bytes,
            frames,
            next: 0,
        }
    }
}

impl FrameSource for PaddedSource {
    type Error = glint::frame::FrameError;

    fn next_frame(&mut self) -> Result<Option<(Frame<'_>, FrameMeta)>, Self::Error> {
        if self.next == self.frames {
            return Ok(None);
        }
        let index = self.next;
        self.next += 1;
        let buffer_bytes = self.stride_bytes * self.size.height();
        let start = index * buffer_bytes;
        let frame = Frame::new_checked(
            &self.bytes[start..start + buffer_bytes],
            self.size,
            self.stride_bytes,
        )?;
        let meta = FrameMeta {
            index: index as u64,
            sequence: index as u64,
            dropped: 0,
            // The same times a dump source at 30 fps gives.
            timestamp_us: (index as f64 * 1e6 / 30.0).round() as u64,
            monotonic_us: 0,
        };
        Ok(Some((frame, meta)))
    }
}

#[test]
fn frames_in_padded_driver_rows_are_tracked_exactly_as_unpadded_ones() {
    let (scene, bytes, truths) = rendered("circles");
    let size = size_of(&scene);
    let run = |source: &mut dyn FnMut(&mut Pipeline, &mut Collect, &mut Monitor)| {
        let mut pipeline = Pipeline::new(size, PipelineConfig::default()).unwrap();
        let mut sink = Collect(Vec::with_capacity(truths.len()));
        let mut monitor = Monitor::new(MonitorConfig::default());
        source(&mut pipeline, &mut sink, &mut monitor);
        sink.0
    };
    // 32 pixels of padding per row, as drivers that align rows to 64 bytes add.
    let padded = run(&mut |pipeline, sink, monitor| {
        let mut source = PaddedSource::new(&bytes, size, 64);
        monitor::run(&mut source, pipeline, sink, monitor)
            .1
            .unwrap();
    });
    let unpadded = run(&mut |pipeline, sink, monitor| {
        let mut source = glint::source::dump::DumpSource::new(&bytes[..], size, 30.0);
        monitor::run(&mut source, pipeline, sink, monitor)
            .1
            .unwrap();
    });
    assert_eq!(padded.len(), truths.len());
    assert_eq!(unpadded.len(), truths.len());
    for (p, u) in padded.iter().zip(&unpadded) {
        assert!(
            p.detection == u.detection && p.position == u.position,
            "frame {}: padded {:?} vs unpadded {:?}",
            p.meta.index,
            p.position,
            u.position
        );
    }
    assert!(padded.iter().all(|r| r.position.is_some()));
}
