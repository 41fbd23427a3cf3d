//! The per-frame path allocates nothing: a counting global allocator watches a whole replay
//! (dump source → detection → JSON lines sink, CSV sink, serial sink on a pty) of rendered
//! scenes after start-up, and the MAVLink sink on a pty.

mod common;

use common::alloc::{allocations_during, Counting};
use std::io::{self, BufWriter, Cursor};
use std::sync::OnceLock;

use glint::frame::FrameSize;
use glint::pipeline::{self, Pipeline, PipelineConfig};
use glint::sink::{CsvSink, JsonLinesSink, SerialSink};
use glint::source::dump::DumpSource;
use glint_tools::scene::Scene;

#[global_allocator]
static GLOBAL: Counting = Counting;

/// Rendered frames of several scenes at 640×480, blank frames between them: rendered once and
/// shared by the tests (they run side by side in this process and only read them).
fn frames() -> &'static (FrameSize, Vec<u8>, usize) {
    static FRAMES: OnceLock<(FrameSize, Vec<u8>, usize)> = OnceLock::new();
    FRAMES.get_or_init(render_frames)
}

fn render_frames() -> (FrameSize, Vec<u8>, usize) {
    // First (so that the tracker starts on its brightest LED), three LEDs on one body, the
    // tracked one hidden for 10 frames while the other two move on: the tracker follows its
    // body by them while it is lost.
    let mut hidden = Scene::preset_config("three-leds").unwrap();
    hidden.frame_count = 60;
    let hidden_frames = 30..40;
    hidden.led_hidden_frames = vec![hidden_frames];
    let (mut bytes, truths) = Scene::new(hidden).unwrap().render_dump();
    let mut count = truths.len();
    for name in [
        "glare",
        "fast-line",
        "circles",
        "leave-occlude",
        "window",
        "three-leds",
    ] {
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
    let &(size, ref bytes, count) = frames();
    assert!(count >= 100, "at least 100 frames, got {count}");

    // Start-up allocations happen here, outside the count.
    let mut source = DumpSource::new(Cursor::new(&bytes), size, 30.0);
    let mut pipeline = Pipeline::new(size, PipelineConfig::default()).unwrap();
    // With `--predict arrival`, so the prediction the lines carry is counted too.
    let mut sink =
        JsonLinesSink::new(BufWriter::with_capacity(64 * 1024, io::sink()), false).predicting();
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
}

/// The CSV sink, the seed's morphological skeleton and the fitted streak model (with the floor
/// it learns without the light, frame by frame, and a rolling shutter's skew of the spot and the
/// velocity) keep the promise too. (A test of its own, so that the costly fit runs beside the
/// other replays.)
#[test]
fn the_fitted_streak_model_allocates_nothing_per_frame() {
    let &(size, ref bytes, _) = frames();
    let config = PipelineConfig {
        detector: glint::detect::DetectorConfig {
            skeleton: glint::detect::skeleton::SkeletonMethod::Morphological,
            erosions: 1,
            streak_model: glint::detect::streak::StreakModel::Fit,
            ..Default::default()
        },
        tracker: glint::track::TrackerConfig {
            exposure_us: Some(25_000),
        },
    };
    let mut source = DumpSource::new(Cursor::new(&bytes), size, 30.0);
    let shutter = glint::track::shutter::RollingShutter::new(40.0).unwrap();
    let mut pipeline = Pipeline::new(size, config)
        .unwrap()
        .with_rolling_shutter(shutter);
    // With `--predict arrival`, so the predicted columns are counted too.
    let mut sink =
        CsvSink::new(BufWriter::with_capacity(64 * 1024, io::sink()), false).predicting();
    let allocations = allocations_during(|| {
        let (s, result) = pipeline::run(&mut source, &mut pipeline, &mut sink);
        result.unwrap();
        assert!(s.found > s.frames / 2, "{s:?}");
    });
    assert_eq!(allocations, 0);
    let floor = pipeline.detector().unwrap().floor_background().unwrap();
    assert!(floor.luma(5, 5).is_some(), "the fit's floor was learned");
}

/// The cascade (`--streak-model auto`): the ramps on every frame, the fit on the doubtful ones,
/// and the floor kept up once a streak was fitted. Both branches must run for the count to
/// mean anything, so the scenes must give it frames of each kind.
#[test]
fn the_cascade_allocates_nothing_per_frame() {
    use glint::frame::Frame;
    let &(size, ref bytes, count) = frames();
    let config = PipelineConfig {
        detector: glint::detect::DetectorConfig {
            streak_model: glint::detect::streak::StreakModel::Auto,
            ..Default::default()
        },
        tracker: glint::track::TrackerConfig {
            exposure_us: Some(25_000),
        },
    };
    let mut pipeline = Pipeline::new(size, config).unwrap();
    let (mut fitted, mut left_to_the_ramps) = (0usize, 0usize);
    let allocations = allocations_during(|| {
        for (i, frame_bytes) in bytes.chunks_exact(size.frame_bytes()).enumerate() {
            let frame = Frame::new_checked(frame_bytes, size, size.row_bytes()).unwrap();
            let report = pipeline.process(&frame, common::view::meta_at_30_fps(i));
            match report.detection.best.map(|(_, s)| s.fitted()) {
                Some(true) => fitted += 1,
                Some(false) => left_to_the_ramps += 1,
                None => {}
            }
        }
    });
    assert_eq!(allocations, 0, "allocations during {count} frames");
    assert!(
        fitted > 0 && left_to_the_ramps > 0,
        "both branches ran: {fitted} fitted, {left_to_the_ramps} left to the ramps"
    );
}

/// So does the background-difference detector, learning included.
#[test]
fn the_background_difference_allocates_nothing_per_frame() {
    let &(size, ref bytes, _) = frames();
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

/// A floor mapping of the marker renderer's reference camera, from four floor points.
fn reference_floor() -> glint::geometry::FloorStage {
    use glint::geometry::{FloorMapping, FloorStage, FloorUnit, Point};
    let camera = glint_tools::markers::reference_camera();
    let floor =
        [(-50.0, -40.0), (70.0, -40.0), (70.0, 60.0), (-50.0, 60.0)].map(|(x, y)| Point::new(x, y));
    let screen = floor.map(|p| camera.project(p).unwrap());
    FloorStage::new(FloorMapping::fit(&floor, &screen).unwrap(), FloorUnit::Cm).unwrap()
}

/// The reference camera with a wide-angle lens and the LED 12 cm up: every floor point is an
/// undistorted ray met with a plane.
fn lens_floor() -> glint::geometry::FloorStage {
    use glint::geometry::{CameraModel, FloorStage, FloorUnit, Lens, Pose};
    use nalgebra::Vector3;
    let centre = Vector3::new(10.0, -70.0, -130.0);
    let target = Vector3::new(10.0, -5.0, 0.0);
    let camera = CameraModel {
        lens: Lens {
            k1: -0.30,
            k2: 0.09,
            ..Lens::ideal(460.0, 460.0, 319.5, 239.5)
        },
        pose: Pose::looking_at(centre, target).unwrap(),
    };
    FloorStage::from_camera(camera, FloorUnit::Cm)
        .with_led_height(12.0)
        .unwrap()
}

#[test]
fn floor_mapping_and_marker_tracking_allocate_nothing_per_frame() {
    use glint::detect::aruco::Dictionary;
    use glint::geometry::{FloorFix, Point};
    use glint_tools::markers::{reference_camera, MarkerScene, PlacedMarker};

    // The LED pipeline with the floor stage, through both sinks.
    let &(size, ref bytes, count) = frames();
    let config = PipelineConfig {
        tracker: glint::track::TrackerConfig {
            exposure_us: Some(25_000),
        },
        ..Default::default()
    };
    fn replay<K: glint::sink::Sink>(
        bytes: &[u8],
        size: FrameSize,
        config: PipelineConfig,
        floor: glint::geometry::FloorStage,
        sink: &mut K,
    ) -> u64 {
        let mut source = DumpSource::new(Cursor::new(bytes), size, 30.0);
        let mut pipeline = Pipeline::new(size, config).unwrap().with_floor(floor);
        allocations_during(|| {
            let (s, result) = pipeline::run(&mut source, &mut pipeline, sink);
            result.unwrap();
            assert!(s.found > s.frames / 2, "{s:?}");
        })
    }
    let out = || BufWriter::with_capacity(64 * 1024, io::sink());
    for (name, floor) in [("homography", reference_floor()), ("lens", lens_floor())] {
        let json = replay(
            bytes,
            size,
            config,
            floor,
            &mut JsonLinesSink::new(out(), false),
        );
        assert_eq!(json, 0, "LED with floor ({name}), JSON lines");
        let csv = replay(bytes, size, config, floor, &mut CsvSink::new(out(), false));
        assert_eq!(csv, 0, "LED with floor ({name}), CSV");
    }
    assert!(count > 100);

    // A marker pipeline with the floor stage, on rendered frames of a turning marker.
    let mut dump = Vec::new();
    for i in 0..4 {
        let robot = PlacedMarker {
            dictionary: Dictionary::Aruco6x6_250,
            id: 7,
            size_cm: 15.0,
            origin_cm: Point::new(-10.0 + 3.0 * f64::from(i), 0.0),
            rotation_deg: 20.0 * f64::from(i),
        };
        dump.extend(MarkerScene::new(reference_camera(), vec![robot]).render_yuyv());
    }
    let tracker = glint::track::MarkerTracker::new(size, Dictionary::Aruco6x6_250, 7).unwrap();
    let mut pipeline = Pipeline::marker(tracker).with_floor(lens_floor());
    let mut source = DumpSource::new(Cursor::new(&dump), size, 30.0);
    let mut reports: heapless::Vec<glint::report::FrameReport, 8> = heapless::Vec::new();
    let allocations = allocations_during(|| {
        while let Some((frame, meta)) = glint::source::FrameSource::next_frame(&mut source).unwrap()
        {
            let report = pipeline.process(&frame, meta);
            reports.push(report).unwrap();
        }
    });
    assert_eq!(allocations, 0, "marker tracking with floor");
    assert_eq!(reports.len(), 4);
    assert!(reports
        .iter()
        .all(|r| matches!(r.floor, Some(FloorFix::Mapped(f)) if f.heading_deg.is_some())));
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
    let mut pipeline = Pipeline::new(size, PipelineConfig::default()).unwrap();
    // With `--predict arrival`: the bend is measured on the capture thread too.
    let mut sink = SerialSink::open(&name, 115_200)
        .expect("open the pty")
        .predicting();
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

/// The preview copies frames for a connected viewer without allocating on the capture thread
/// (the server thread's own allocations, for HTTP and BMP encoding, do not count).
#[test]
fn preview_sink_with_a_viewer_allocates_nothing_per_frame() {
    use common::live::get;

    let &(size, ref bytes, count) = frames();
    let mut sink =
        glint::sink::preview::PreviewSink::start("127.0.0.1:0".parse().unwrap(), size, Vec::new())
            .unwrap();
    // A viewer asks for the state: from now on frames are copied (at most twice a second).
    let (status, body) = get(sink.local_addr(), "/state.json");
    assert_eq!(status, "HTTP/1.1 200 OK");
    let answer = String::from_utf8_lossy(&body);
    assert!(
        answer.contains("\"captured\":false"),
        "nothing copied yet: {answer}"
    );

    let mut source = DumpSource::new(Cursor::new(&bytes), size, 30.0);
    let mut pipeline = Pipeline::new(size, PipelineConfig::default()).unwrap();
    let allocations = allocations_during(|| {
        let (s, result) = pipeline::run(&mut source, &mut pipeline, &mut sink);
        result.unwrap();
        assert_eq!(s.frames, count as u64);
    });
    assert_eq!(allocations, 0);

    // And the copy happened: the state now names a frame.
    let (_, body) = get(sink.local_addr(), "/state.json");
    let answer = String::from_utf8_lossy(&body);
    assert!(answer.contains("\"captured\":true"), "{answer}");
}

/// The command's own source, a dump read through the stop-aware reader (one `poll` before each
/// read) and ended by the stop flag, allocates nothing per frame either.
#[test]
fn the_stop_aware_file_source_allocates_nothing_per_frame() {
    use glint::source::interruptible::Interruptible;
    use glint::source::stoppable::Stoppable;
    use std::sync::atomic::AtomicBool;
    use std::sync::Arc;

    let &(size, ref bytes, count) = frames();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("frames.yuv");
    std::fs::write(&path, bytes).unwrap();
    let stop = Arc::new(AtomicBool::new(false));
    let reader = Interruptible::new(std::fs::File::open(&path).unwrap(), Arc::clone(&stop));
    let mut source = Stoppable::new(DumpSource::try_new(reader, size, 30.0).unwrap(), stop);
    let mut pipeline = Pipeline::new(size, PipelineConfig::default()).unwrap();
    let mut sink = JsonLinesSink::new(BufWriter::with_capacity(64 * 1024, io::sink()), false);
    let mut frames_run = 0;
    let allocations = allocations_during(|| {
        let (s, result) = pipeline::run(&mut source, &mut pipeline, &mut sink);
        result.unwrap();
        frames_run = s.frames;
    });
    assert_eq!(frames_run, count as u64);
    assert_eq!(allocations, 0, "allocations during {count} frames");
}

/// The re-check of the calibration's markers allocates nothing per frame on the tracking
/// thread either (the copy handed to its worker, a verdict applied, a pose refit after a knock,
/// and the preview's grid redrawn through it). The worker thread's own share is counted in
/// `tests/recheck_alloc_free.rs`.
#[test]
fn the_marker_recheck_and_a_pose_refit_allocate_nothing() {
    use glint::detect::aruco::Dictionary;
    use glint::frame::Frame;
    use glint::geometry::recheck::MarkerRecheck;
    use glint::geometry::{CameraModel, FloorStage, FloorUnit, Lens, MarkerPlacement, Pose};
    use nalgebra::Vector3;

    // The knocked scene's true camera before the knock: the mild lens over the reference pose.
    let config = Scene::preset_config("knocked").unwrap();
    let view = config.view.clone().unwrap();
    let knock_frame = view.knock.unwrap().frame;
    let l = view.lens;
    let centre = Vector3::new(10.0, -70.0, -130.0);
    let target = Vector3::new(10.0, -5.0, 0.0);
    let camera = CameraModel {
        lens: Lens {
            fx: l.fx,
            fy: l.fy,
            cx: l.cx,
            cy: l.cy,
            k1: l.k1,
            k2: l.k2,
            k3: l.k3,
            p1: l.p1,
            p2: l.p2,
        },
        pose: Pose::looking_at(centre, target).unwrap(),
    };
    let map: Vec<MarkerPlacement> = view.markers.iter().map(|m| m.placement()).collect();
    let scene = Scene::new(config).unwrap();
    let size = FrameSize::new(scene.width_px(), scene.height_px()).unwrap();
    let floor = FloorStage::from_camera(camera, FloorUnit::Cm);
    let recheck = MarkerRecheck::new(size, Dictionary::Aruco6x6_250, &map, 0.05).unwrap();
    let mut pipeline = Pipeline::new(size, PipelineConfig::default())
        .unwrap()
        .with_floor(floor)
        .with_recheck(recheck);
    // Checks are made every period from the first frame; the first after the knock is
    // refitted a verdict's lag later.
    let period = glint::geometry::recheck::RECHECK_PERIOD_FRAMES as usize;
    let lag = glint::geometry::recheck::VERDICT_LAG_FRAMES as usize;
    let first = knock_frame - 16;
    let refit_at = first + period * (knock_frame - first).div_ceil(period) + lag;
    let rendered = first..refit_at + 6;
    let mut frames: Vec<(usize, Vec<u8>)> = rendered
        .clone()
        .map(|i| {
            let mut bytes = vec![0u8; scene.frame_len_bytes()];
            scene.render(i, &mut bytes).unwrap();
            (i, bytes)
        })
        .collect();
    // Then three periods of a black picture: checks find no marker, around where the pose puts
    // them or in the whole frame.
    frames.extend(
        (rendered.end..rendered.end + 3 * period).map(|i| (i, vec![0u8; scene.frame_len_bytes()])),
    );
    // A watched preview drawing the floor grid, redrawn after the refit.
    let mut preview =
        glint::sink::preview::PreviewSink::start("127.0.0.1:0".parse().unwrap(), size, Vec::new())
            .unwrap()
            .with_floor_camera(camera);
    let (status, _) = common::live::get(preview.local_addr(), "/state.json");
    assert_eq!(status, "HTTP/1.1 200 OK");
    let mut ages: heapless::Vec<f64, 128> = heapless::Vec::new();
    let allocations = allocations_during(|| {
        for (i, bytes) in &frames {
            let frame = Frame::new_checked(bytes, size, size.row_bytes()).unwrap();
            let meta = common::view::meta_at_30_fps(*i);
            let report = pipeline.process(&frame, meta);
            ages.push(report.calib.unwrap().age_s).unwrap();
            glint::sink::Sink::write_frame(&mut preview, &frame, &report).unwrap();
            if *i == refit_at {
                // The next frame is copied, with the grid redrawn through the refitted pose.
                std::thread::sleep(glint::sink::preview::COPY_PERIOD);
            }
        }
    });
    assert_eq!(
        allocations, 0,
        "marker re-check, pose refit and the preview's grid"
    );
    let refit = pipeline.floor().unwrap().camera().unwrap().pose;
    assert_ne!(
        refit, camera.pose,
        "the knock was seen and the pose refitted"
    );
    assert_eq!(
        pipeline.floor().unwrap().camera().unwrap().lens,
        camera.lens
    );
    // Confirmed at the checks before the knock and refitted after it: ages restart, at most a
    // period and a verdict's lag after the frame checked.
    let most_s = (period + lag) as f64 / 30.0 + 0.01;
    assert!(
        ages[..rendered.len()].iter().all(|&a| a < most_s),
        "{ages:?}"
    );
    // In the black frames nothing confirms the pose.
    assert!(ages.last().is_some_and(|&a| a > 0.9), "{ages:?}");
}

/// The MAVLink sink's per-frame call (messages built on the stack, posted to the writer
/// thread, which frames and writes them and sends the heartbeats) allocates nothing on the
/// capture thread.
#[test]
fn mavlink_sink_allocates_nothing_per_frame() {
    use glint::sink::mavlink::{Identity, MavlinkSink, ToLocal};
    use serialport::SerialPort;
    use std::io::Read;
    use std::sync::atomic::{AtomicBool, Ordering};
    use std::sync::Arc;

    let &(size, ref bytes, count) = frames();
    let (mut master, slave) = serialport::TTYPort::pair().expect("pty pair");
    let name = slave.name().expect("slave name");
    let stop = Arc::new(AtomicBool::new(false));
    let reader = {
        let stop = Arc::clone(&stop);
        std::thread::spawn(move || {
            let mut buf = [0u8; 1024];
            let mut received = 0;
            while !stop.load(Ordering::Relaxed) {
                received += master.read(&mut buf).unwrap_or(0);
            }
            received
        })
    };

    let floor = reference_floor();
    let identity = Identity {
        system_id: 1,
        component_id: glint::sink::mavlink::VISION_COMPONENT_ID,
    };
    let mut sink = MavlinkSink::open(&name, 115_200, identity, ToLocal::new(floor, 30.0, 0.1))
        .expect("open the pty");
    let mut source = DumpSource::new(Cursor::new(&bytes), size, 30.0);
    let mut pipeline = Pipeline::new(size, PipelineConfig::default())
        .unwrap()
        .with_floor(floor);
    let allocations = allocations_during(|| {
        pipeline::run(&mut source, &mut pipeline, &mut sink)
            .1
            .unwrap();
    });
    glint::sink::Sink::finish(&mut sink).unwrap();
    stop.store(true, Ordering::Relaxed);
    let received = reader.join().unwrap();
    let stats = sink.stats();
    assert!(
        stats.positions as usize > count / 2 && stats.speeds > 0,
        "{stats:?}"
    );
    assert!(
        stats.sent > 0 && received > 0,
        "{stats:?}, {received} bytes"
    );
    assert_eq!(allocations, 0, "allocations during {count} frames");
}

/// Identification (asking robots in turn, judging the frames after each request, unbinding
/// tracks that meet) allocates nothing per frame.
#[test]
fn identification_allocates_nothing_per_frame() {
    use glint::identify::{Identifier, IdentifyConfig, TrackSeen};

    const PERIOD_US: u64 = 33_333;
    let mut id = Identifier::<16>::new(IdentifyConfig::new(4, PERIOD_US)).unwrap();
    let mut tracks = [TrackSeen::default(); 4];
    // Robot k's LED is off during off[k]; robots 2 and 3 meet halfway through.
    let mut off = [(0u64, 0u64); 4];
    let mut bound = 0;
    let allocations = allocations_during(|| {
        for frame in 1..=900u64 {
            let now_us = frame * PERIOD_US;
            let meeting = (400..430).contains(&frame);
            for (k, t) in tracks.iter_mut().enumerate() {
                let (from, until) = off[k];
                t.visible = !(from..until).contains(&now_us);
                t.x_px = if meeting && k >= 2 {
                    300.0 + k as f32
                } else {
                    100.0 * k as f32
                };
                t.y_px = 50.0;
            }
            let step = id.step(now_us, &tracks);
            if let Some(r) = step.request {
                let from = now_us + 10_000 + u64::from(r.delay_us);
                off[usize::from(r.robot) - 1] = (from, from + u64::from(r.off_us));
            }
            bound = (0..4)
                .filter(|&s| id.robot_of(s) == Some(s as u8 + 1))
                .count();
        }
    });
    assert_eq!(bound, 4, "every robot identified by the end");
    assert!(id.stats().unbound >= 2, "the meeting unbound two tracks");
    assert_eq!(allocations, 0);
}

#[test]
fn several_robots_allocate_nothing_per_frame() {
    use glint::sink::Tee;
    use glint::track::{MultiTracker, TrackerConfig, MAX_ROBOTS};
    use glint_tools::scene::Fleet;

    let fleet = Fleet::preset("fleet-meeting").unwrap();
    let scene = fleet.robot(0).unwrap();
    let size = FrameSize::new(scene.width_px(), scene.height_px()).unwrap();
    let mut bytes = vec![0u8; scene.frame_len_bytes() * scene.frame_count()];
    for (i, out) in bytes.chunks_exact_mut(scene.frame_len_bytes()).enumerate() {
        fleet.render(i, out).unwrap();
    }
    let tracker = TrackerConfig {
        exposure_us: Some(scene.exposure_us()),
    };
    let config = PipelineConfig {
        tracker,
        ..PipelineConfig::default()
    };
    // The largest tables, with a floor stage mapping every track.
    let tracks = MultiTracker::new(MAX_ROBOTS, tracker).unwrap();
    let mut pipeline = Pipeline::several(size, config, tracks)
        .unwrap()
        .with_floor(reference_floor());
    let mut source = DumpSource::new(Cursor::new(&bytes), size, 30.0);
    let out = || BufWriter::with_capacity(64 * 1024, io::sink());
    let mut sink = Tee::new(JsonLinesSink::new(out(), false), CsvSink::new(out(), false));
    let mut summary = None;
    let allocations = allocations_during(|| {
        let (s, result) = pipeline::run(&mut source, &mut pipeline, &mut sink);
        result.unwrap();
        summary = Some(s);
    });
    let summary = summary.unwrap();
    assert_eq!(summary.frames, scene.frame_count() as u64);
    assert!(summary.found > summary.frames / 2, "tracked: {summary:?}");
    assert_eq!(
        allocations, 0,
        "allocations during {} frames",
        summary.frames
    );
}

/// Identification in the pipeline and the shared line's robot positions and LED requests
/// allocate nothing per frame either (the robots here never answer: every attempt is retried).
#[test]
fn identifying_several_robots_over_a_shared_line_allocates_nothing_per_frame() {
    use glint::identify::IdentifyConfig;
    use glint::sink::Tee;
    use glint::track::{MultiTracker, TrackerConfig, MAX_ROBOTS};
    use glint_tools::scene::Fleet;
    use serialport::SerialPort;
    use std::io::Read;
    use std::sync::atomic::{AtomicBool, Ordering};
    use std::sync::Arc;

    let fleet = Fleet::preset("fleet-crossing").unwrap();
    let scene = fleet.robot(0).unwrap();
    let size = FrameSize::new(scene.width_px(), scene.height_px()).unwrap();
    let mut bytes = vec![0u8; scene.frame_len_bytes() * scene.frame_count()];
    for (i, out) in bytes.chunks_exact_mut(scene.frame_len_bytes()).enumerate() {
        fleet.render(i, out).unwrap();
    }
    let tracker = TrackerConfig {
        exposure_us: Some(scene.exposure_us()),
    };
    let config = PipelineConfig {
        tracker,
        ..PipelineConfig::default()
    };
    let tracks = MultiTracker::new(MAX_ROBOTS, tracker).unwrap();
    let identify = IdentifyConfig::new(MAX_ROBOTS as u8, (1e6 / scene.fps()).round() as u64);
    let mut pipeline = Pipeline::several(size, config, tracks)
        .unwrap()
        .with_identify(identify)
        .unwrap();
    let (mut master, slave) = serialport::TTYPort::pair().expect("pty pair");
    let name = slave.name().expect("slave name");
    let stop = Arc::new(AtomicBool::new(false));
    let reader = {
        let stop = Arc::clone(&stop);
        std::thread::spawn(move || {
            let mut buf = [0u8; 1024];
            while !stop.load(Ordering::Relaxed) {
                let _ = master.read(&mut buf);
            }
        })
    };
    let mut source = DumpSource::new(Cursor::new(&bytes), size, scene.fps());
    let json = JsonLinesSink::new(BufWriter::with_capacity(64 * 1024, io::sink()), false);
    let mut sink = Tee::new(
        json,
        SerialSink::open(&name, 115_200).expect("open the pty"),
    );
    let allocations = allocations_during(|| {
        pipeline::run(&mut source, &mut pipeline, &mut sink)
            .1
            .unwrap();
    });
    stop.store(true, Ordering::Relaxed);
    reader.join().unwrap();
    let (_, serial) = sink.into_parts();
    let stats = serial.stats();
    assert!(stats.led_requests >= 2, "identification asked: {stats:?}");
    assert!(stats.updates > 0, "{stats:?}");
    assert_eq!(
        allocations,
        0,
        "allocations during {} frames",
        scene.frame_count()
    );
}

/// Publishing (`--publish`): the tracking thread only copies each report into the publish
/// queue, whether it has room or not; the publisher thread, which may allocate, sends them on a
/// real Zenoh session (listening on the loopback only, no scouting, nobody subscribed).
#[cfg(feature = "net")]
#[test]
fn publishing_allocates_nothing_on_the_tracking_thread() {
    use glint::net::{Keys, PublishConfig, PublishSink, QUEUE_REPORTS};
    use glint::sink::Sink;
    use glint::source::FrameSource;

    let &(size, ref bytes, count) = frames();
    let config = PublishConfig {
        keys: Keys::new("glint/alloc-test", "cam", 0).unwrap(),
        connect: Vec::new(),
        listen: vec!["tcp/127.0.0.1:0".into()],
    };
    let mut sink = PublishSink::start(&config).unwrap();
    let mut source = DumpSource::new(Cursor::new(&bytes), size, 30.0);
    let mut pipeline = Pipeline::new(size, PipelineConfig::default())
        .unwrap()
        .with_floor(reference_floor());
    let allocations = allocations_during(|| {
        let (s, result) = pipeline::run(&mut source, &mut pipeline, &mut sink);
        result.unwrap();
        assert!(s.found > s.frames / 2, "{s:?}");
    });
    assert_eq!(
        allocations, 0,
        "allocations during {count} published frames"
    );

    let published = sink.stats();
    assert_eq!(
        published.queued + published.dropped,
        count as u64,
        "{published}"
    );
    assert_eq!(
        published.sent + published.failed,
        published.queued,
        "{published}"
    );

    // A burst faster than the publisher thread: the full queue drops, without allocating. How
    // many writes it takes to fill the queue depends on how the threads are scheduled (a CI run
    // once saw the publisher keep up with 128), so the burst goes on until the first drop, up
    // to far more writes than a bounded queue of QUEUE_REPORTS could ever absorb.
    let mut sink = PublishSink::start(&config).unwrap();
    let mut source = DumpSource::new(Cursor::new(&bytes), size, 30.0);
    let mut pipeline = Pipeline::new(size, PipelineConfig::default()).unwrap();
    let (frame, meta) = source.next_frame().unwrap().expect("a frame");
    let report = pipeline.process(&frame, meta);
    let most_writes = 10_000 * QUEUE_REPORTS as u64;
    let mut burst = 0;
    let allocations = allocations_during(|| {
        while burst < most_writes && sink.stats().dropped == 0 {
            sink.write(&report).unwrap();
            burst += 1;
        }
    });
    assert_eq!(allocations, 0, "allocations during a burst of {burst}");
    sink.finish().unwrap();
    let stats = sink.stats();
    assert_eq!(stats.queued + stats.dropped, burst, "{stats}");
    assert!(
        stats.dropped > 0,
        "{burst} writes never overflowed the queue: {stats}"
    );
    assert_eq!(stats.sent + stats.failed, stats.queued, "{stats}");
}
