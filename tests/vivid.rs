//! Capture against a real V4L2 driver: the kernel's `vivid` virtual video driver, in a small
//! qemu VM (tests/vm/). One boot runs all scenarios (tests/vm/guest-suite.sh) with the
//! `capture_probe` example and the real `glint` binary as the guest programs; each test below
//! checks one scenario's output. The LED scenes fed through vivid's output→capture loop are
//! rendered here with the scene renderer, so their ground truth is known.
//!
//! Needs the packages of tools/setup-system.sh. `GLINT_SKIP_VM=1` skips these tests (loudly);
//! otherwise a VM that fails to boot fails them.

#![cfg(feature = "v4l2")]

mod common;

use std::collections::HashMap;
use std::fs;
use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::OnceLock;
use std::time::Instant;

use glint::frame::PixelFormat;
use glint_tools::scene::{Scene, Truth};
use serde_json::Value;

/// Frames a slow LED may stay ambiguous at the start, before it has moved enough to be told
/// from glare.
const MAX_ACQUIRE_FRAMES: usize = 3;

const WIDTH_PX: usize = 640;
const HEIGHT_PX: usize = 480;
const ROW_BYTES: usize = WIDTH_PX * 2;
/// Distinct pictures fed through vivid's loop.
const LOOP_FRAMES: u8 = 6;
/// The LED scene fed through the loop for `glint track --device`: every `SCENE_STEP`-th frame
/// of the preset, so that the fed LED positions are 40 px apart and each report can be matched
/// to the one frame it came from, however vivid repeats or skips frames.
const SCENE: &str = "slow-line";
const SCENE_STEP: usize = 20;
const SCENE_FRAMES: u8 = 8;
/// Streak middles found in the loop's frames are within this of the scene's truth (the p95
/// bound of tests/replay_accuracy.rs).
const MID_MAX_ERROR_PX: f64 = 0.5;
/// The reported position (the streak's head, the LED at the end of the exposure) is within this
/// of the scene's truth: the bound issue 11 sets for an LED through a real V4L2 driver.
const HEAD_MAX_ERROR_PX: f64 = 1.5;
/// Frames `glint record` records in the guest.
const RECORD_FRAMES: usize = 12;
/// The fast LED scene fed as a mono camera's GREY and as UYVY: every `FAST_STEP`-th frame of
/// the preset from `FAST_FIRST` on, streaks 13 to 40 px long, on one straight line, their heads
/// 53 to 106 px apart, so that each report matches one fed frame and the frames before it on
/// the path lie behind its streak (30 px behind its tail at least).
const FAST_SCENE: &str = "speed-ramp";
const FAST_FIRST: usize = 11;
const FAST_STEP: usize = 2;
const FAST_FRAMES: u8 = 8;
/// The formats the fast scene is fed in, as `--format-in` names them.
const FAST_FORMATS: [PixelFormat; 2] = [PixelFormat::Grey, PixelFormat::Uyvy];
/// The middle of a streak whose LED speeds up or brakes is not where the LED was at the middle
/// of the exposure (the truth's middle): the two differ by the acceleration times the
/// exposure squared over 8, 0.49 px at most in the fast scene. Middles are held to the
/// accuracy bound plus that.
const FAST_MID_MAX_ERROR_PX: f64 = MID_MAX_ERROR_PX + 0.5;
/// Frames `glint record` records of the fast scene, per format. It nearly keeps up with
/// vivid's 60 fps in the guest, so its frames come in the fed order, with repeats when the
/// feeder is late (see [`check_fast_run`]).
const FAST_RECORD_FRAMES: usize = 24;
/// Reports `glint track --device` gives on the fast scene, per format, at least (the guest
/// stops it after these).
const FAST_TRACK_REPORTS: usize = 5;
/// Frames of the recordings whose head is checked (see [`check_fast_run`]), over both formats,
/// at least. `glint track --device`'s few reports are checked wherever their frames come in
/// order, but no number of them is: its first frames are vivid's next few (the buffers fill
/// while glint starts), repeats included, and its later ones whichever fed frame is showing;
/// one to six heads in a run here. The frames are byte-identical to the recorded ones, so
/// the recordings' replays hold the heads of the same pixels.
const MIN_RECORDED_HEADS_CHECKED: usize = 6;

/// The scenario outputs, read once.
struct Suite {
    out: PathBuf,
}

static SUITE: OnceLock<Result<Suite, String>> = OnceLock::new();

/// The suite's output, booting the VM on first use; `None` when skipped.
fn suite() -> Option<&'static Suite> {
    if common::skipped("GLINT_SKIP_VM", "V4L2 capture on the vivid VM") {
        return None;
    }
    match SUITE.get_or_init(run_suite) {
        Ok(suite) => Some(suite),
        Err(e) => panic!("vivid VM suite failed to run: {e}"),
    }
}

fn repo() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// The probe `cargo test` built beside this test (examples are built with the tests).
fn probe_binary() -> Result<PathBuf, String> {
    let exe = std::env::current_exe().map_err(|e| e.to_string())?;
    // target/<profile>/deps/vivid-HASH → target/<profile>/examples/capture_probe
    let profile_dir = exe
        .parent()
        .and_then(Path::parent)
        .ok_or("cannot locate the target directory")?;
    let probe = profile_dir.join("examples").join("capture_probe");
    if probe.exists() {
        Ok(probe)
    } else {
        Err(format!(
            "{} is missing: run the whole `cargo test` (which builds examples) or `cargo build --example capture_probe` first",
            probe.display()
        ))
    }
}

/// Frame `k` of the loop input: a gradient with a bright disk whose place depends on `k`, and
/// the frame id in the first four luma bytes. Values stay in video range (16..=235).
fn loop_frame(k: u8) -> Vec<u8> {
    let mut frame = vec![0u8; ROW_BYTES * HEIGHT_PX];
    let (cx, cy, r) = (80 + 90 * i64::from(k), 240i64, 24i64);
    for (y, row) in frame.chunks_exact_mut(ROW_BYTES).enumerate() {
        for (x, px) in row.chunks_exact_mut(2).enumerate() {
            let (dx, dy) = (x as i64 - cx, y as i64 - cy);
            px[0] = if dx * dx + dy * dy <= r * r {
                235
            } else {
                (16 + (x + y) % 160) as u8
            };
            // U on even pixels, V on odd ones.
            px[1] = if x % 2 == 0 { 100 + k * 5 } else { 160 - k * 5 };
        }
    }
    for (i, b) in loop_frame_id(k).to_le_bytes().into_iter().enumerate() {
        frame[2 * i] = b;
    }
    frame
}

fn loop_frame_id(k: u8) -> u32 {
    u32::from_le_bytes([0x40 + k, 0x51, 0x62, 0x73])
}

/// Frame id of scene frame `k`, in the first four luma bytes (all far below saturation).
fn scene_frame_id(k: u8) -> u32 {
    u32::from_le_bytes([0x20 + k, 0x31, 0x42, 0x53])
}

/// Frame id of fast scene frame `k`.
fn fast_frame_id(k: u8) -> u32 {
    u32::from_le_bytes([0x60 + k, 0x71, 0x82, 0x93])
}

/// The id in the first four luma bytes of a YUYV frame.
fn luma_id(frame: &[u8]) -> u32 {
    luma_id_as(frame, PixelFormat::Yuyv)
}

/// The id in the first four luma bytes of a frame of `format`.
fn luma_id_as(frame: &[u8], format: PixelFormat) -> u32 {
    let luma = |i: usize| frame[i * format.bytes_per_pixel() + format.luma_offset()];
    u32::from_le_bytes([luma(0), luma(1), luma(2), luma(3)])
}

/// `count` frames of preset `name`, every `step`-th from `first` on, as YUYV with their ids
/// (`id(k)`) written into the first luma bytes, and their truths.
fn feed(
    name: &str,
    first: usize,
    step: usize,
    count: u8,
    id: fn(u8) -> u32,
) -> (Vec<u8>, Vec<Truth>) {
    let scene = Scene::preset(name).expect("scene preset");
    assert_eq!((scene.width_px(), scene.height_px()), (640, 480));
    let mut bytes = Vec::new();
    let mut truths = Vec::new();
    let mut frame = vec![0u8; scene.frame_len_bytes()];
    for k in 0..count {
        truths.push(
            scene
                .render(first + usize::from(k) * step, &mut frame)
                .expect("render"),
        );
        for (i, b) in id(k).to_le_bytes().into_iter().enumerate() {
            frame[2 * i] = b;
        }
        bytes.extend_from_slice(&frame);
    }
    (bytes, truths)
}

/// The slow scene frames fed through the loop as YUYV, and their truths.
fn scene_feed() -> (Vec<u8>, Vec<Truth>) {
    feed(SCENE, 0, SCENE_STEP, SCENE_FRAMES, scene_frame_id)
}

/// The fast scene frames (YUYV, to be repacked), and their truths.
fn fast_feed() -> (Vec<u8>, Vec<Truth>) {
    feed(
        FAST_SCENE,
        FAST_FIRST,
        FAST_STEP,
        FAST_FRAMES,
        fast_frame_id,
    )
}

/// The fed scene frame whose truth lies nearest to a report's streak middle, and how far.
fn nearest_truth(report: &Value, truths: &[Truth]) -> (usize, f64) {
    let (x, y) = (
        report["mid_x"].as_f64().expect("mid_x"),
        report["mid_y"].as_f64().expect("mid_y"),
    );
    truths
        .iter()
        .enumerate()
        .map(|(k, t)| {
            let d = (t.mid_x_px.expect("visible") - x).hypot(t.mid_y_px.expect("visible") - y);
            (k, d)
        })
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .expect("some truths")
}

/// A found report's streak middle and head are where the fed frame's truth puts them.
fn assert_on_truth(report: &Value, truth: &Truth) {
    assert_near_truth(report, truth, MID_MAX_ERROR_PX, true);
}

/// A found report's streak middle is within `mid_max_px` of the fed frame's truth, and, when
/// `check_head`, its head within [`HEAD_MAX_ERROR_PX`]; returns the head's distance.
fn assert_near_truth(report: &Value, truth: &Truth, mid_max_px: f64, check_head: bool) -> f64 {
    let at = |x: &str, y: &str| {
        (
            report[x]
                .as_f64()
                .unwrap_or_else(|| panic!("{report}: {x}")),
            report[y]
                .as_f64()
                .unwrap_or_else(|| panic!("{report}: {y}")),
        )
    };
    let (mid_x, mid_y) = at("mid_x", "mid_y");
    let mid_px =
        (mid_x - truth.mid_x_px.expect("visible")).hypot(mid_y - truth.mid_y_px.expect("visible"));
    assert!(
        mid_px <= mid_max_px,
        "{report}: middle {mid_px:.3} px from scene frame {}'s",
        truth.frame
    );
    let (x, y) = at("x", "y");
    let head_px = (x - truth.x_px.expect("visible")).hypot(y - truth.y_px.expect("visible"));
    assert!(
        !check_head || head_px <= HEAD_MAX_ERROR_PX,
        "{report}: head {head_px:.3} px from scene frame {}'s",
        truth.frame
    );
    head_px
}

/// The probe's frame hash: FNV-1a 64 over the unpadded rows.
fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325, |h, &b| {
        (h ^ u64::from(b)).wrapping_mul(0x0000_0100_0000_01b3)
    })
}

fn run_suite() -> Result<Suite, String> {
    let probe = probe_binary()?;
    // Cargo's per-target scratch directory: reused (not accumulated) across runs, and kept
    // after a failure for a look at the guest's logs.
    let share = Path::new(env!("CARGO_TARGET_TMPDIR")).join("vivid-vm");
    let _ = fs::remove_dir_all(&share);
    fs::create_dir_all(share.join("in")).map_err(|e| e.to_string())?;
    // Without its debug info the probe is 10x smaller, which saves seconds of 9p copying
    // under TCG; copy it whole where binutils' strip is missing.
    let stripped = Command::new("strip")
        .arg("-o")
        .arg(share.join("capture_probe"))
        .arg(&probe)
        .status()
        .is_ok_and(|s| s.success());
    if !stripped {
        fs::copy(&probe, share.join("capture_probe")).map_err(|e| e.to_string())?;
    }
    fs::copy(
        repo().join("tests/vm/guest-suite.sh"),
        share.join("guest.sh"),
    )
    .map_err(|e| e.to_string())?;
    // The real glint binary, stripped like the probe.
    let glint = Path::new(env!("CARGO_BIN_EXE_glint"));
    let stripped = Command::new("strip")
        .arg("-o")
        .arg(share.join("glint"))
        .arg(glint)
        .status()
        .is_ok_and(|s| s.success());
    if !stripped {
        fs::copy(glint, share.join("glint")).map_err(|e| e.to_string())?;
    }
    let input: Vec<u8> = (0..LOOP_FRAMES).flat_map(loop_frame).collect();
    fs::write(share.join("in/loop.yuv"), input).map_err(|e| e.to_string())?;
    fs::write(share.join("in/scene.yuv"), scene_feed().0).map_err(|e| e.to_string())?;
    let fast = fast_feed().0;
    for format in FAST_FORMATS {
        fs::write(
            share.join(format!("in/fast.{format}")),
            common::repack(&fast, format),
        )
        .map_err(|e| e.to_string())?;
    }

    let started = Instant::now();
    let prepare = Command::new(repo().join("tests/vm/prepare.sh"))
        .output()
        .map_err(|e| format!("tests/vm/prepare.sh: {e}"))?;
    if !prepare.status.success() {
        return Err(format!(
            "tests/vm/prepare.sh failed: {}",
            String::from_utf8_lossy(&prepare.stderr)
        ));
    }
    let prepared = Instant::now();
    let run = Command::new(repo().join("tests/vm/run.sh"))
        .arg(&share)
        .output()
        .map_err(|e| format!("tests/vm/run.sh: {e}"))?;
    let guest_log = fs::read_to_string(share.join("guest.log")).unwrap_or_default();
    if !run.status.success() {
        return Err(format!(
            "tests/vm/run.sh failed ({}): {}\nguest log:\n{guest_log}",
            run.status,
            String::from_utf8_lossy(&run.stderr)
        ));
    }
    let timing = fs::read_to_string(share.join("out/timing")).unwrap_or_default();
    eprintln!(
        "vivid VM suite: prepare {:.1} s, VM run {:.1} s; guest uptime marks: {}",
        (prepared - started).as_secs_f64(),
        prepared.elapsed().as_secs_f64(),
        timing.replace('\n', ", ")
    );
    Ok(Suite {
        out: share.join("out"),
    })
}

/// One JSON line of the probe, as flat `key → raw value` (the probe prints no nesting).
#[derive(Debug)]
struct Line(HashMap<String, String>);

impl Line {
    fn parse(line: &str) -> Line {
        let body = line.trim().trim_start_matches('{').trim_end_matches('}');
        let mut map = HashMap::new();
        let mut rest = body;
        while let Some(key_start) = rest.find('"') {
            let after = &rest[key_start + 1..];
            let Some(key_end) = after.find('"') else {
                break;
            };
            let key = &after[..key_end];
            let value_part = after[key_end + 1..].trim_start_matches(':');
            let (value, next) = if let Some(s) = value_part.strip_prefix('"') {
                let mut end = 0;
                let bytes = s.as_bytes();
                while end < bytes.len()
                    && !(bytes[end] == b'"' && (end == 0 || bytes[end - 1] != b'\\'))
                {
                    end += 1;
                }
                (s[..end].to_string(), s.get(end + 1..).unwrap_or(""))
            } else {
                let end = value_part.find(',').unwrap_or(value_part.len());
                (value_part[..end].to_string(), &value_part[end..])
            };
            map.insert(key.to_string(), value);
            rest = next.trim_start_matches(',');
        }
        Line(map)
    }

    fn str(&self, key: &str) -> &str {
        self.0.get(key).map_or("", String::as_str)
    }

    fn num(&self, key: &str) -> u64 {
        self.str(key)
            .parse()
            .unwrap_or_else(|_| panic!("{key} is not a number in {self:?}"))
    }
}

impl Suite {
    fn lines(&self, name: &str) -> Vec<Line> {
        fs::read_to_string(self.out.join(format!("{name}.jsonl")))
            .unwrap_or_default()
            .lines()
            .map(Line::parse)
            .collect()
    }

    fn frames(&self, name: &str) -> Vec<Line> {
        self.lines(name)
            .into_iter()
            .filter(|l| l.str("event") == "frame")
            .collect()
    }

    fn status(&self, name: &str) -> String {
        fs::read_to_string(self.out.join(format!("{name}.status")))
            .unwrap_or_default()
            .trim()
            .to_string()
    }

    fn log(&self, name: &str) -> String {
        fs::read_to_string(self.out.join(format!("{name}.err"))).unwrap_or_default()
    }

    fn file(&self, name: &str) -> String {
        fs::read_to_string(self.out.join(name)).unwrap_or_default()
    }

    /// glint's own JSON lines, parsed strictly.
    fn reports(&self, name: &str) -> Vec<Value> {
        common::parse_jsonl(&fs::read(self.out.join(format!("{name}.jsonl"))).unwrap_or_default())
    }
}

/// Sequence numbers step by one plus the drops reported, and time only moves forward.
fn assert_timeline(frames: &[Line]) {
    assert_eq!(frames[0].num("t_us"), 0, "the first frame is t = 0");
    for (i, pair) in frames.windows(2).enumerate() {
        let (a, b) = (&pair[0], &pair[1]);
        assert_eq!(b.num("index"), a.num("index") + 1, "frame {i}: index");
        assert_eq!(
            b.num("seq"),
            a.num("seq") + 1 + b.num("dropped"),
            "frame {i}: sequence step vs dropped"
        );
        assert!(
            b.num("t_us") > a.num("t_us"),
            "frame {i}: time must increase"
        );
    }
}

#[test]
fn test_pattern_capture_negotiates_and_times_frames() {
    let Some(suite) = suite() else { return };
    assert_eq!(
        suite.status("pattern"),
        "0",
        "probe log: {}",
        suite.log("pattern")
    );
    let lines = suite.lines("pattern");
    let open = lines.first().expect("an open line");
    assert_eq!(open.str("event"), "open");
    assert_eq!((open.num("width"), open.num("height")), (640, 480));
    assert!(open.num("stride") >= 1280);
    assert_eq!(open.str("fps"), "10.000");
    assert_eq!(open.num("buffers"), 3, "the buffer count asked for");

    let frames = suite.frames("pattern");
    assert_eq!(frames.len(), 12);
    assert!(frames.iter().all(|f| f.num("stride") == open.num("stride")));
    assert_timeline(&frames);
    // Real capture times, not counters: 11 intervals at 10 fps span about 1.1 s.
    let span_us = frames[11].num("t_us");
    assert!(
        (550_000..=3_300_000).contains(&span_us),
        "11 frames at 10 fps took {span_us} µs"
    );
    // vivid's picture carries a running counter: every frame differs.
    let hashes: std::collections::HashSet<_> = frames.iter().map(|f| f.str("hash")).collect();
    assert_eq!(hashes.len(), frames.len());
}

#[test]
fn controls_report_what_was_set_and_refused() {
    let Some(suite) = suite() else { return };
    let controls = suite
        .lines("pattern")
        .into_iter()
        .find(|l| l.str("event") == "controls")
        .expect("a controls line");
    let report = controls.str("report");
    assert!(
        report.contains("set brightness = 200 (now 200)"),
        "{report}"
    );
    assert!(
        report.contains("refused no_such_control = 1: the camera has no such control"),
        "{report}"
    );
    assert!(
        report.contains("exposure_time_absolute = 5 (500 µs"),
        "{report}"
    );
    assert_eq!(controls.num("set"), 1, "{report}");
}

#[test]
fn unsupported_formats_are_refused_with_what_the_camera_offers() {
    let Some(suite) = suite() else { return };
    for name in ["bad_size", "bad_fps"] {
        assert_eq!(
            suite.status(name),
            "2",
            "{name} exits with an error, not a panic"
        );
        let error = suite.lines(name).into_iter().last().expect("an error line");
        assert_eq!(error.str("event"), "error");
        let message = error.str("message");
        assert!(message.contains("The camera offers:"), "{message}");
        assert!(
            message.contains("640x480 @ 1, 2, 4, 5, 10, 12.5, 15, 25 fps"),
            "{message}"
        );
    }
    assert!(suite.lines("bad_size")[0]
        .str("message")
        .contains("cannot capture YUYV 800x600"));
    assert!(suite.lines("bad_fps")[0]
        .str("message")
        .contains("at 30 fps"));
}

#[test]
fn devices_lists_vivid_with_formats_and_controls() {
    let Some(suite) = suite() else { return };
    let list = suite.file("list.txt");
    assert!(list.contains("/dev/video0: vivid (driver vivid"), "{list}");
    assert!(list.contains("YUYV (YUYV 4:2:2): 320x180 @"), "{list}");
    assert!(list.contains("brightness (int 0..=255 step 1"), "{list}");
    // Output-only nodes are not capture devices.
    assert!(!list.contains("/dev/video1:"), "{list}");
}

/// `glint row-time --device` reads the camera's frames and, the loop's LED scene having no
/// flicker bands, gives no row time: one line and exit status 1, nothing on standard output.
#[test]
fn row_time_reads_a_camera_and_gives_no_number_without_bands() {
    let Some(suite) = suite() else { return };
    let log = suite.log("row_time");
    assert_eq!(suite.status("row_time"), "1", "{log}");
    assert!(log.contains("glint: no row time from 12 frames: "), "{log}");
    assert_eq!(suite.file("row_time.out"), "", "{log}");
}

#[test]
fn loopback_frames_come_back_byte_exact() {
    let Some(suite) = suite() else { return };
    assert_eq!(
        suite.status("loop"),
        "0",
        "probe log: {}",
        suite.log("loop")
    );
    let fed: HashMap<u64, String> = (0..LOOP_FRAMES)
        .map(|k| {
            (
                u64::from(loop_frame_id(k)),
                format!("{:016x}", fnv1a(&loop_frame(k))),
            )
        })
        .collect();
    let frames = suite.frames("loop");
    assert_eq!(frames.len(), 16);
    for frame in &frames {
        let id = frame.num("id");
        let expected = fed
            .get(&id)
            .unwrap_or_else(|| panic!("frame {} carries unknown id {id:#x}", frame.num("index")));
        assert_eq!(
            frame.str("hash"),
            expected,
            "frame {} (id {id:#x})",
            frame.num("index")
        );
    }
    let ids: std::collections::HashSet<_> = frames.iter().map(|f| f.num("id")).collect();
    assert!(
        ids.len() >= 2,
        "the loop should advance through the fed frames: {ids:?}"
    );
    assert_timeline(&frames);
}

#[test]
fn a_vanishing_device_is_a_typed_error_not_a_panic() {
    let Some(suite) = suite() else { return };
    let log = suite.log("unplug_plain");
    assert_eq!(suite.status("unplug_plain"), "2", "log: {log}");
    assert!(!log.contains("panicked"), "{log}");
    assert!(
        suite.frames("unplug_plain").len() >= 3,
        "frames before the unbind"
    );
    let last = suite
        .lines("unplug_plain")
        .into_iter()
        .last()
        .expect("output");
    assert_eq!(last.str("event"), "error");
    assert_eq!(last.str("disconnected"), "true", "{:?}", last);
}

#[test]
fn the_reopening_source_resumes_after_the_device_returns() {
    let Some(suite) = suite() else { return };
    let log = suite.log("unplug_reopen");
    assert_eq!(suite.status("unplug_reopen"), "0", "log: {log}");
    assert!(!log.contains("panicked"), "{log}");
    assert!(log.contains("disappeared"), "the fault is logged: {log}");
    assert!(log.contains("reopened, resuming capture"), "{log}");
    let frames = suite.frames("unplug_reopen");
    assert_eq!(frames.len(), 30);
    assert_timeline(&frames);
    // The outage (1 s unbound) shows as one long gap in frame time, not as a reset to 0.
    let longest_gap_us = frames
        .windows(2)
        .map(|p| p[1].num("t_us") - p[0].num("t_us"))
        .max()
        .unwrap_or(0);
    assert!(longest_gap_us >= 900_000, "longest gap {longest_gap_us} µs");
    let end = suite
        .lines("unplug_reopen")
        .into_iter()
        .last()
        .expect("output");
    assert_eq!(end.str("event"), "end");
    assert!(end.num("reopens") >= 1);
}

/// The reports of `glint track` replaying the 640×480 dump at `path` on the host, with `args`;
/// the run must succeed (`label` names the case in the message).
fn replay_on_host(path: &Path, args: &[&str], label: &str) -> Vec<Value> {
    let out = common::glint()
        .args(["track", "--input"])
        .arg(path)
        .args(["--size", "640x480"])
        .args(args)
        .output()
        .expect("run glint");
    assert!(
        out.status.success(),
        "{label}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    common::parse_jsonl(&out.stdout)
}

/// glint's reports: frames numbered from 0, time from 0 and rising, sequence numbers stepping
/// by one plus the drops reported.
fn assert_report_timeline(reports: &[Value]) {
    assert_eq!(
        reports[0]["t"].as_f64(),
        Some(0.0),
        "the first frame is t = 0"
    );
    for (i, pair) in reports.windows(2).enumerate() {
        let (a, b) = (&pair[0], &pair[1]);
        let n = |v: &Value, k: &str| v[k].as_u64().unwrap_or_else(|| panic!("{k} in {v}"));
        assert_eq!(n(b, "frame"), n(a, "frame") + 1, "report {i}: frame");
        assert_eq!(
            n(b, "seq"),
            n(a, "seq") + 1 + n(b, "dropped"),
            "report {i}: sequence step vs dropped"
        );
        assert!(
            b["t"].as_f64() > a["t"].as_f64(),
            "report {i}: time must increase"
        );
    }
}

#[test]
fn scene_frames_come_back_through_the_loop_byte_exact() {
    let Some(suite) = suite() else { return };
    assert_eq!(
        suite.status("scene_loop"),
        "0",
        "{}",
        suite.log("scene_loop")
    );
    let (bytes, _) = scene_feed();
    let fed: HashMap<u64, String> = bytes
        .chunks_exact(ROW_BYTES * HEIGHT_PX)
        .map(|f| (u64::from(luma_id(f)), format!("{:016x}", fnv1a(f))))
        .collect();
    let frames = suite.frames("scene_loop");
    assert_eq!(frames.len(), 8);
    for frame in &frames {
        let id = frame.num("id");
        assert_eq!(
            Some(frame.str("hash")),
            fed.get(&id).map(String::as_str),
            "frame {} (id {id:#x})",
            frame.num("index")
        );
    }
}

#[test]
fn glint_track_finds_the_led_of_a_scene_fed_through_the_loop() {
    let Some(suite) = suite() else { return };
    let log = suite.log("track");
    assert_eq!(
        suite.status("track"),
        "0",
        "SIGTERM ends glint cleanly: {log}"
    );
    assert!(!log.contains("panicked"), "{log}");
    // Every line is complete JSON: the output was flushed when the stream stopped.
    let reports = suite.reports("track");
    assert!(reports.len() >= 20, "{} reports; log: {log}", reports.len());
    assert_report_timeline(&reports);

    let (_, truths) = scene_feed();
    // A light that has not moved since it appeared is not taken (it could be glare): the first
    // frames of a slow LED may be ambiguous. From the first found frame on, it is found.
    let waited = reports
        .iter()
        .take_while(|r| r["found"] != true && r["ambiguous"] == true)
        .count();
    let counted = &reports[waited..];
    let found: Vec<&Value> = counted.iter().filter(|r| r["found"] == true).collect();
    // The guest's capture skips pictures at random, so the LED may jump 100 to 270 px between
    // captured frames, and a light far from the prediction is not taken at once.
    assert!(
        found.len() * 4 >= counted.len() * 3,
        "the LED is found in {} of {} frames after {waited} ambiguous ones",
        found.len(),
        counted.len()
    );
    let mut matched = Vec::new();
    for report in found {
        let (k, _) = nearest_truth(report, &truths);
        assert_on_truth(report, &truths[k]);
        matched.push(k);
    }
    let distinct: std::collections::HashSet<_> = matched.iter().collect();
    assert!(
        distinct.len() >= 2,
        "the loop advances through the fed frames: {matched:?}"
    );
    // How long the light waits to be taken depends on which pictures the capture happens to
    // see: a guest busy starting glint starves the feeder, and vivid repeats the last picture
    // for as long as that lasts. The rule itself is asserted frame by frame in
    // tests/acquisition.rs and on the recorded frames below, whose pictures are known; here the
    // wait only has to be a short start of the run.
    assert!(
        waited <= MAX_ACQUIRE_FRAMES.max(reports.len() / 3),
        "ambiguous for {waited} of {} frames: {matched:?}",
        reports.len()
    );
}

#[test]
fn glint_track_reports_controls_summaries_and_latency_on_stderr() {
    let Some(suite) = suite() else { return };
    let log = suite.log("track");
    assert!(
        log.contains("refused no_such_control = 1: the camera has no such control"),
        "{log}"
    );
    assert!(
        log.contains("YUYV 640x480 with rows 1280 bytes apart"),
        "{log}"
    );
    let summary = log
        .lines()
        .find(|l| l.contains("glint: info: last "))
        .unwrap_or_else(|| panic!("a periodic summary: {log}"));
    for part in [" frames (", " fps), ", " dropped (", "LED found in "] {
        assert!(summary.contains(part), "{part:?} in {summary}");
    }
    // The latency table, periodically and once more at the end.
    assert!(log.matches("dequeue→results").count() >= 2, "{log}");
    assert!(log.contains("glint: latency over "), "{log}");
}

#[test]
fn glint_record_writes_a_dump_and_sidecar_that_replays_with_the_real_timing() {
    let Some(suite) = suite() else { return };
    let log = suite.file("record.err");
    assert_eq!(suite.status("record"), "0", "{log}");
    assert!(
        log.contains(&format!("recorded {RECORD_FRAMES} frames")),
        "{log}"
    );
    let dump_path = suite.out.join("rec.yuv");
    let dump = fs::read(&dump_path).expect("the recorded dump");
    let frame_bytes = ROW_BYTES * HEIGHT_PX;
    assert_eq!(dump.len(), RECORD_FRAMES * frame_bytes);
    let sidecar: Value =
        serde_json::from_str(&suite.file("rec.yuv.json")).expect("the sidecar is JSON");
    assert_eq!(sidecar["format"], "YUYV");
    assert_eq!(
        (sidecar["width"].as_u64(), sidecar["height"].as_u64()),
        (Some(640), Some(480))
    );
    assert_eq!(sidecar["stride"].as_u64(), Some(ROW_BYTES as u64));
    assert!(sidecar["driver_stride"].as_u64() >= Some(ROW_BYTES as u64));
    assert_eq!(sidecar["device"], "/dev/video0");
    let timing = sidecar["frames"].as_array().expect("frames");
    assert_eq!(timing.len(), RECORD_FRAMES);

    // Replayed on the host, the dump carries the capture's times, sequence numbers and drops.
    let reports = replay_on_host(&dump_path, &[], "YUYV");
    assert_eq!(reports.len(), RECORD_FRAMES);
    assert_report_timeline(&reports);
    let (_, truths) = scene_feed();
    let mut previous_seq = None;
    let (mut waited, mut lost, mut found) = (0usize, 0usize, 0usize);
    // The first picture's id, and whether a later one has shown the LED elsewhere.
    let (mut first_id, mut moved) = (None, false);
    for ((report, t), frame) in reports
        .iter()
        .zip(timing)
        .zip(dump.chunks_exact(frame_bytes))
    {
        let seq = t["seq"].as_u64().expect("seq");
        let t_us = t["t_us"].as_u64().expect("t_us");
        assert_eq!(report["seq"].as_u64(), Some(seq), "{report}");
        assert_eq!(
            report["dropped"].as_u64(),
            Some(previous_seq.map_or(0, |p: u64| seq - p - 1)),
            "{report}"
        );
        previous_seq = Some(seq);
        let t_s = report["t"].as_f64().expect("t");
        assert!((t_s - t_us as f64 * 1e-6).abs() < 1e-6, "{report} vs {t}");
        // Which fed frame this is, by its id; the LED must be where that frame put it.
        let id = luma_id(frame);
        let k = (0..SCENE_FRAMES)
            .position(|k| scene_frame_id(k) == id)
            .unwrap_or_else(|| panic!("recorded frame with unknown id {id:#x}"));
        // The replay starts at the light's first appearance: a spot that has not moved yet is
        // not taken (it could be glare), so the frames are ambiguous while the capture repeats
        // the first picture (vivid repeats the last picture while the guest's feeder is
        // starved: one CI run recorded the first picture six times over), and for at most a
        // few frames after the LED first moved. The guest's capture skips pictures at random,
        // so the LED may jump 100 to 270 px between frames, and a light far from the
        // prediction is not taken at once: a few frames may be lost (see the loop test above).
        // Every frame that is found is where its picture put it.
        moved |= *first_id.get_or_insert(id) != id;
        if found == 0 && lost == 0 && report["ambiguous"] == true {
            waited += usize::from(moved);
            continue;
        }
        if report["found"] != true {
            lost += 1;
            continue;
        }
        found += 1;
        assert_on_truth(report, &truths[k]);
    }
    assert!(
        waited <= MAX_ACQUIRE_FRAMES,
        "ambiguous for {waited} of {} frames after the LED first moved",
        reports.len()
    );
    assert!(
        found * 4 >= (found + lost) * 3,
        "found in {found} of {} frames after {waited} ambiguous ones",
        found + lost
    );
}

#[test]
fn glint_devices_lists_the_loop_capture_node() {
    let Some(suite) = suite() else { return };
    let list = suite.file("devices.txt");
    assert!(list.contains("/dev/video0: vivid (driver vivid"), "{list}");
    assert!(list.contains("YUYV (YUYV 4:2:2)"), "{list}");
    assert!(list.contains(" controls:"), "{list}");
    assert!(
        !list.contains("/dev/video1:"),
        "output nodes are not cameras: {list}"
    );
}

/// The fast scene's frames as a camera of `format` sends them, and how many bytes each takes.
fn fast_pictures(format: PixelFormat) -> (Vec<u8>, usize) {
    let size = glint::frame::FrameSize::new(WIDTH_PX as u32, HEIGHT_PX as u32).expect("size");
    (
        common::repack(&fast_feed().0, format),
        size.frame_bytes_as(format),
    )
}

fn fourcc(format: PixelFormat) -> String {
    String::from_utf8_lossy(&format.fourcc()).into_owned()
}

/// Holds one run on the fast scene to its truths: `pictures[i]` is the fed frame report `i`
/// shows. Every found report's middle is checked; its head is checked when the report before
/// it found the LED in an earlier fed frame. The head is the streak's end farther from where
/// the LED was in the frame before (src/track), and a camera's frames come in the order of
/// the exposures. vivid's loop does not keep that order: a slow guest's capture takes
/// whichever fed frame is showing when it asks, so the LED may seem to jump back along its
/// path, or a frame may come twice, and then the streak's far end is its tail, the way no
/// camera's frames show it. Returns the checked heads' distances from the truth.
fn check_fast_run(reports: &[Value], pictures: &[Option<usize>], truths: &[Truth]) -> Vec<f64> {
    let mut heads_px = Vec::new();
    let mut previous = None;
    for (report, picture) in reports.iter().zip(pictures) {
        let Some(k) = picture.filter(|_| report["found"] == true) else {
            previous = None;
            continue;
        };
        let in_order = previous.is_some_and(|p| p < k);
        let head_px = assert_near_truth(report, &truths[k], FAST_MID_MAX_ERROR_PX, in_order);
        if in_order {
            heads_px.push(head_px);
        }
        previous = Some(k);
    }
    heads_px
}

/// The LED is found in at least half of a short run on the fast scene. A streak is taken in
/// the first frame it shows, but the guest's capture makes the LED jump back and forth along
/// its path, and a light far from the prediction is not taken at once (see the slow scene's
/// test, whose longer run is held to three frames in four).
fn assert_mostly_found(reports: &[Value], what: &dyn std::fmt::Display) {
    let found = reports.iter().filter(|r| r["found"] == true).count();
    assert!(
        found * 2 >= reports.len() && reports.first().is_some_and(|r| r["found"] == true),
        "{what}: the LED is found in {found} of {} frames",
        reports.len()
    );
}

/// The checked heads' worst and 95th percentile, on standard error for the README's figures,
/// and enough of them checked.
fn report_heads(what: &str, heads_px: &[f64], min_checked: usize) {
    assert!(
        heads_px.len() >= min_checked,
        "{what}: only {} heads checked",
        heads_px.len()
    );
    if heads_px.is_empty() {
        eprintln!("{what}: no frame in order, no head checked");
        return;
    }
    eprintln!(
        "{what}: {} heads checked, worst {:.3} px, p95 {:.3} px, median {:.3} px",
        heads_px.len(),
        common::quantile(heads_px, 1.0),
        common::quantile(heads_px, 0.95),
        common::quantile(heads_px, 0.5),
    );
}

#[test]
fn glint_records_grey_and_uyvy_cameras_byte_exact_and_the_records_replay() {
    let Some(suite) = suite() else { return };
    let (_, truths) = fast_feed();
    let mut heads_px = Vec::new();
    for format in FAST_FORMATS {
        let name = format!("record_{format}");
        let log = suite.log(&name);
        assert_eq!(suite.status(&name), "0", "{log}");
        assert!(
            log.contains(&format!("recorded {FAST_RECORD_FRAMES} frames")),
            "{log}"
        );
        let (fed, frame_bytes) = fast_pictures(format);
        let row_bytes = WIDTH_PX * format.bytes_per_pixel();
        let dump_path = suite.out.join(format!("fast-{format}.raw"));
        let dump = fs::read(&dump_path).expect("the recorded dump");
        assert_eq!(dump.len(), FAST_RECORD_FRAMES * frame_bytes, "{format}");
        let sidecar: Value = serde_json::from_str(&suite.file(&format!("fast-{format}.raw.json")))
            .expect("the sidecar is JSON");
        assert_eq!(sidecar["format"], fourcc(format));
        assert_eq!(sidecar["stride"].as_u64(), Some(row_bytes as u64));
        assert!(sidecar["driver_stride"].as_u64() >= Some(row_bytes as u64));

        // Each recorded frame is one fed frame, byte for byte: the driver's buffers were read
        // as `format`, and written without their padding.
        let pictures: Vec<Option<usize>> = dump
            .chunks_exact(frame_bytes)
            .map(|frame| {
                let k = fed.chunks_exact(frame_bytes).position(|p| p == frame);
                assert!(
                    k.is_some(),
                    "{format}: a recorded frame (id {:#x}) is none of the fed ones",
                    luma_id_as(frame, format)
                );
                k
            })
            .collect();

        // Replayed on the host without --format-in: the sidecar says what the frames are.
        let reports = replay_on_host(&dump_path, &[], &format.to_string());
        assert_eq!(reports.len(), FAST_RECORD_FRAMES, "{format}");
        assert_report_timeline(&reports);
        assert_mostly_found(&reports, &format);
        heads_px.extend(check_fast_run(&reports, &pictures, &truths));

        // vivid repeats a fed frame for as long as the feeder is late (a loaded guest's feeder
        // runs at 15-40 fps), and after a repeat the far end is the tail (see
        // `check_fast_run`). A camera never sends one exposure twice: the recording without
        // its repeats is replayed too, so that the heads of more frames are checked.
        let mut once = Vec::new();
        let mut shown = Vec::new();
        for (frame, &k) in dump.chunks_exact(frame_bytes).zip(&pictures) {
            if shown.last() != Some(&k) {
                once.extend_from_slice(frame);
                shown.push(k);
            }
        }
        let once_path = suite.out.join(format!("fast-{format}-once.raw"));
        fs::write(&once_path, once).expect("write the frames without repeats");
        let reports = replay_on_host(
            &once_path,
            &["--format-in", format.name()],
            &format.to_string(),
        );
        assert_eq!(reports.len(), shown.len(), "{format}");
        heads_px.extend(check_fast_run(&reports, &shown, &truths));
    }
    report_heads(
        "fast scene recorded as GREY and UYVY, replayed",
        &heads_px,
        MIN_RECORDED_HEADS_CHECKED,
    );
}

#[test]
fn glint_track_follows_a_fast_led_from_grey_and_uyvy_cameras() {
    let Some(suite) = suite() else { return };
    let (_, truths) = fast_feed();
    let mut heads_px = Vec::new();
    for format in FAST_FORMATS {
        let name = format!("track_{format}");
        let log = suite.log(&name);
        assert_eq!(
            suite.status(&name),
            "0",
            "SIGTERM ends glint cleanly: {log}"
        );
        assert!(!log.contains("panicked"), "{log}");
        let row_bytes = WIDTH_PX * format.bytes_per_pixel();
        assert!(
            log.contains(&format!(
                "{} 640x480 with rows {row_bytes} bytes apart",
                fourcc(format)
            )),
            "{log}"
        );
        let reports = suite.reports(&name);
        assert!(
            reports.len() >= FAST_TRACK_REPORTS,
            "{format}: {} reports; log: {log}",
            reports.len()
        );
        assert_report_timeline(&reports);
        // A smeared light alone in view is taken in the first frame it shows.
        let waited = reports
            .iter()
            .take_while(|r| r["found"] != true && r["ambiguous"] == true)
            .count();
        assert!(
            waited <= MAX_ACQUIRE_FRAMES,
            "{format}: ambiguous for {waited} frames"
        );
        let counted = &reports[waited..];
        assert_mostly_found(counted, &format);
        let pictures: Vec<Option<usize>> = counted
            .iter()
            .map(|r| (r["found"] == true).then(|| nearest_truth(r, &truths).0))
            .collect();
        let distinct: std::collections::HashSet<_> = pictures.iter().flatten().collect();
        assert!(
            distinct.len() >= 2,
            "{format}: the loop advances through the fed frames: {pictures:?}"
        );
        heads_px.extend(check_fast_run(counted, &pictures, &truths));
    }
    report_heads(
        "fast scene through glint track --device, GREY and UYVY",
        &heads_px,
        0,
    );
}
