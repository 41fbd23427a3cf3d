//! The per-frame path allocates nothing: a counting global allocator watches a whole replay
//! (dump source → detection → JSON lines sink, CSV sink, serial sink on a pty) of rendered
//! scenes after start-up.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::io::{self, BufWriter, Cursor};

use glint::frame::FrameSize;
use glint::pipeline::{self, Pipeline, PipelineConfig};
use glint::sink::{CsvSink, JsonLinesSink, SerialSink};
use glint::source::dump::DumpSource;
use glint_tools::scene::Scene;

struct Counting;

thread_local! {
    /// Only allocations on the thread under test count; the test harness has others.
    static COUNTING: Cell<bool> = const { Cell::new(false) };
    static ALLOCATIONS: Cell<u64> = const { Cell::new(0) };
}

fn note_allocation() {
    if COUNTING.with(Cell::get) {
        ALLOCATIONS.with(|a| a.set(a.get() + 1));
    }
}

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        note_allocation();
        unsafe { System.alloc(layout) }
    }

    unsafe fn alloc_zeroed(&self, layout: Layout) -> *mut u8 {
        note_allocation();
        unsafe { System.alloc_zeroed(layout) }
    }

    unsafe fn realloc(&self, ptr: *mut u8, layout: Layout, new_size: usize) -> *mut u8 {
        note_allocation();
        unsafe { System.realloc(ptr, layout, new_size) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static GLOBAL: Counting = Counting;

/// Runs `f` and returns how many allocations it made on this thread.
fn allocations_during(f: impl FnOnce()) -> u64 {
    ALLOCATIONS.with(|a| a.set(0));
    COUNTING.with(|c| c.set(true));
    f();
    COUNTING.with(|c| c.set(false));
    ALLOCATIONS.with(Cell::get)
}

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
    let mut pipeline = Pipeline::new(size, PipelineConfig::default());
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

    // The counter itself works: a deliberate allocation is seen.
    let seen = allocations_during(|| drop(std::hint::black_box(vec![1u8; 10])));
    assert_eq!(seen, 1);

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
    let mut pipeline = Pipeline::new(size, config);
    let mut sink = CsvSink::new(BufWriter::with_capacity(64 * 1024, io::sink()), false);
    let allocations = allocations_during(|| {
        pipeline::run(&mut source, &mut pipeline, &mut sink)
            .1
            .unwrap();
    });
    assert_eq!(allocations, 0);
}

/// The serial sink's per-frame call (position and heartbeat built and encoded on the stack,
/// posted to the writer thread) allocates nothing on the capture thread; the writer thread,
/// which owns the port, is not the per-frame path and is not counted.
#[test]
fn serial_sink_allocates_nothing_per_frame() {
    use serialport::SerialPort;
    use std::io::Read;
    use std::sync::atomic::{AtomicBool, Ordering};
    use std::sync::Arc;

    let scene = Scene::preset("slow-line").unwrap();
    let (bytes, truths) = scene.render_dump();
    let size = FrameSize::new(scene.width_px(), scene.height_px()).unwrap();
    let (mut master, slave) = serialport::TTYPort::pair().expect("pty pair");
    let name = slave.name().expect("slave name");
    // The robot's end reads everything, so the writer keeps sending.
    let stop = Arc::new(AtomicBool::new(false));
    let reader = {
        let stop = Arc::clone(&stop);
        std::thread::spawn(move || {
            let mut buf = [0u8; 256];
            let mut received = 0;
            while !stop.load(Ordering::Relaxed) {
                received += master.read(&mut buf).unwrap_or(0);
            }
            received
        })
    };

    let mut source = DumpSource::new(Cursor::new(&bytes), size, scene.fps());
    let mut pipeline = Pipeline::new(size, PipelineConfig::default());
    let mut sink = SerialSink::open(&name, 115_200).expect("open the pty");
    let allocations = allocations_during(|| {
        pipeline::run(&mut source, &mut pipeline, &mut sink)
            .1
            .unwrap();
    });
    stop.store(true, Ordering::Relaxed);
    let received = reader.join().unwrap();
    let stats = sink.stats();
    assert_eq!(stats.updates, truths.len() as u64);
    assert!(
        stats.sent > 0 && received > 0,
        "{stats:?}, {received} bytes"
    );
    assert_eq!(allocations, 0, "allocations during {} frames", truths.len());
}
