//! The serial link end to end, over real pseudo-terminals: the `glint` binary tracks rendered
//! frames with `--serial` on a pty's slave end, and the test decodes the master end with
//! `glint_protocol::Decoder`, as the robot's firmware would.
//!
//! Frames go to glint's standard input one at a time, and the test waits for each frame's
//! position update before sending the next, so no update is ever stale and every one must
//! arrive; other tests stop reading, pull the pty away mid-run, or bring it back.

mod common;

use std::io::{Read, Write};
use std::os::unix::io::AsRawFd;
use std::path::Path;
use std::process::{Child, ChildStdin, ExitStatus, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError};
use std::sync::{Arc, Mutex, PoisonError};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use glint_protocol::{
    Decoder, Heartbeat, Message, Position, PositionAge, Received, Status, TrackerState, Units,
    PROTOCOL_VERSION, QUANTA_PER_PX,
};
use glint_tools::scene::Scene;
use nix::fcntl::{fcntl, FcntlArg, FdFlag, OFlag};
use serde_json::Value;
use serialport::{SerialPort, TTYPort};

/// Longest wait for anything that should happen at once; only reached when something is broken.
const PATIENCE: Duration = Duration::from_secs(60);

/// The decimals glint prints positions with: `{:.3}`.
const JSON_POSITION_RESOLUTION_PX: f64 = 0.0005;

/// Rendered frames of a scene, to be sent to glint's standard input one by one.
struct Frames {
    scene: Scene,
    dump: Vec<u8>,
}

impl Frames {
    fn new(name: &str) -> Frames {
        let scene = Scene::preset(name).expect("preset");
        let (dump, _) = scene.render_dump();
        Frames { scene, dump }
    }

    /// Frame `i`, cycling through the scene.
    fn frame(&self, i: usize) -> &[u8] {
        let len = self.scene.frame_len_bytes();
        let at = (i % self.scene.frame_count()) * len;
        &self.dump[at..at + len]
    }

    fn count(&self) -> usize {
        self.scene.frame_count()
    }
}

/// The size, rate and exposure arguments for a scene's frames.
fn scene_args(scene: &Scene) -> Vec<String> {
    [
        "--size".into(),
        format!("{}x{}", scene.width_px(), scene.height_px()),
        "--fps".into(),
        scene.fps().to_string(),
        "--exposure-us".into(),
        scene.exposure_us().to_string(),
    ]
    .into()
}

/// What the reading end saw: a message, or what went wrong instead.
type Seen = Result<Message, String>;

/// Reads a pty's master end on a thread, decoding as it goes.
struct Robot {
    messages: Receiver<Seen>,
    /// The first byte that arrived: the sender's opening 0x00.
    first_byte: Receiver<u8>,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl Robot {
    fn listen(mut master: TTYPort) -> Robot {
        let (tx, messages) = mpsc::channel();
        let (first_tx, first_byte) = mpsc::channel();
        let stop = Arc::new(AtomicBool::new(false));
        let thread = {
            let stop = Arc::clone(&stop);
            std::thread::spawn(move || {
                let mut decoder = Decoder::new();
                let mut buf = [0u8; 256];
                let mut first = Some(first_tx);
                while !stop.load(Ordering::Relaxed) {
                    let n = match master.read(&mut buf) {
                        Ok(n) => n,
                        // Timed out, or no slave open yet (EIO): nothing to read.
                        Err(_) => {
                            std::thread::sleep(Duration::from_millis(1));
                            continue;
                        }
                    };
                    if let (Some(tx), Some(&b)) = (first.take(), buf[..n].first()) {
                        let _ = tx.send(b);
                    }
                    for outcome in decoder.feed(&buf[..n]) {
                        let seen = match outcome {
                            Ok(Received::Message(m)) => Ok(m),
                            Ok(Received::Unknown { id }) => Err(format!("unknown id {id:#04x}")),
                            Err(e) => Err(format!("{e}")),
                        };
                        let _ = tx.send(seen);
                    }
                }
            })
        };
        Robot {
            messages,
            first_byte,
            stop,
            thread: Some(thread),
        }
    }

    /// The next position update, collecting heartbeats on the way; fails on anything else.
    fn next_position(&self, heartbeats: &mut Vec<(usize, Heartbeat)>, frame: usize) -> Position {
        self.next_update(heartbeats, frame).0
    }

    /// The next position update and the age frame that must follow it at once.
    fn next_update(
        &self,
        heartbeats: &mut Vec<(usize, Heartbeat)>,
        frame: usize,
    ) -> (Position, PositionAge) {
        let position = loop {
            match self.messages.recv_timeout(PATIENCE) {
                Ok(Ok(Message::Position(p))) => break p,
                Ok(Ok(Message::Heartbeat(h))) => heartbeats.push((frame, h)),
                Ok(other) => panic!("frame {frame}: the robot saw {other:?}"),
                Err(e) => panic!("frame {frame}: no position update arrived: {e}"),
            }
        };
        (position, self.age_of(&position))
    }

    /// The age frame that must come right after `position`.
    fn age_of(&self, position: &Position) -> PositionAge {
        match self.messages.recv_timeout(PATIENCE) {
            Ok(Ok(Message::Age(a))) if a.seq == position.seq => a,
            other => panic!("after {position:?} the robot saw {other:?}"),
        }
    }

    /// Everything that arrives until the line has been quiet for `quiet`.
    fn drain(&self, quiet: Duration) -> Vec<Seen> {
        let mut seen = Vec::new();
        loop {
            match self.messages.recv_timeout(quiet) {
                Ok(s) => seen.push(s),
                Err(RecvTimeoutError::Timeout | RecvTimeoutError::Disconnected) => return seen,
            }
        }
    }
}

impl Drop for Robot {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

/// A running `glint track --input -` whose output and log are collected on threads.
struct Glint {
    child: Child,
    stdin: Option<ChildStdin>,
    stdout: JoinHandle<Vec<u8>>,
    stderr: JoinHandle<Vec<u8>>,
}

/// What a finished glint left behind.
struct Finished {
    status: ExitStatus,
    reports: Vec<Value>,
    log: String,
}

impl Glint {
    /// `glint -v track --input INPUT ARGS --serial SERIAL`.
    fn start(input: &str, args: &[String], serial: &Path) -> Glint {
        let spawning = SPAWNING.lock().unwrap_or_else(PoisonError::into_inner);
        let mut child = common::glint()
            .args(["-v", "track", "--input", input])
            .args(args)
            .arg("--serial")
            .arg(serial)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("start glint");
        drop(spawning);
        let collect = |mut r: Box<dyn Read + Send>| {
            std::thread::spawn(move || {
                let mut bytes = Vec::new();
                r.read_to_end(&mut bytes).expect("read glint's output");
                bytes
            })
        };
        let stdout = collect(Box::new(child.stdout.take().unwrap()));
        let stderr = collect(Box::new(child.stderr.take().unwrap()));
        Glint {
            stdin: child.stdin.take(),
            child,
            stdout,
            stderr,
        }
    }

    fn send(&mut self, frame: &[u8]) {
        self.stdin
            .as_mut()
            .expect("stdin open")
            .write_all(frame)
            .expect("glint reads its input");
    }

    /// Closes standard input and waits for glint to exit, killing it if it hangs.
    fn finish(mut self) -> Finished {
        drop(self.stdin.take());
        let started = Instant::now();
        let status = loop {
            if let Some(status) = self.child.try_wait().expect("wait for glint") {
                break status;
            }
            if started.elapsed() > PATIENCE {
                let _ = self.child.kill();
                panic!("glint did not exit after its input ended");
            }
            std::thread::sleep(Duration::from_millis(10));
        };
        let reports = common::parse_jsonl(&self.stdout.join().unwrap());
        let log = String::from_utf8(self.stderr.join().unwrap()).expect("utf-8 log");
        Finished {
            status,
            reports,
            log,
        }
    }
}

/// Held while a pty pair is made and while a child is started: `TTYPort::pair` opens both ends
/// without close-on-exec, and a glint started by a test running in parallel must not inherit
/// them (an inherited master keeps the pty alive after the test drops it).
static SPAWNING: Mutex<()> = Mutex::new(());

/// Bytes of a message on the wire.
fn wire_len(message: Message) -> u64 {
    let mut out = [0u8; glint_protocol::MAX_ENCODED_LEN + 1];
    glint_protocol::encode(&message, &mut out)
        .expect("fits")
        .len() as u64
}

/// An update's age on arrival: at least the line time of the update and its age at the default
/// baud, and at most the time since the test started sending its frame plus the line time of
/// everything that write may hold (a pty takes no line time, the age counts it all the same).
/// Its frame was read from a pipe, so glint counts the age from the frame's arrival.
fn check_age(p: &Position, age: &PositionAge, since_sending: Duration) {
    const BAUD: u64 = 115_200;
    const LONGEST_HEARTBEAT_AND_DELIMITER: u64 = 16;
    assert!(!age.predicted, "{age:?}");
    let update_bytes = wire_len(Message::Position(*p)) + wire_len(Message::Age(*age));
    let line_us = |bytes: u64| bytes * 10 * 1_000_000 / BAUD;
    let age_us = u64::from(age.age_us);
    assert!(
        age_us >= line_us(update_bytes),
        "{age:?}: less than the line time"
    );
    let bound_us =
        since_sending.as_micros() as u64 + line_us(update_bytes + LONGEST_HEARTBEAT_AND_DELIMITER);
    assert!(
        age_us <= bound_us,
        "{age:?}: older than the {bound_us} µs since its frame was sent"
    );
}

/// A pty pair; the slave end stays open here too, so the master end never reads a hang-up
/// between glint's opens.
fn pty() -> (TTYPort, TTYPort, String) {
    let _spawning = SPAWNING.lock().unwrap_or_else(PoisonError::into_inner);
    let (master, slave) = TTYPort::pair().expect("pty pair");
    for end in [&master, &slave] {
        fcntl(end.as_raw_fd(), FcntlArg::F_SETFD(FdFlag::FD_CLOEXEC)).expect("close-on-exec");
    }
    let name = slave.name().expect("slave has a name");
    (master, slave, name)
}

/// The link's summary counters from glint's log (`-v`): `updates=150 heartbeats=5 ...`.
fn serial_summary(log: &str) -> Vec<(String, u64)> {
    let line = log
        .lines()
        .find(|l| l.contains(" updates="))
        .unwrap_or_else(|| panic!("no serial summary in the log:\n{log}"));
    line.split_whitespace()
        .filter_map(|w| {
            let (key, value) = w.split_once('=')?;
            Some((key.to_string(), value.parse().ok()?))
        })
        .collect()
}

fn count(summary: &[(String, u64)], key: &str) -> u64 {
    summary
        .iter()
        .find(|(k, _)| k == key)
        .map(|(_, v)| *v)
        .unwrap_or_else(|| panic!("no {key:?} in {summary:?}"))
}

/// Checks a position update against glint's JSON report of the same frame.
fn check_against_report(p: &Position, r: &Value, last_found: &mut (i16, i16)) {
    let frame = r["frame"].as_u64().unwrap();
    assert_eq!(u64::from(p.seq), frame % 256, "seq of frame {frame}");
    let t_us = (r["t"].as_f64().unwrap() * 1e6).round() as u64;
    assert_eq!(p.timestamp_us, t_us as u32, "timestamp of frame {frame}");
    assert_eq!(p.units, Units::Pixels);
    if r["found"] == true {
        assert_eq!(p.status, Status::Found, "frame {frame}");
        assert!(p.quality > 0);
        // The wire carries 1/8 px, rounded to nearest; JSON has three decimals.
        let tolerance = 0.5 / f64::from(QUANTA_PER_PX) + JSON_POSITION_RESOLUTION_PX;
        for (wire, key) in [(p.x, "x"), (p.y, "y")] {
            let json = r[key].as_f64().unwrap();
            let got = f64::from(wire) / f64::from(QUANTA_PER_PX);
            assert!(
                (got - json).abs() <= tolerance,
                "frame {frame}: {key} {got} on the wire, {json} in JSON"
            );
        }
        *last_found = (p.x, p.y);
    } else {
        assert_eq!(p.status, Status::Lost, "frame {frame}");
        assert_eq!(
            (p.x, p.y, p.vx_per_s, p.vy_per_s),
            (last_found.0, last_found.1, 0, 0)
        );
        assert_eq!(p.quality, 0);
    }
}

/// Frames of a small synthetic scene: quick to track, even under qemu's TCG.
const DOTS_WIDTH_PX: usize = 64;
const DOTS_HEIGHT_PX: usize = 48;
const DOTS_FRAMES: usize = 90;
/// Frames without the light, so lost updates cross the UART too.
const DOTS_HIDDEN: std::ops::Range<usize> = 40..50;

/// A bright disk gliding over a dim textured background, packed YUYV.
fn dots() -> Vec<u8> {
    let mut out = Vec::with_capacity(DOTS_FRAMES * DOTS_WIDTH_PX * DOTS_HEIGHT_PX * 2);
    for i in 0..DOTS_FRAMES {
        let (cx, cy) = (10.0 + 0.45 * i as f64, 20.0 + 0.1 * i as f64);
        for y in 0..DOTS_HEIGHT_PX {
            for x in 0..DOTS_WIDTH_PX {
                let lit = !DOTS_HIDDEN.contains(&i)
                    && (x as f64 - cx).powi(2) + (y as f64 - cy).powi(2) <= 9.0;
                out.push(if lit { 255 } else { 40 + ((x + y) % 20) as u8 });
                out.push(128);
            }
        }
    }
    out
}

/// glint's arguments for [`dots`].
fn dots_args() -> Vec<String> {
    [
        "--size".into(),
        format!("{DOTS_WIDTH_PX}x{DOTS_HEIGHT_PX}"),
        "--fps".into(),
        "30".into(),
    ]
    .into()
}

#[test]
fn one_valid_update_per_frame_in_order_with_heartbeats() {
    let frames = Frames::new("leave-occlude");
    // Past 256 updates, so the sequence number wraps.
    let total = 2 * frames.count();
    let (master, _slave, name) = pty();
    let robot = Robot::listen(master);
    let mut glint = Glint::start("-", &scene_args(&frames.scene), Path::new(&name));

    let mut positions = Vec::new();
    let mut heartbeats = Vec::new();
    for i in 0..total {
        let sending = Instant::now();
        glint.send(frames.frame(i));
        let (p, age) = robot.next_update(&mut heartbeats, i);
        check_age(&p, &age, sending.elapsed());
        positions.push(p);
    }
    let done = glint.finish();
    let leftover = robot.drain(Duration::from_millis(200));
    assert!(leftover.is_empty(), "after the last update: {leftover:?}");
    assert!(done.status.success(), "glint failed:\n{}", done.log);
    assert_eq!(robot.first_byte.try_recv(), Ok(0x00), "opening delimiter");

    assert_eq!(done.reports.len(), total);
    let mut last_found = (0, 0);
    for (p, r) in positions.iter().zip(&done.reports) {
        check_against_report(p, r, &mut last_found);
    }
    let found = done.reports.iter().filter(|r| r["found"] == true).count();
    assert!(
        found > total / 2 && found < total,
        "found {found} of {total}"
    );

    // A heartbeat before the first update, then one as soon as a second of frame time has
    // passed since the last.
    let t = |frame: usize| done.reports[frame]["t"].as_f64().unwrap();
    let mut expected = vec![0];
    for frame in 1..total {
        if t(frame) - t(*expected.last().unwrap()) >= 1.0 - 1e-6 {
            expected.push(frame);
        }
    }
    let at: Vec<usize> = heartbeats.iter().map(|(f, _)| *f).collect();
    assert_eq!(at, expected);
    let fps_centihz = (frames.scene.fps() * 100.0).round() as u16;
    for (n, (frame, h)) in heartbeats.iter().enumerate() {
        assert_eq!(h.protocol_version, PROTOCOL_VERSION);
        assert_eq!(h.dropped_frames, 0);
        if n > 0 {
            assert!(h.frame_rate_centihz.abs_diff(fps_centihz) <= 1, "{h:?}");
        }
        let state = if done.reports[*frame]["found"] == true {
            TrackerState::Tracking
        } else if done.reports[..*frame].iter().any(|r| r["found"] == true) {
            TrackerState::Coasting
        } else {
            TrackerState::Searching
        };
        // Coasting turns to searching after a long loss; the scene's gaps are short.
        assert_eq!(h.tracker_state, state, "heartbeat at frame {frame}");
    }

    let summary = serial_summary(&done.log);
    assert_eq!(count(&summary, "updates"), total as u64);
    assert_eq!(count(&summary, "dropped"), 0, "{}", done.log);
}

#[test]
fn a_receiver_that_stops_reading_costs_stale_updates_not_tracking() {
    let (master, mut slave, name) = pty();
    // Fill the pty's buffer towards the master, which nobody reads: glint's writes find no room.
    // Non-blocking, or the last write would wait for all its bytes to fit.
    fcntl(slave.as_raw_fd(), FcntlArg::F_SETFL(OFlag::O_NONBLOCK)).unwrap();
    let filler = [0u8; 4096];
    let mut filled = 0;
    while let Ok(n) = slave.write(&filler) {
        filled += n;
    }
    assert!(filled > 0);
    let mut dump = tempfile::NamedTempFile::new().unwrap();
    dump.write_all(&dots()).unwrap();

    // Small frames from a file, as fast as glint goes: many frames per write timeout.
    let glint = Glint::start(
        dump.path().to_str().unwrap(),
        &dots_args(),
        Path::new(&name),
    );
    let done = glint.finish();
    assert!(done.status.success(), "glint failed:\n{}", done.log);
    assert_eq!(done.reports.len(), DOTS_FRAMES, "every frame reported");

    let summary = serial_summary(&done.log);
    let posted = count(&summary, "updates") + count(&summary, "heartbeats");
    assert_eq!(count(&summary, "updates"), DOTS_FRAMES as u64);
    assert!(count(&summary, "stale") > 0, "{summary:?}");
    assert!(
        count(&summary, "timed_out") > 0,
        "writes timed out: {summary:?}"
    );
    assert_eq!(count(&summary, "sent") + count(&summary, "dropped"), posted);
    drop(master);
}

#[test]
fn pulling_the_pty_away_mid_run_is_logged_and_tracking_goes_on() {
    let frames = Frames::new("slow-line");
    let (master, slave, name) = pty();
    let robot = Robot::listen(master);
    let mut glint = Glint::start("-", &scene_args(&frames.scene), Path::new(&name));
    let half = frames.count() / 2;
    let mut heartbeats = Vec::new();
    for i in 0..half {
        glint.send(frames.frame(i));
        robot.next_position(&mut heartbeats, i);
    }
    // The robot's end goes away (an adapter unplugged): the slave hangs up and its node goes.
    drop(robot);
    drop(slave);
    for i in half..frames.count() {
        glint.send(frames.frame(i));
    }
    let done = glint.finish();
    assert!(done.status.success(), "glint failed:\n{}", done.log);
    assert_eq!(done.reports.len(), frames.count(), "every frame reported");
    let warnings: Vec<&str> = done.log.lines().filter(|l| l.contains("lost")).collect();
    assert_eq!(warnings.len(), 1, "the loss is logged once:\n{}", done.log);
    assert!(warnings[0].starts_with("glint: warn: serial port"));

    let summary = serial_summary(&done.log);
    assert_eq!(count(&summary, "updates"), frames.count() as u64);
    assert!(count(&summary, "sent") >= half as u64);
    assert!(count(&summary, "port_down") > 0, "{summary:?}");
    assert_eq!(count(&summary, "losses"), 1);
    assert_eq!(count(&summary, "reopens"), 0);
}

#[test]
fn a_port_that_comes_back_is_reopened_and_starts_with_a_delimiter() {
    let frames = Frames::new("slow-line");
    let dir = tempfile::tempdir().unwrap();
    let link = dir.path().join("robot");
    let (master, slave, name) = pty();
    std::os::unix::fs::symlink(&name, &link).unwrap();
    let robot = Robot::listen(master);
    let mut glint = Glint::start("-", &scene_args(&frames.scene), &link);
    let mut heartbeats = Vec::new();
    let unplug_at = 20;
    for i in 0..unplug_at {
        glint.send(frames.frame(i));
        assert_eq!(robot.next_position(&mut heartbeats, i).seq, i as u8);
    }

    // Unplugged: the device node goes away; frames go on.
    drop(robot);
    drop(slave);
    std::fs::remove_file(&link).unwrap();
    let gone_until = unplug_at + 10;
    for i in unplug_at..gone_until {
        glint.send(frames.frame(i));
    }

    // Plugged back in, under the same name (as /dev/serial/by-id/... would be).
    let (master, _slave, name) = pty();
    std::os::unix::fs::symlink(&name, &link).unwrap();
    let robot = Robot::listen(master);
    let mut i = gone_until;
    let first = loop {
        assert!(i < frames.count(), "the port was not reopened");
        glint.send(frames.frame(i));
        i += 1;
        match robot.messages.recv_timeout(Duration::from_millis(100)) {
            Ok(Ok(Message::Position(p))) => {
                robot.age_of(&p);
                break p;
            }
            Ok(Ok(Message::Heartbeat(_))) | Err(RecvTimeoutError::Timeout) => {}
            Ok(other) => panic!("after reopening the robot saw {other:?}"),
            Err(e) => panic!("{e}"),
        }
    };
    assert_eq!(
        robot.first_byte.try_recv(),
        Ok(0x00),
        "reopened with a delimiter"
    );
    // Every update after the reopening arrives, numbered by frame: the gap is the outage. The
    // port may come back while glint still works through the frames sent during the outage, so
    // the first update after it may be any from the unplugging on.
    assert!(
        usize::from(first.seq) >= unplug_at && usize::from(first.seq) < i,
        "first {first:?}, gone until {gone_until}, sent {i}"
    );
    // Updates posted while the port was being reopened may still be on their way (on a loaded
    // machine the first one seen need not be the last one sent): take them, in order, before
    // holding every further frame to its own update.
    let mut last_seq = first.seq;
    while usize::from(last_seq) + 1 < i {
        match robot.messages.recv_timeout(Duration::from_millis(500)) {
            Ok(Ok(Message::Position(p))) => {
                assert!(p.seq > last_seq, "in order after reopening");
                robot.age_of(&p);
                last_seq = p.seq;
            }
            Ok(Ok(Message::Heartbeat(_))) => {}
            _ => break,
        }
    }
    for j in i..frames.count() {
        glint.send(frames.frame(j));
        assert_eq!(robot.next_position(&mut heartbeats, j).seq, j as u8);
    }
    let done = glint.finish();
    assert!(done.status.success(), "glint failed:\n{}", done.log);
    assert_eq!(done.reports.len(), frames.count());
    assert!(done.log.contains("reopened after"), "{}", done.log);
    let summary = serial_summary(&done.log);
    assert_eq!(count(&summary, "losses"), 1);
    assert_eq!(count(&summary, "reopens"), 1);
}

#[test]
fn a_port_that_cannot_be_opened_is_an_error_at_start() {
    let out = common::glint()
        .args(["track", "--input", "-", "--size", "64x48", "--serial"])
        .arg("/nonexistent/tty")
        .stdin(Stdio::null())
        .output()
        .expect("run glint");
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.starts_with("glint: cannot open serial port /nonexistent/tty"),
        "{err}"
    );
}

#[test]
fn the_baud_rate_is_checked() {
    let out = common::glint()
        .args(["track", "--input", "-", "--size", "64x48", "--baud", "0"])
        .stdin(Stdio::null())
        .output()
        .expect("run glint");
    assert_eq!(out.status.code(), Some(2));
}

/// A real UART: in the test VM of tests/vm/ (the vivid suite's), glint writes to the guest's
/// /dev/ttyS1, a 16550A driven by the kernel's 8250 driver, which qemu joins to a host pty read
/// here. Every frame glint reports as sent must arrive intact, in order, matching its report.
/// Needs tools/setup-system.sh's packages; `GLINT_SKIP_VM=1` skips it (loudly).
#[test]
fn a_real_uart_in_a_vm_delivers_every_frame_sent() {
    if common::skipped("GLINT_SKIP_VM", "the serial link over the VM's 8250 UART") {
        return;
    }
    let repo = Path::new(env!("CARGO_MANIFEST_DIR"));
    let share = Path::new(env!("CARGO_TARGET_TMPDIR")).join("serial-vm");
    let _ = std::fs::remove_dir_all(&share);
    std::fs::create_dir_all(share.join("in")).unwrap();
    // Stripped, it is far quicker to load through 9p under TCG.
    let stripped = std::process::Command::new("strip")
        .arg("-o")
        .arg(share.join("glint"))
        .arg(env!("CARGO_BIN_EXE_glint"))
        .status()
        .is_ok_and(|s| s.success());
    if !stripped {
        std::fs::copy(env!("CARGO_BIN_EXE_glint"), share.join("glint")).unwrap();
    }
    std::fs::copy(
        repo.join("tests/vm/serial-guest.sh"),
        share.join("guest.sh"),
    )
    .unwrap();
    std::fs::write(share.join("in/dots.yuv"), dots()).unwrap();
    std::fs::write(share.join("in/args"), dots_args().join(" ")).unwrap();

    let prepare = std::process::Command::new(repo.join("tests/vm/prepare.sh"))
        .output()
        .expect("run tests/vm/prepare.sh");
    assert!(
        prepare.status.success(),
        "tests/vm/prepare.sh failed: {}",
        String::from_utf8_lossy(&prepare.stderr)
    );
    let mut vm = {
        let _spawning = SPAWNING.lock().unwrap_or_else(PoisonError::into_inner);
        std::process::Command::new(repo.join("tests/vm/run.sh"))
            .arg(&share)
            .env("GLINT_VM_QEMU_EXTRA", "-serial pty")
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .expect("start tests/vm/run.sh")
    };

    // qemu names its pty on standard error: "char device redirected to /dev/pts/N (label ...)".
    let started = Instant::now();
    let pty = loop {
        let log = std::fs::read_to_string(share.join("qemu.log")).unwrap_or_default();
        if let Some(at) = log.find("/dev/pts/") {
            let name: String = log[at..]
                .chars()
                .take_while(|c| !c.is_whitespace())
                .collect();
            break name;
        }
        if let Some(status) = vm.try_wait().unwrap() {
            panic!("the VM ended ({status}) before qemu named its pty:\n{log}");
        }
        assert!(started.elapsed() < PATIENCE, "qemu did not name its pty");
        std::thread::sleep(Duration::from_millis(20));
    };
    let mut port = serialport::new(&pty, 115_200)
        .open_native()
        .expect("open qemu's pty");
    // Handshake: the guest says "r" once its port is open (bytes reaching a closed 8250 port
    // are lost), and waits for our "g" before it starts glint.
    let mut ready = [0u8; 1];
    loop {
        match port.read(&mut ready) {
            Ok(1) if ready == *b"r" => break,
            Ok(_) => panic!("unexpected byte {ready:?} from the guest"),
            Err(_) => {
                if let Some(status) = vm.try_wait().unwrap() {
                    panic!("the VM ended ({status}) before the guest was ready");
                }
            }
        }
    }
    port.write_all(b"g").unwrap();
    let robot = Robot::listen(port);
    let run = vm.wait_with_output().expect("wait for the VM");
    let seen = robot.drain(Duration::from_millis(500));
    let out = share.join("out");
    let log = std::fs::read_to_string(out.join("serial.err")).unwrap_or_default();
    assert!(
        run.status.success(),
        "the VM run failed ({}): {}\nglint's log:\n{log}",
        run.status,
        String::from_utf8_lossy(&run.stderr)
    );
    let status = std::fs::read_to_string(out.join("serial.status")).unwrap();
    assert_eq!(status.trim(), "0", "glint in the guest failed:\n{log}");
    let reports = common::parse_jsonl(&std::fs::read(out.join("serial.jsonl")).unwrap());
    assert_eq!(reports.len(), DOTS_FRAMES);
    assert_eq!(robot.first_byte.try_recv(), Ok(0x00), "opening delimiter");

    let mut positions = Vec::new();
    let mut heartbeats = 0u64;
    for s in seen {
        match s {
            Ok(Message::Position(p)) => positions.push(p),
            Ok(Message::Heartbeat(h)) => {
                assert_eq!(h.protocol_version, PROTOCOL_VERSION);
                heartbeats += 1;
            }
            // Each update's age follows it; the LED is never asked for here.
            Ok(Message::Age(a)) => assert_eq!(Some(a.seq), positions.last().map(|p| p.seq)),
            Ok(Message::Led(r)) => panic!("over the UART: an unasked LED request {r:?}"),
            // One robot on its own line: never an addressed update.
            Ok(Message::RobotPosition(r)) => panic!("over the UART: an addressed update {r:?}"),
            Err(e) => panic!("over the UART: {e}"),
        }
    }
    // Whatever glint handed to the kernel came out of the UART, nothing else.
    let summary = serial_summary(&log);
    assert_eq!(
        positions.len() as u64 + heartbeats,
        count(&summary, "sent"),
        "{log}"
    );
    assert!(heartbeats >= 1);
    assert!(positions.len() > DOTS_FRAMES / 2, "{log}");
    // In order, each one matching its frame's report (fewer than 256 frames: seq = frame).
    let mut last_found = (0, 0);
    let mut previous_seq = None;
    for p in &positions {
        assert!(previous_seq < Some(p.seq), "updates in order");
        previous_seq = Some(p.seq);
        let r = &reports[usize::from(p.seq)];
        if r["found"] == false {
            // Lost updates repeat the last found position, which may not have been sent, or
            // (0, 0) before the first (a light standing still at the start is not yet taken).
            let prior = reports[..usize::from(p.seq)]
                .iter()
                .rev()
                .find(|r| r["found"] == true);
            last_found = prior.map_or((0, 0), |prior| {
                (
                    (prior["x"].as_f64().unwrap() * f64::from(QUANTA_PER_PX)).round() as i16,
                    (prior["y"].as_f64().unwrap() * f64::from(QUANTA_PER_PX)).round() as i16,
                )
            });
        }
        check_against_report(p, r, &mut last_found);
    }
    let lost = positions
        .iter()
        .filter(|p| p.status == Status::Lost)
        .count();
    assert!(lost > 0, "lost updates crossed the UART too");
}

/// The median of `values`.
fn median(mut values: Vec<f64>) -> f64 {
    values.sort_by(f64::total_cmp);
    values.get(values.len() / 2).copied().unwrap_or(f64::NAN)
}

#[test]
fn predict_arrival_moves_found_positions_on_by_their_age_and_says_so() {
    let frames = Frames::new("figure-eight");
    let (master, _slave, name) = pty();
    let robot = Robot::listen(master);
    let mut args = scene_args(&frames.scene);
    args.extend(["--predict".to_string(), "arrival".to_string()]);
    let mut glint = Glint::start("-", &args, Path::new(&name));
    let mut updates = Vec::new();
    let mut heartbeats = Vec::new();
    let count = frames.count() / 2;
    for i in 0..count {
        glint.send(frames.frame(i));
        updates.push(robot.next_update(&mut heartbeats, i));
    }
    let done = glint.finish();
    assert!(done.status.success(), "glint failed:\n{}", done.log);
    assert_eq!(done.reports.len(), count);
    let px = f64::from(QUANTA_PER_PX);
    let trajectory = &frames.scene.config().trajectory;
    let mut predicted = 0;
    let mut closer = 0;
    // Per predicted update: its error against the truth on arrival, and what its inputs'
    // errors (position at capture, velocity over the age, both against the truth, and the
    // path's bend over the age) allow.
    let (mut sent_errors, mut input_errors) = (Vec::new(), Vec::new());
    let (mut json_errors, mut json_input_errors) = (Vec::new(), Vec::new());
    for ((p, age), r) in updates.iter().zip(&done.reports) {
        let frame = r["frame"].as_u64().unwrap();
        let velocity = r["vx"].as_f64().zip(r["vy"].as_f64());
        if r["found"] != true || velocity.is_none() {
            assert!(!age.predicted, "frame {frame}: nothing to predict from");
            assert!(r.get("predicted").is_none(), "frame {frame}");
            continue;
        }
        let (vx, vy) = velocity.unwrap();
        // Frames after the first of a track have their bend measured too; all are predicted.
        assert!(
            age.predicted,
            "frame {frame}: a found, moving LED is predicted"
        );
        predicted += 1;
        // Against the renderer's truth at the arrival: the end of the exposure plus the age.
        let ahead_s = f64::from(age.age_us) * 1e-6;
        let at = trajectory
            .motion(r["t"].as_f64().unwrap() + ahead_s)
            .position_px;
        let sent = (f64::from(p.x) / px, f64::from(p.y) / px);
        let miss = |(x, y): (f64, f64)| (x - at.x).hypot(y - at.y);
        let measured = (r["x"].as_f64().unwrap(), r["y"].as_f64().unwrap());
        closer += usize::from(miss(sent) < miss(measured));
        let t_s = r["t"].as_f64().unwrap();
        let truth = trajectory.motion(t_s);
        let position_error =
            (measured.0 - truth.position_px.x).hypot(measured.1 - truth.position_px.y);
        let velocity_error = (vx - truth.velocity_px_s.x).hypot(vy - truth.velocity_px_s.y);
        // The path's bend over the look-ahead, which the prediction estimates from the turn of
        // the measured velocity: half the true acceleration times the look-ahead squared.
        let bend_px = |ahead_s: f64| {
            let (before, after) = (trajectory.motion(t_s - 1e-3), trajectory.motion(t_s + 1e-3));
            let ax = (after.velocity_px_s.x - before.velocity_px_s.x) / 2e-3;
            let ay = (after.velocity_px_s.y - before.velocity_px_s.y) / 2e-3;
            0.5 * ax.hypot(ay) * ahead_s * ahead_s
        };
        sent_errors.push(miss(sent));
        input_errors.push(position_error + velocity_error * ahead_s + bend_px(ahead_s) + 0.5 / px);
        // The JSON line's own prediction, to the moment it was written, is flagged there.
        let j = &r["predicted"];
        let ahead_ms = j["ahead_ms"].as_f64().expect("ahead_ms");
        let at = trajectory
            .motion(r["t"].as_f64().unwrap() + ahead_ms * 1e-3)
            .position_px;
        let printed = (j["x"].as_f64().unwrap(), j["y"].as_f64().unwrap());
        json_errors.push((printed.0 - at.x).hypot(printed.1 - at.y));
        json_input_errors
            .push(position_error + velocity_error * ahead_ms * 1e-3 + bend_px(ahead_ms * 1e-3));
    }
    let (sent, inputs) = (median(sent_errors), median(input_errors));
    eprintln!("sent {sent:.2} px from the truth on arrival (median), inputs allow {inputs:.2} px");
    assert!(
        sent <= inputs,
        "sent {sent:.2} px, its inputs allow {inputs:.2} px"
    );
    let (json, json_inputs) = (median(json_errors), median(json_input_errors));
    assert!(
        json <= json_inputs + JSON_POSITION_RESOLUTION_PX,
        "JSON prediction {json:.2} px, its inputs allow {json_inputs:.2} px"
    );
    assert!(predicted > count / 2, "{predicted} of {count} predicted");
    // Moving on by the age brings nearly every update closer to where the LED is on arrival.
    assert!(
        closer * 10 >= predicted * 9,
        "{closer} of {predicted} closer"
    );
}
