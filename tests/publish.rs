//! `--publish` end to end, received by an implementation glint did not write: a Python peer
//! (eclipse-zenoh, `tests/publish/subscribe.py`) listens on a local TCP port with multicast
//! scouting off, and `glint track` connects to it. It decodes the binary form from the
//! README's table, the ROS messages with rosbags, the rmw_zenoh attachment with
//! zenoh-ros2-sdk, and builds the rmw_zenoh key with zenoh-ros2-sdk; the test compares all of
//! it with glint's own JSON reports of the same run and with the rendered truth.
//!
//! The Python packages live in a venv made by `tools/setup-python.sh` (tools/test.sh runs it);
//! without it these tests fail and say the command.

mod common;

use std::collections::BTreeMap;
use std::io::Write;
use std::process::{Command, Stdio};
use std::thread;
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use common::live::feed_endlessly;
use common::peers::{calibrate_two_markers, free_port, PySubscriber};
use common::{glint, parse_jsonl, quantile, render, score};
use serde_json::Value;

const KEY: &str = "lab/glint";
const CAMERA: &str = "cam_1";
/// Not the default, to see it reach the rmw_zenoh key.
const ROS_DOMAIN: &str = "7";
/// The longest any step may take on a loaded machine before the test gives up.
const PATIENCE: Duration = Duration::from_secs(60);
/// The JSON prints positions with 3 decimals and velocities with 2; the binary form carries
/// f32.
const BINARY_TOLERANCE: f64 = 1e-3;
const BINARY_VELOCITY_TOLERANCE: f64 = 1e-2;
/// The JSON's floor centimetres to 3 decimals, as metres.
const POINT_TOLERANCE_M: f64 = 1e-5;

/// The Python subscriber of every report, listening on `port`.
fn subscriber(port: u16) -> PySubscriber {
    PySubscriber::start(
        "tests/publish/subscribe.py",
        &[&format!("tcp/127.0.0.1:{port}"), KEY, CAMERA, ROS_DOMAIN],
        PATIENCE,
    )
}

impl PySubscriber {
    /// Waits for a JSON report with a frame above `after`; its frame.
    fn json_frame_after(&self, after: Option<u64>, within: Duration) -> Option<u64> {
        let deadline = Instant::now() + within;
        while let Some(left) = deadline.checked_duration_since(Instant::now()) {
            let Ok(sample) = self.samples.recv_timeout(left) else {
                return None;
            };
            if sample["form"] == "json" {
                let frame = sample["report"]["frame"].as_u64().unwrap();
                if after.is_none_or(|a| frame > a) {
                    return Some(frame);
                }
            }
        }
        None
    }
}

fn f(v: &Value) -> f64 {
    v.as_f64().unwrap_or_else(|| panic!("not a number: {v}"))
}

fn unix_now_us() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .unwrap()
        .as_micros() as u64
}

#[test]
fn an_independent_peer_receives_every_report_in_every_form() {
    let dir = tempfile::tempdir().unwrap();
    let calib = calibrate_two_markers(dir.path());
    let r = render("figure-eight");
    let frames = std::fs::read(&r.dump).unwrap();
    let frame_bytes = frames.len() / r.truths.len();
    let port = free_port();
    let subscriber = subscriber(port);
    let started_us = unix_now_us();

    let size = format!("{}x{}", r.scene.width_px(), r.scene.height_px());
    let mut child = glint()
        .args(["-v", "track", "--input", "-"])
        .args(["--size", &size, "--fps", &r.scene.fps().to_string()])
        .args(["--exposure-us", &r.scene.exposure_us().to_string()])
        .arg("--calib")
        .arg(&calib)
        .args(["--publish", KEY, "--camera-name", CAMERA])
        .args(["--zenoh-connect", &format!("tcp/127.0.0.1:{port}")])
        .args(["--ros-domain-id", ROS_DOMAIN])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Frames 10 ms apart, as a fast camera would deliver them: nothing needs dropping.
    let mut stdin = child.stdin.take().unwrap();
    let writer = thread::spawn(move || {
        for frame in frames.chunks(frame_bytes) {
            stdin.write_all(frame).unwrap();
            thread::sleep(Duration::from_millis(10));
        }
    });
    let run = child.wait_with_output().unwrap();
    writer.join().unwrap();
    let log = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{log}");
    let reports = parse_jsonl(&run.stdout);
    assert_eq!(reports.len(), r.truths.len(), "{log}");
    // What is in flight arrives.
    thread::sleep(Duration::from_millis(500));
    let samples = subscriber.stop();
    let ended_us = unix_now_us();

    let errors: Vec<&Value> = samples
        .iter()
        .filter(|s| s["form"] == "error" || s["form"] == "unexpected")
        .collect();
    assert!(errors.is_empty(), "{errors:?}");
    let of_form =
        |form: &str| -> Vec<&Value> { samples.iter().filter(|s| s["form"] == form).collect() };
    let json = of_form("json");
    let binary = of_form("bin");
    let points = of_form("point");
    let rmw = of_form("rmw");

    // Every report arrives once as JSON, in order, under KEY/CAMERA: glint's line, plus the
    // camera and the wall-clock capture time.
    let lost: Vec<&Value> = reports
        .iter()
        .map(|r| &r["frame"])
        .filter(|&frame| !json.iter().any(|s| &s["report"]["frame"] == frame))
        .collect();
    assert!(lost.is_empty(), "frames lost: {lost:?}\n{log}");
    assert_eq!(json.len(), reports.len());
    let mut unix_us_of = BTreeMap::new();
    for (sample, line) in json.iter().zip(&reports) {
        assert_eq!(sample["key"], format!("{KEY}/{CAMERA}"));
        assert_eq!(sample["encoding"], "application/json");
        let mut report = sample["report"].clone();
        let fields = report.as_object_mut().unwrap();
        assert_eq!(fields.remove("camera"), Some(Value::from(CAMERA)));
        let unix_us = fields.remove("unix_us").and_then(|v| v.as_u64()).unwrap();
        assert!(
            (started_us..=ended_us).contains(&unix_us),
            "{unix_us} outside the run"
        );
        assert_eq!(&report, line, "the network line is glint's");
        unix_us_of.insert(line["frame"].as_u64().unwrap(), unix_us);
    }
    // The pixel positions against the rendered truth (as tests/replay_accuracy.rs holds them).
    let received: Vec<Value> = json.iter().map(|s| s["report"].clone()).collect();
    let s = score(&received, &r.truths);
    assert!(s.detected * 10 >= s.visible * 9, "{s:?}");
    assert!(quantile(&s.pos_errors_px, 0.95) < 2.0, "{s:?}");

    // The binary form says the same, decoded from the README's table.
    assert_eq!(binary.len(), reports.len());
    for (sample, line) in binary.iter().zip(&reports) {
        assert_eq!(sample["key"], format!("{KEY}/{CAMERA}/bin"));
        assert_eq!(
            sample["encoding"],
            "application/octet-stream;glint.report.1"
        );
        let b = &sample["report"];
        let frame = line["frame"].as_u64().unwrap();
        assert_eq!(b["version"], 1);
        assert_eq!(b["frame"].as_u64(), Some(frame));
        assert_eq!(b["sequence"], line["seq"]);
        assert_eq!(
            b["t_us"].as_u64(),
            Some((f(&line["t"]) * 1e6).round() as u64)
        );
        assert_eq!(b["unix_us"].as_u64(), unix_us_of.get(&frame).copied());
        let close = |a: &Value, b: &Value| (f(a) - f(b)).abs() <= BINARY_TOLERANCE;
        match line["found"].as_bool().unwrap() {
            true => {
                assert!(close(&b["position_px"][0], &line["x"]), "{b} vs {line}");
                assert!(close(&b["position_px"][1], &line["y"]), "{b} vs {line}");
            }
            false => assert!(b["position_px"].is_null(), "{b}"),
        }
        if line["vx"].is_number() {
            for (i, key) in ["vx", "vy"].into_iter().enumerate() {
                let v = f(&b["velocity_px_s"][i]);
                assert!(
                    (v - f(&line[key])).abs() <= BINARY_VELOCITY_TOLERANCE,
                    "{b} vs {line}"
                );
            }
        }
        match line["floor_x"].is_number() {
            true => {
                assert_eq!(b["floor"]["unit"], 1, "cm");
                assert!(close(&b["floor"]["x"], &line["floor_x"]), "{b} vs {line}");
                assert!(close(&b["floor"]["y"], &line["floor_y"]), "{b} vs {line}");
            }
            false => assert!(b["floor"].is_null(), "{b}"),
        }
        let ambiguous = line["ambiguous"] == true;
        assert_eq!(b["flags"].as_u64().unwrap() & 1 == 1, ambiguous, "{b}");
    }

    // Floor positions as ROS PointStamped in metres, stamped with the capture time, through the
    // bridge's key and rmw_zenoh's (built by zenoh-ros2-sdk, so only a right key receives).
    let floor_reports: Vec<&Value> = reports
        .iter()
        .filter(|r| r["floor_x"].is_number())
        .collect();
    assert!(
        floor_reports.len() > reports.len() / 2,
        "the robot was on the floor"
    );
    for (form, key) in [
        (&points, format!("{KEY}/{CAMERA}/point")),
        (&rmw, String::new()),
    ] {
        assert_eq!(form.len(), floor_reports.len(), "{key}");
        for (sample, line) in form.iter().zip(&floor_reports) {
            if !key.is_empty() {
                assert_eq!(sample["key"], key.as_str());
            }
            assert_eq!(sample["encoding"], "application/cdr");
            let msg = &sample["msg"];
            let frame = line["frame"].as_u64().unwrap();
            let unix_us = unix_us_of[&frame];
            assert_eq!(msg["sec"].as_u64(), Some(unix_us / 1_000_000), "{msg}");
            assert_eq!(msg["nanosec"].as_u64(), Some(unix_us % 1_000_000 * 1000));
            assert_eq!(msg["frame_id"], "glint_floor");
            assert!((f(&msg["x"]) - f(&line["floor_x"]) / 100.0).abs() <= POINT_TOLERANCE_M);
            assert!((f(&msg["y"]) - f(&line["floor_y"]) / 100.0).abs() <= POINT_TOLERANCE_M);
            assert_eq!(f(&msg["z"]), 0.0);
        }
    }
    for (i, (sample, line)) in rmw.iter().zip(&floor_reports).enumerate() {
        let a = &sample["attachment"];
        assert_eq!(a["sequence"].as_u64(), Some(i as u64 + 1), "{sample}");
        let unix_us = unix_us_of[&line["frame"].as_u64().unwrap()];
        assert_eq!(a["timestamp_ns"].as_u64(), Some(unix_us * 1000));
        assert_eq!(a["gid_len"], 16);
    }

    // The summary counts them all, none dropped.
    let summary = format!(
        "publish: queued={0} dropped=0 sent={0} failed=0",
        reports.len()
    );
    assert!(log.contains(&summary), "{summary} not in\n{log}");
}

/// `glint run` with the settings in its file, so the file's keys are tried too.
#[test]
fn a_subscriber_that_restarts_loses_reports_not_the_process() {
    const FRAME_BYTES: usize = 160 * 120 * 2;
    let port = free_port();
    let dir = tempfile::tempdir().unwrap();
    let settings = dir.path().join("glint.toml");
    std::fs::write(
        &settings,
        format!(
            "input = \"-\"\nsize = \"160x120\"\nsummary-every = 0.5\npublish = \"{KEY}\"\n\
             camera-name = \"{CAMERA}\"\nzenoh-connect = [\"tcp/127.0.0.1:{port}\"]\n"
        ),
    )
    .unwrap();
    let first = subscriber(port);
    let mut child = glint()
        .args(["run", "--config"])
        .arg(&settings)
        .stdin(Stdio::piped())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let feeder = feed_endlessly(
        child.stdin.take().unwrap(),
        vec![16u8; FRAME_BYTES * 4],
        FRAME_BYTES,
    );
    let before = first
        .json_frame_after(None, PATIENCE)
        .expect("reports reach the first subscriber");
    first.stop();

    // The subscriber is gone: glint keeps tracking, and keeps trying to reconnect.
    thread::sleep(Duration::from_millis(500));
    assert!(child.try_wait().unwrap().is_none(), "glint exited");

    let second = subscriber(port);
    let after = second.json_frame_after(Some(before), PATIENCE);
    assert!(child.try_wait().unwrap().is_none(), "glint exited");
    let kill = Command::new("kill")
        .args(["-TERM", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(kill.success());
    let out = child.wait_with_output().unwrap();
    feeder.join().unwrap();
    second.stop();
    let log = String::from_utf8_lossy(&out.stderr);
    assert!(
        after.is_some(),
        "no report after frame {before} reached the restarted subscriber:\n{log}"
    );
    assert!(out.status.success(), "{log}");
    assert!(log.contains(", publish "), "no status: {log}");
    assert!(log.contains("publish: queued="), "{log}");
}
