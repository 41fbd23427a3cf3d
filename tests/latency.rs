//! `glint latency` end to end: glint reads frames rendered on the fly from its standard input
//! and talks to the robot over a real pty pair; a thread standing in for the robot decodes the
//! LED requests and, a configured delay after each, switches the LED off in the frames it
//! renders next. The harness owns the timeline: frames are 1 ms apart on glint's frame clock
//! (`--fps 1000`), frame n shows the LED as it is at n ms, and the next frame is only written
//! once glint's update for the one two before it has arrived, so the frames can never run ahead
//! of a request. The latency glint measures must be the configured delay, whatever the
//! machine's speed.

mod common;

use std::io::{Read, Write};
use std::os::unix::io::AsRawFd;
use std::process::{Child, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Condvar, Mutex, PoisonError};
use std::time::{Duration, Instant};

use glint_protocol::{Decoder, Message, Received, EVERY_ROBOT};
use glint_tools::scene::{Point, Scene, Trajectory};
use nix::fcntl::{fcntl, FcntlArg, FdFlag};
use serialport::{SerialPort, TTYPort};

/// The harness's frame clock: 1 000 fps, so a frame is 1 ms.
const FPS: u32 = 1_000;
const FRAME_US: u64 = 1_000;
/// Frames written ahead of glint's updates.
const AHEAD_FRAMES: u64 = 2;
/// The robot's configured reaction: from a request's last byte to its LED going off.
const REACTION_US: u64 = 12_000;
/// The whole test may not take longer than this; only reached when something is broken.
const PATIENCE: Duration = Duration::from_secs(120);
/// What `glint latency` must get within: the brief's 2 ms.
const AGREEMENT_MS: f64 = 2.0;

/// What the robot's end has seen, shared with the frame writer.
#[derive(Debug, Default)]
struct Robot {
    /// The newest position update's seq.
    last_seq: Option<u8>,
    /// Frame time the LED is off from and until, per the last request answered.
    dark_us: Option<(u64, u64)>,
    requests: u32,
}

struct Shared {
    robot: Mutex<Robot>,
    changed: Condvar,
    stop: AtomicBool,
}

/// Scenes with the LED lit at the centre, and with it gone.
fn scenes() -> (Scene, Scene) {
    let make = |at: Point| {
        let mut c = Scene::preset_config("slow-line").expect("preset");
        c.width_px = 160;
        c.height_px = 120;
        c.fps = f64::from(FPS);
        c.exposure_us = 500;
        c.trajectory = Trajectory::Line {
            start_px: at,
            velocity_px_s: Point::new(0.0, 0.0),
        };
        Scene::new(c).expect("valid scene")
    };
    (
        make(Point::new(80.0, 60.0)),
        make(Point::new(-400.0, -400.0)),
    )
}

fn pty() -> (TTYPort, String) {
    let (master, slave) = TTYPort::pair().expect("pty pair");
    for end in [&master, &slave] {
        fcntl(end.as_raw_fd(), FcntlArg::F_SETFD(FdFlag::FD_CLOEXEC)).expect("close-on-exec");
    }
    let name = slave.name().expect("slave has a name");
    // The slave end is glint's; this process keeps only the master.
    std::mem::forget(slave);
    (master, name)
}

/// Decodes the master end: counts updates, and answers LED requests when `answer` is set.
fn listen(mut master: TTYPort, shared: Arc<Shared>, answer: bool) -> std::thread::JoinHandle<()> {
    std::thread::spawn(move || {
        let mut decoder = Decoder::new();
        let mut buf = [0u8; 512];
        while !shared.stop.load(Ordering::Relaxed) {
            let n = match master.read(&mut buf) {
                Ok(n) => n,
                Err(_) => {
                    std::thread::sleep(Duration::from_millis(1));
                    continue;
                }
            };
            for event in decoder.feed(&buf[..n]) {
                let mut robot = shared.robot.lock().unwrap_or_else(PoisonError::into_inner);
                match event {
                    Ok(Received::Message(Message::Position(p))) => {
                        robot.last_seq = Some(p.seq);
                    }
                    Ok(Received::Message(Message::Led(r))) if r.robot == EVERY_ROBOT => {
                        robot.requests += 1;
                        if answer {
                            let from = u64::from(r.at_us) + u64::from(r.delay_us) + REACTION_US;
                            robot.dark_us = Some((from, from + u64::from(r.off_us)));
                        }
                    }
                    Ok(_) => {}
                    Err(e) => panic!("the robot's end saw a bad frame: {e}"),
                }
                drop(robot);
                shared.changed.notify_all();
            }
        }
    })
}

/// Whether update `seq` is at or after frame `frame`'s (seq is the frame index mod 256).
fn reached(seq: u8, frame: u64) -> bool {
    (seq.wrapping_sub(frame as u8) as i8) >= 0
}

/// Runs `glint latency` against the harness; returns its exit status, standard output and
/// standard error, and the requests the robot saw.
fn run_latency(answer: bool, extra: &[&str]) -> (std::process::ExitStatus, String, String, u32) {
    let (lit, gone) = scenes();
    let (master, name) = pty();
    let shared = Arc::new(Shared {
        robot: Mutex::new(Robot::default()),
        changed: Condvar::new(),
        stop: AtomicBool::new(false),
    });
    let listener = listen(master, Arc::clone(&shared), answer);
    let mut glint: Child = common::glint()
        .args([
            "latency", "--input", "-", "--size", "160x120", "--fps", "1000",
        ])
        .args(["--exposure-us", "500", "--serial", &name, "--seed", "11"])
        .args(extra)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start glint");
    let mut stdin = glint.stdin.take().expect("stdin");
    let started = Instant::now();
    let mut frame = vec![0u8; lit.frame_len_bytes()];
    for n in 0u64.. {
        assert!(started.elapsed() < PATIENCE, "glint latency did not finish");
        let t_us = n * FRAME_US;
        let dark = {
            let mut robot = shared.robot.lock().unwrap_or_else(PoisonError::into_inner);
            // Never more than AHEAD_FRAMES frames ahead of glint's updates.
            if n >= AHEAD_FRAMES {
                let want = n - AHEAD_FRAMES;
                loop {
                    if robot.last_seq.is_some_and(|s| reached(s, want)) {
                        break;
                    }
                    if glint.try_wait().expect("wait").is_some() {
                        break;
                    }
                    assert!(started.elapsed() < PATIENCE, "no update for frame {want}");
                    robot = shared
                        .changed
                        .wait_timeout(robot, Duration::from_millis(20))
                        .unwrap_or_else(PoisonError::into_inner)
                        .0;
                }
            }
            robot
                .dark_us
                .is_some_and(|(from, until)| t_us >= from && t_us < until)
        };
        let scene = if dark { &gone } else { &lit };
        scene.render(n as usize % 1000, &mut frame).expect("render");
        if stdin.write_all(&frame).is_err() {
            break; // glint is done and closed its input
        }
    }
    drop(stdin);
    let out = glint.wait_with_output().expect("glint output");
    shared.stop.store(true, Ordering::Relaxed);
    listener.join().expect("listener");
    let requests = shared
        .robot
        .lock()
        .unwrap_or_else(PoisonError::into_inner)
        .requests;
    (
        out.status,
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
        requests,
    )
}

/// The p50 of the line `latency: request on the robot's side to dark frame captured: p50 X ms`.
fn captured_p50_ms(stdout: &str) -> f64 {
    let line = stdout
        .lines()
        .find(|l| l.contains("to dark frame captured"))
        .unwrap_or_else(|| panic!("no capture line in:\n{stdout}"));
    let after = line.split("p50 ").nth(1).expect("p50");
    after
        .split(" ms")
        .next()
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("bad line {line}"))
}

/// The figure after `label` on the line of `stdout` that contains `line_has`, in ms.
fn figure_after(stdout: &str, line_has: &str, label: &str) -> f64 {
    let line = stdout
        .lines()
        .find(|l| l.contains(line_has))
        .unwrap_or_else(|| panic!("no line with {line_has:?} in:\n{stdout}"));
    line.split(label)
        .nth(1)
        .and_then(|rest| rest.trim().split(" ms").next())
        .and_then(|v| v.trim().parse().ok())
        .unwrap_or_else(|| panic!("no figure after {label:?} in {line}"))
}

#[test]
fn the_measured_latency_is_the_robots_configured_delay() {
    let trials = 8;
    let (status, stdout, stderr, requests) = run_latency(
        true,
        &[
            "--trials",
            &trials.to_string(),
            "--off-ms",
            "30",
            "--answer-ms",
            "300",
        ],
    );
    assert!(
        status.success(),
        "glint latency failed:\n{stderr}\n{stdout}"
    );
    assert_eq!(requests, trials, "{stdout}");
    assert!(
        stdout.contains(&format!("{trials} of {trials} requests answered")),
        "{stdout}"
    );
    // The first frame ending at or after the LED went off: at most one frame period late.
    let p50 = captured_p50_ms(&stdout);
    let expected = REACTION_US as f64 * 1e-3;
    assert!(
        (p50 - expected).abs() <= AGREEMENT_MS,
        "measured {p50} ms, the robot's delay is {expected} ms:\n{stdout}"
    );
    assert!(stdout.contains("parts of the p50: line time"), "{stdout}");
    // From the frames' phases: the line time and the robot's reaction, without the wait for
    // the next frame.
    let phases = figure_after(&stdout, "from the frames' phases", "phases:");
    let line = figure_after(&stdout, "parts of the p50", "line time");
    assert!(
        (phases - line - expected).abs() <= AGREEMENT_MS,
        "from the phases {phases} ms less the line time {line} ms, the robot's delay is \
         {expected} ms:\n{stdout}"
    );
    eprintln!("{stdout}");
}

#[test]
fn a_robot_that_does_not_answer_is_reported_not_waited_for() {
    let (status, stdout, stderr, requests) = run_latency(
        false,
        &["--trials", "5", "--off-ms", "20", "--answer-ms", "50"],
    );
    assert!(!status.success(), "{stdout}");
    assert!(stderr.contains("robot did not answer"), "{stderr}");
    assert_eq!(requests, 3, "gave up after three in a row");
}

#[test]
fn without_a_link_it_refuses_to_start() {
    let out = common::glint()
        .args(["latency", "--input", "-", "--size", "160x120"])
        .stdin(Stdio::null())
        .output()
        .expect("run glint");
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("needs a link to the robot"), "{stderr}");
}
