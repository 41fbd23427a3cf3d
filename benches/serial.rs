//! The serial link's costs on the capture thread, and its latency to the kernel.
//!
//! - `encode_position`: a frame's report to wire bytes (quantise, number, CRC, COBS), as the
//!   capture thread does per frame. Target: well under 1 µs.
//! - `post`: the whole per-frame call of the serial sink (encode, then hand the frame to the
//!   writer thread), with a reader draining the pty.
//! - `frame_to_kernel`: from the per-frame call until the writer thread's `write` has returned
//!   (its sent counter moves; the bench thread spins on it): the hand-over, the writer waking,
//!   and the system call. "Frame processed → bytes handed to the kernel"; target ≤ 50 µs.
//! - `frame_to_reader`: from the per-frame call until the bytes have been read at the other end
//!   of the pty, which adds the reader's wake-up: what a process on the far side would see.

use std::io::Read;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use criterion::{criterion_group, criterion_main, Criterion};
use std::hint::black_box;

use glint::frame::{Frame, FrameSize};
use glint::pipeline::{Pipeline, PipelineConfig};
use glint::report::FrameReport;
use glint::sink::serial::{Located, Updates};
use glint::sink::{SerialSink, Sink};
use glint::source::FrameMeta;
use glint_protocol::{encode, Message, MAX_ENCODED_LEN};
use glint_tools::scene::Scene;
use serialport::{SerialPort, TTYPort};

/// A report in which the LED was found, from a rendered frame.
fn found_report() -> FrameReport {
    let scene = Scene::preset("fast-line").expect("preset");
    let size = FrameSize::new(scene.width_px(), scene.height_px()).unwrap();
    let mut pipeline = Pipeline::new(size, PipelineConfig::default()).expect("pipeline");
    let mut bytes = vec![0u8; size.frame_bytes()];
    let mut report = None;
    for i in 0..scene.frame_count() / 2 {
        scene.render(i, &mut bytes).expect("render");
        let frame = Frame::new_checked(&bytes, size, size.row_bytes()).unwrap();
        let meta = FrameMeta {
            index: i as u64,
            sequence: i as u64,
            dropped: 0,
            timestamp_us: i as u64 * 33_333,
            monotonic_us: glint::source::clock::monotonic_now_us(),
        };
        report = Some(pipeline.process(&frame, meta));
    }
    let report = report.expect("frames");
    assert!(report.position.is_some(), "the LED is found mid-scene");
    report
}

/// A pty pair and the path of its slave end.
fn pty() -> (TTYPort, TTYPort, String) {
    let (master, slave) = TTYPort::pair().expect("pty pair");
    let name = slave.name().expect("slave name");
    (master, slave, name)
}

fn encode_position(c: &mut Criterion) {
    let report = found_report();
    let mut updates = Updates::new();
    let mut out = [0u8; MAX_ENCODED_LEN + 1];
    c.bench_function("serial/encode_position", |b| {
        b.iter(|| {
            let report = black_box(&report);
            let located = report.position.as_ref().map(Located::from_pixels);
            let q = updates.position(&report.meta, located.as_ref());
            encode(&Message::Position(q.position), &mut out).map(|f| f.len())
        })
    });
}

fn post(c: &mut Criterion) {
    let report = found_report();
    let (mut master, _slave, name) = pty();
    let stop = Arc::new(AtomicBool::new(false));
    let reader = {
        let stop = Arc::clone(&stop);
        std::thread::spawn(move || {
            let mut buf = [0u8; 4096];
            while !stop.load(Ordering::Relaxed) {
                let _ = master.read(&mut buf);
            }
        })
    };
    let mut sink = SerialSink::open(&name, 115_200).expect("open pty");
    c.bench_function("serial/post", |b| b.iter(|| sink.write(black_box(&report))));
    sink.finish().unwrap();
    stop.store(true, Ordering::Relaxed);
    reader.join().unwrap();
}

/// Reads until a non-empty frame has ended with its delimiter.
fn read_frame(master: &mut TTYPort, buf: &mut [u8]) {
    let mut in_frame = false;
    loop {
        let n = master.read(buf).expect("the frame arrives");
        for &b in &buf[..n] {
            if b == 0 && in_frame {
                return;
            }
            in_frame = b != 0;
        }
    }
}

fn frame_to_kernel(c: &mut Criterion) {
    let report = found_report();
    let (mut master, _slave, name) = pty();
    let stop = Arc::new(AtomicBool::new(false));
    let reader = {
        let stop = Arc::clone(&stop);
        std::thread::spawn(move || {
            let mut buf = [0u8; 4096];
            while !stop.load(Ordering::Relaxed) {
                let _ = master.read(&mut buf);
            }
        })
    };
    let mut sink = SerialSink::open(&name, 115_200).expect("open pty");
    c.bench_function("serial/frame_to_kernel", |b| {
        b.iter_custom(|iters| {
            let mut total = Duration::ZERO;
            for _ in 0..iters {
                let sent = sink.stats().sent;
                let started = Instant::now();
                sink.write(black_box(&report)).unwrap();
                while sink.stats().sent == sent {
                    std::hint::spin_loop();
                }
                total += started.elapsed();
            }
            total
        })
    });
    sink.finish().unwrap();
    stop.store(true, Ordering::Relaxed);
    reader.join().unwrap();
}

fn frame_to_reader(c: &mut Criterion) {
    let report = found_report();
    let (mut master, _slave, name) = pty();
    master.set_timeout(Duration::from_secs(5)).unwrap();
    let mut sink = SerialSink::open(&name, 115_200).expect("open pty");
    let mut buf = [0u8; 256];
    // The first call also sends a heartbeat; the report's time never advances, so no more come.
    sink.write(&report).unwrap();
    read_frame(&mut master, &mut buf);
    std::thread::sleep(Duration::from_millis(10));
    let _ = master.clear(serialport::ClearBuffer::Input);
    c.bench_function("serial/frame_to_reader", |b| {
        b.iter_custom(|iters| {
            let mut total = Duration::ZERO;
            for _ in 0..iters {
                let started = Instant::now();
                sink.write(black_box(&report)).unwrap();
                read_frame(&mut master, &mut buf);
                total += started.elapsed();
            }
            total
        })
    });
    sink.finish().unwrap();
}

criterion_group! {
    name = benches;
    config = Criterion::default()
        .measurement_time(Duration::from_secs(3))
        .warm_up_time(Duration::from_secs(1));
    targets = encode_position, post, frame_to_kernel, frame_to_reader
}
criterion_main!(benches);
