//! `--mavlink` end to end, decoded by an implementation glint did not write: `glint track`
//! sends MAVLink 2 on a pty's slave end; the master end's bytes go to pymavlink
//! (`tests/mavlink/decode.py`), which checks every frame's CRC (CRC extra included) and decodes
//! its fields. The test compares them with glint's own JSON reports of the same run.
//!
//! pymavlink lives in a venv made by `tools/setup-python.sh` (tools/test.sh runs it); without
//! it this test fails and says the command.

mod common;

use std::io::{Read, Write};
use std::os::unix::io::AsRawFd;
use std::process::Stdio;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

use common::peers::{calibrate_two_markers, decode_mavlink, north_east_m, number, python};
use common::{glint, parse_jsonl, render};
use nix::fcntl::{fcntl, FcntlArg, FdFlag};
use serde_json::Value;
use serialport::{SerialPort, TTYPort};

/// The bearing of floor +x given to glint: not a multiple of 90°, so a swapped or mirrored
/// axis cannot pass.
const YAW_OFFSET_DEG: f64 = 30.0;
/// A system id other than the default, to see the flag arrive.
const SYSTEM_ID: u64 = 7;
/// `MAV_COMP_ID_VISUAL_INERTIAL_ODOMETRY`.
const COMPONENT_ID: u64 = 197;
/// `MAV_TYPE_ONBOARD_CONTROLLER`, `MAV_AUTOPILOT_INVALID`, `MAV_STATE_ACTIVE`.
const HEARTBEAT_TYPE: u64 = 18;
const HEARTBEAT_AUTOPILOT: u64 = 8;
const HEARTBEAT_STATE: u64 = 4;
/// The JSON prints floor positions with 3 decimals (cm), and MAVLink carries f32 metres.
const POSITION_TOLERANCE_M: f64 = 1e-4;
const VELOCITY_TOLERANCE_M_S: f64 = 1e-3;
/// The variance of an angle uniform over the circle, π²/3 rad², given to unmeasured angles.
const UNMEASURED_ANGLE_VARIANCE_RAD2: f64 = std::f64::consts::PI * std::f64::consts::PI / 3.0;

/// `key=value` counts of the sink's summary line in glint's log.
fn summary_count(log: &str, key: &str) -> u64 {
    let line = log
        .lines()
        .find(|l| l.contains("mavlink port") && l.contains("positions="))
        .unwrap_or_else(|| panic!("no mavlink summary in the log:\n{log}"));
    line.split_whitespace()
        .find_map(|kv| kv.strip_prefix(&format!("{key}=")))
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("no {key} in {line}"))
}

#[test]
fn pymavlink_decodes_every_message_with_the_reported_positions() {
    let python = python();
    assert!(python.exists());
    let dir = tempfile::tempdir().unwrap();
    let calib = calibrate_two_markers(dir.path());
    let r = render("figure-eight");

    let (mut master, slave) = TTYPort::pair().expect("pty pair");
    for end in [&master, &slave] {
        fcntl(end.as_raw_fd(), FcntlArg::F_SETFD(FdFlag::FD_CLOEXEC)).expect("close-on-exec");
    }
    let name = slave.name().expect("slave name");
    let stop = Arc::new(AtomicBool::new(false));
    let reader = {
        let stop = Arc::clone(&stop);
        std::thread::spawn(move || {
            let mut bytes = Vec::new();
            let mut buf = [0u8; 4096];
            let mut quiet = 0;
            // After glint has exited, read until the pty has been empty for 200 ms.
            while !stop.load(Ordering::Relaxed) || quiet < 200 {
                match master.read(&mut buf) {
                    Ok(n) if n > 0 => {
                        bytes.extend_from_slice(&buf[..n]);
                        quiet = 0;
                    }
                    _ => {
                        std::thread::sleep(Duration::from_millis(1));
                        quiet += 1;
                    }
                }
            }
            bytes
        })
    };
    let size = format!("{}x{}", r.scene.width_px(), r.scene.height_px());
    let mut child = glint()
        .args(["-v", "track", "--input", "-"])
        .args(["--size", &size, "--fps", &r.scene.fps().to_string()])
        .args(["--exposure-us", &r.scene.exposure_us().to_string()])
        .arg("--calib")
        .arg(&calib)
        .args(["--serial", &name, "--mavlink"])
        .args(["--mavlink-yaw-offset-deg", &YAW_OFFSET_DEG.to_string()])
        .args(["--mavlink-system-id", &SYSTEM_ID.to_string()])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // Frames come at the scene's rate, as from a camera. A dump read from a file comes as fast
    // as glint can track it, faster than the writer thread is scheduled on a loaded machine:
    // then most positions are replaced unsent (newest wins, counted as stale), which is the
    // link's design, not a loss (measured: 57 of 119 sent with three runs at once).
    let frame_interval = Duration::from_secs_f64(1.0 / r.scene.fps());
    let feeder = {
        let mut stdin = child.stdin.take().unwrap();
        let dump = std::fs::read(&r.dump).unwrap();
        let frame_bytes = r.scene.frame_len_bytes();
        std::thread::spawn(move || {
            for frame in dump.chunks_exact(frame_bytes) {
                // A write fails only once glint has exited; its status says why.
                if stdin.write_all(frame).is_err() {
                    break;
                }
                std::thread::sleep(frame_interval);
            }
        })
    };
    let run = child.wait_with_output().unwrap();
    feeder.join().unwrap();
    stop.store(true, Ordering::Relaxed);
    let bytes = reader.join().unwrap();
    let log = String::from_utf8_lossy(&run.stderr);
    assert!(run.status.success(), "{log}");
    let reports = parse_jsonl(&run.stdout);
    let (messages, summary) = decode_mavlink(&bytes);

    // Every byte decodes, every CRC holds, and a flipped byte is caught.
    assert!(
        !messages.is_empty(),
        "nothing decoded from {} bytes",
        bytes.len()
    );
    assert!(
        messages.iter().all(|m| m["type"] != "BAD_DATA"),
        "bad frames: {:?}",
        messages.iter().filter(|m| m["type"] == "BAD_DATA").count()
    );
    assert_eq!(summary["bytes"].as_u64(), Some(bytes.len() as u64));
    assert!(summary["corrupted_bad"].as_u64() >= Some(1), "{summary}");

    // Sequence numbers count every message, from 0; ids are glint's.
    for (i, m) in messages.iter().enumerate() {
        assert_eq!(m["seq"].as_u64(), Some(i as u64 % 256), "message {i}: {m}");
        assert_eq!(m["sysid"].as_u64(), Some(SYSTEM_ID), "{m}");
        assert_eq!(m["compid"].as_u64(), Some(COMPONENT_ID), "{m}");
    }

    let of_type = |t: &'static str| messages.iter().filter(move |m| m["type"] == t);
    let heartbeats: Vec<_> = of_type("HEARTBEAT").collect();
    assert_eq!(messages[0]["type"], "HEARTBEAT", "a heartbeat first");
    for h in &heartbeats {
        let fields = &h["fields"];
        assert_eq!(fields["type"].as_u64(), Some(HEARTBEAT_TYPE));
        assert_eq!(fields["autopilot"].as_u64(), Some(HEARTBEAT_AUTOPILOT));
        assert_eq!(fields["system_status"].as_u64(), Some(HEARTBEAT_STATE));
        assert_eq!(fields["mavlink_version"].as_u64(), Some(3));
    }

    // Positions: each at a reported frame's time, in metres, turned by the yaw offset.
    let floor_reports: Vec<&Value> = reports
        .iter()
        .filter(|r| r["floor_x"].is_number())
        .collect();
    assert!(
        floor_reports.len() > reports.len() / 2,
        "the robot was on the floor"
    );
    let at = |usec: u64| {
        floor_reports
            .iter()
            .find(|r| (number(&r["t"]) * 1e6).round() as u64 == usec)
            .unwrap_or_else(|| panic!("no report with a floor position at {usec} µs"))
    };
    let positions: Vec<_> = of_type("VISION_POSITION_ESTIMATE").collect();
    let mut last_usec = None;
    for p in &positions {
        let fields = &p["fields"];
        let usec = fields["usec"].as_u64().unwrap();
        assert!(Some(usec) > last_usec, "times increase");
        last_usec = Some(usec);
        let report = at(usec);
        let (n, e) = north_east_m(
            number(&report["floor_x"]),
            number(&report["floor_y"]),
            YAW_OFFSET_DEG,
        );
        assert!(
            (number(&fields["x"]) - n).abs() < POSITION_TOLERANCE_M,
            "{fields} vs {report}"
        );
        assert!(
            (number(&fields["y"]) - e).abs() < POSITION_TOLERANCE_M,
            "{fields} vs {report}"
        );
        assert_eq!(number(&fields["z"]), 0.0);
        let cov = fields["covariance"].as_array().expect("covariance sent");
        assert_eq!(cov.len(), 21);
        let variance = number(&cov[0]);
        // A σ between 0.1 mm and 1 cm: a fraction of a pixel at a few mm per pixel (about 1 mm here).
        assert!((1e-8..1e-4).contains(&variance), "variance {variance} m²");
        // The diagonal: x, y, z the same; roll, pitch, yaw a whole circle (π²/3); 0 elsewhere.
        let diagonal = [0, 6, 11, 15, 18, 20];
        for (state, &i) in diagonal.iter().enumerate() {
            let expected = if state < 3 {
                variance
            } else {
                UNMEASURED_ANGLE_VARIANCE_RAD2
            };
            assert!(
                (number(&cov[i]) - expected).abs() <= 1e-6 * expected,
                "entry {i}: {cov:?}"
            );
        }
        let off_diagonal = (0..21).filter(|i| !diagonal.contains(i));
        assert!(
            off_diagonal.into_iter().all(|i| number(&cov[i]) == 0.0),
            "{cov:?}"
        );
    }
    let speeds: Vec<_> = of_type("VISION_SPEED_ESTIMATE").collect();
    for s in &speeds {
        let fields = &s["fields"];
        let report = at(fields["usec"].as_u64().unwrap());
        let (n, e) = north_east_m(
            number(&report["floor_vx"]),
            number(&report["floor_vy"]),
            YAW_OFFSET_DEG,
        );
        assert!(
            (number(&fields["x"]) - n).abs() < VELOCITY_TOLERANCE_M_S,
            "{fields} vs {report}"
        );
        assert!(
            (number(&fields["y"]) - e).abs() < VELOCITY_TOLERANCE_M_S,
            "{fields} vs {report}"
        );
        assert!(
            fields["covariance"][0].is_null(),
            "velocity covariance unknown"
        );
    }

    // Nothing lost: what was posted was received, or replaced unsent (and counted).
    let posted = summary_count(&log, "positions") + summary_count(&log, "speeds");
    let stale = summary_count(&log, "stale");
    assert_eq!(summary_count(&log, "positions"), floor_reports.len() as u64);
    assert_eq!(
        positions.len() as u64 + speeds.len() as u64 + stale,
        posted,
        "{log}"
    );
    assert!(
        positions.len() >= floor_reports.len() / 2,
        "most positions sent: {log}"
    );
    assert!(!speeds.is_empty(), "velocities sent");
    assert_eq!(heartbeats.len() as u64, summary_count(&log, "heartbeats"));
}

#[test]
fn mavlink_without_a_calibration_is_refused_with_one_line() {
    let r = render("slow-line");
    let (_master, slave) = TTYPort::pair().expect("pty pair");
    let name = slave.name().unwrap();
    let out = common::track(&r, &["--serial", &name, "--mavlink"]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("--mavlink needs --calib"), "{err}");
    assert_eq!(err.trim().lines().count(), 1, "{err}");
    assert!(out.stdout.is_empty());

    // And it changes what --serial sends: without a port it is refused too.
    let out = common::track(&r, &["--mavlink"]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("--serial"));
}

/// Reads a pty master on a thread until told to stop, then until it has been quiet for 200 ms.
struct PtyReader {
    stop: Arc<AtomicBool>,
    /// Bytes read so far.
    received: Arc<AtomicUsize>,
    thread: std::thread::JoinHandle<Vec<u8>>,
}

impl PtyReader {
    fn start(mut master: TTYPort) -> Self {
        let stop = Arc::new(AtomicBool::new(false));
        let received = Arc::new(AtomicUsize::new(0));
        let thread = {
            let stop = Arc::clone(&stop);
            let received = Arc::clone(&received);
            std::thread::spawn(move || {
                // Heartbeats come once a second: quiet is measured in time, not in reads.
                master
                    .set_timeout(Duration::from_millis(10))
                    .expect("read timeout");
                let mut bytes = Vec::new();
                let mut buf = [0u8; 4096];
                let mut last_byte = Instant::now();
                while !stop.load(Ordering::Relaxed)
                    || last_byte.elapsed() < Duration::from_millis(200)
                {
                    if let Ok(n @ 1..) = master.read(&mut buf) {
                        bytes.extend_from_slice(&buf[..n]);
                        received.store(bytes.len(), Ordering::Relaxed);
                        last_byte = Instant::now();
                    }
                }
                bytes
            })
        };
        PtyReader {
            stop,
            received,
            thread,
        }
    }

    /// Waits until something has been read, for at most `timeout`.
    fn wait_for_bytes(&self, timeout: Duration) -> bool {
        let start = Instant::now();
        while self.received.load(Ordering::Relaxed) == 0 {
            if start.elapsed() > timeout {
                return false;
            }
            std::thread::sleep(Duration::from_millis(10));
        }
        true
    }

    /// Stops reading (the master end closes when the thread ends) and gives what was read.
    fn finish(self) -> Vec<u8> {
        self.stop.store(true, Ordering::Relaxed);
        self.thread.join().unwrap()
    }
}

/// A pty pair whose ends are not inherited by glint, and the slave's name.
fn cloexec_pty() -> (TTYPort, TTYPort, String) {
    let (master, slave) = TTYPort::pair().expect("pty pair");
    for end in [&master, &slave] {
        fcntl(end.as_raw_fd(), FcntlArg::F_SETFD(FdFlag::FD_CLOEXEC)).expect("close-on-exec");
    }
    let name = slave.name().expect("slave name");
    (master, slave, name)
}

#[test]
fn an_unplugged_mavlink_port_is_reopened_and_sends_whole_frames_again() {
    python();
    let dir = tempfile::tempdir().unwrap();
    let calib = calibrate_two_markers(dir.path());
    let r = render("figure-eight");
    let frame_bytes = r.scene.width_px() as usize * r.scene.height_px() as usize * 2;
    let dump = std::fs::read(&r.dump).unwrap();
    let frames: Vec<&[u8]> = dump.chunks_exact(frame_bytes).collect();
    assert!(frames.len() >= 60, "{} frames", frames.len());

    // The port is reached through a link, as /dev/serial/by-id/... names an adapter.
    let link = dir.path().join("autopilot");
    let (master, slave, name) = cloexec_pty();
    std::os::unix::fs::symlink(&name, &link).unwrap();
    let before = PtyReader::start(master);
    let size = format!("{}x{}", r.scene.width_px(), r.scene.height_px());
    let mut child = glint()
        .args(["-v", "track", "--input", "-"])
        .args(["--size", &size, "--fps", &r.scene.fps().to_string()])
        .args(["--exposure-us", &r.scene.exposure_us().to_string()])
        .arg("--calib")
        .arg(&calib)
        .arg("--serial")
        .arg(&link)
        .arg("--mavlink")
        .args(["--mavlink-yaw-offset-deg", &YAW_OFFSET_DEG.to_string()])
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut stdin = child.stdin.take().unwrap();
    let stdout = {
        let mut out = child.stdout.take().unwrap();
        std::thread::spawn(move || {
            let mut bytes = Vec::new();
            out.read_to_end(&mut bytes).unwrap();
            bytes
        })
    };
    let stderr = {
        let mut err = child.stderr.take().unwrap();
        std::thread::spawn(move || {
            let mut text = String::new();
            err.read_to_string(&mut text).unwrap();
            text
        })
    };
    let pace = Duration::from_millis(30);
    let third = frames.len() / 3;
    for frame in &frames[..third] {
        stdin.write_all(frame).unwrap();
        std::thread::sleep(pace);
    }

    // Unplugged: both ends and the name go away while frames go on.
    let first_bytes = before.finish();
    drop(slave);
    std::fs::remove_file(&link).unwrap();
    for frame in &frames[third..2 * third] {
        stdin.write_all(frame).unwrap();
        std::thread::sleep(pace);
    }

    // Plugged back in under the same name.
    let (master, _slave, name) = cloexec_pty();
    std::os::unix::fs::symlink(&name, &link).unwrap();
    let after = PtyReader::start(master);
    // The writer finds the port again within its back-off (at most 5 s) and sends a heartbeat
    // at once or within a second; only then do the last frames come, so that their positions
    // are sent on the new port however late the machine schedules the writer.
    assert!(
        after.wait_for_bytes(Duration::from_secs(15)),
        "the port was not reopened"
    );
    for frame in &frames[2 * third..] {
        stdin.write_all(frame).unwrap();
        std::thread::sleep(pace);
    }
    drop(stdin);
    let status = child.wait().unwrap();
    let reports = parse_jsonl(&stdout.join().unwrap());
    let log = stderr.join().unwrap();
    let second_bytes = after.finish();
    assert!(status.success(), "{log}");
    assert_eq!(reports.len(), frames.len(), "every frame reported: {log}");
    assert!(!first_bytes.is_empty(), "sent before the unplugging");

    assert_eq!(summary_count(&log, "losses"), 1, "{log}");
    assert_eq!(summary_count(&log, "reopens"), 1, "{log}");
    assert!(summary_count(&log, "port_down") > 0, "{log}");

    // What comes after the reopening decodes whole: the writer never resumes mid-frame.
    let (messages, _) = decode_mavlink(&second_bytes);
    assert!(!messages.is_empty(), "nothing sent after reopening: {log}");
    assert!(
        messages.iter().all(|m| m["type"] != "BAD_DATA"),
        "{messages:?}"
    );
    // Sequence numbers run on without a break from the first frame after the reopening.
    for pair in messages.windows(2) {
        let (a, b) = (pair[0]["seq"].as_u64(), pair[1]["seq"].as_u64());
        assert_eq!(b, a.map(|a| (a + 1) % 256), "{pair:?}");
    }
    // The positions are those of frames after the reopening, as reported.
    let positions: Vec<&Value> = messages
        .iter()
        .filter(|m| m["type"] == "VISION_POSITION_ESTIMATE")
        .collect();
    assert!(!positions.is_empty(), "positions after reopening");
    let unplugged_at_us = number(&reports[third]["t"]) * 1e6;
    for p in positions {
        let usec = p["fields"]["usec"].as_u64().unwrap() as f64;
        let report = reports
            .iter()
            .find(|r| (number(&r["t"]) * 1e6 - usec).abs() < 0.5)
            .unwrap_or_else(|| panic!("no report at {usec} µs"));
        assert!(
            usec >= unplugged_at_us,
            "{usec} µs was sent before the unplugging"
        );
        let (n, e) = north_east_m(
            number(&report["floor_x"]),
            number(&report["floor_y"]),
            YAW_OFFSET_DEG,
        );
        assert!((number(&p["fields"]["x"]) - n).abs() < POSITION_TOLERANCE_M);
        assert!((number(&p["fields"]["y"]) - e).abs() < POSITION_TOLERANCE_M);
    }
}
