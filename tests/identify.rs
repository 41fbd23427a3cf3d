//! Identification end to end: `glint track --robots 2 --serial PTY` (or `--serial 1=PTY1
//! --serial 2=PTY2`) reads frames rendered on the fly from its standard input and talks to the
//! robots over real pty pairs (one shared line, or a line each);
//! a thread standing in for both robots decodes the LED requests and switches the asked robot's
//! LED off, at the requested frame time, in the frames rendered next (as tests/latency.rs does
//! for one robot). The harness owns the timeline: frame n shows the LEDs as they are at frame
//! time n, and is only written once glint's updates for frame n − 2 have arrived.
//!
//! The robots' ids are not their order of appearance. glint must bind each track to the robot
//! that answered, report `id_source` blink, and never send a robot another robot's position.

mod common;

use std::io::{Read, Write};
use std::os::unix::io::AsRawFd;
use std::process::{Child, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Condvar, Mutex, PoisonError};
use std::time::{Duration, Instant};

use glint_protocol::{Decoder, Message, Received, Status, Units, QUANTA_PER_PX};
use glint_tools::scene::{Fleet, Point, Scene, SceneConfig, Trajectory};
use nix::fcntl::{fcntl, FcntlArg, FdFlag};
use serde_json::Value;
use serialport::{SerialPort, TTYPort};

/// A slow frame clock: 10 fps, so that glint's processing time (wall clock, between a frame
/// and its request) stays well inside the two frames identification allows for it.
const FPS: u32 = 10;
const FRAME_US: u64 = 100_000;
const FRAMES: u64 = 100;
/// Frames written ahead of glint's updates.
const AHEAD_FRAMES: u64 = 2;
/// The whole test may not take longer than this; only reached when something is broken.
const PATIENCE: Duration = Duration::from_secs(240);
/// How far a robot's position may be from its own LED's truth, px.
const NEAR_PX: f64 = 8.0;

/// Fleet robot k (in rendering order) is robot ROBOT_IDS[k]: the first robot seen is id 2.
const ROBOT_IDS: [u8; 2] = [2, 1];

/// The robots' paths: parallel lines far apart, moving so that neither is taken for glare.
fn trajectories() -> [Trajectory; 2] {
    [
        Trajectory::Line {
            start_px: Point::new(80.0, 120.0),
            velocity_px_s: Point::new(30.0, 0.0),
        },
        Trajectory::Line {
            start_px: Point::new(560.0, 360.0),
            velocity_px_s: Point::new(-30.0, 0.0),
        },
    ]
}

/// Where robot k's LED is at frame time `t_us`, px.
fn truth_px(k: usize, t_us: u64) -> (f64, f64) {
    let t_s = t_us as f64 * 1e-6;
    match &trajectories()[k] {
        Trajectory::Line {
            start_px,
            velocity_px_s,
        } => (
            start_px.x + velocity_px_s.x * t_s,
            start_px.y + velocity_px_s.y * t_s,
        ),
        _ => unreachable!("lines only"),
    }
}

fn base() -> SceneConfig {
    let mut c = Scene::preset_config("slow-line").expect("preset");
    c.fps = f64::from(FPS);
    c.exposure_us = 2_000;
    c.frame_count = FRAMES as usize;
    c
}

/// One fleet per set of lit robots (bit k: robot k lit); a dark robot's LED is out of view.
fn fleets() -> Vec<Fleet> {
    let gone = Trajectory::Line {
        start_px: Point::new(-400.0, -400.0),
        velocity_px_s: Point::new(0.0, 0.0),
    };
    (0..4u8)
        .map(|lit| {
            let paths: Vec<Trajectory> = trajectories()
                .iter()
                .enumerate()
                .map(|(k, t)| {
                    if lit & (1 << k) != 0 {
                        t.clone()
                    } else {
                        gone.clone()
                    }
                })
                .collect();
            Fleet::new(&base(), &paths).expect("valid fleet")
        })
        .collect()
}

/// What the robots' end has seen, shared with the frame writer.
#[derive(Debug, Default)]
struct Robots {
    /// The newest frame time an update arrived for.
    last_frame_us: Option<u64>,
    /// Per robot id − 1: frame time its LED is off from and until, per its last request.
    dark_us: [Option<(u64, u64)>; 2],
    /// LED requests per robot id − 1.
    requests: [u32; 2],
    /// Found updates per robot id − 1.
    found: [u32; 2],
    /// Updates whose position was another robot's (must stay empty).
    misaddressed: Vec<String>,
}

struct Shared {
    robots: Mutex<Robots>,
    changed: Condvar,
    stop: AtomicBool,
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

/// The fleet index of robot `id`.
fn fleet_index(id: u8) -> Option<usize> {
    ROBOT_IDS.iter().position(|&r| r == id)
}

/// Decodes a master end as the robots' firmware would: on the shared line (`own` None) each
/// robot takes the updates addressed to it; on robot `own`'s line, the plain updates are its.
/// A robot answers LED requests for its id (from `at_us` + `delay_us`, in glint's frame clock).
fn listen(
    mut master: TTYPort,
    own: Option<u8>,
    shared: Arc<Shared>,
) -> std::thread::JoinHandle<()> {
    std::thread::spawn(move || {
        let mut decoder = Decoder::new();
        let mut buf = [0u8; 1024];
        while !shared.stop.load(Ordering::Relaxed) {
            let n = match master.read(&mut buf) {
                Ok(n) => n,
                Err(_) => {
                    std::thread::sleep(Duration::from_millis(1));
                    continue;
                }
            };
            for event in decoder.feed(&buf[..n]) {
                let mut robots = shared.robots.lock().unwrap_or_else(PoisonError::into_inner);
                let update = match event {
                    Ok(Received::Message(Message::RobotPosition(r))) if own.is_none() => {
                        Some((r.robot, r.position))
                    }
                    Ok(Received::Message(Message::Position(p))) => own.map(|robot| (robot, p)),
                    _ => None,
                };
                match event {
                    _ if update.is_some() => {
                        let Some((robot, p)) = update else { continue };
                        // The frame clock wraps at 2³² µs; this run is far shorter.
                        let t_us = u64::from(p.timestamp_us);
                        robots.last_frame_us = robots.last_frame_us.max(Some(t_us));
                        let Some(k) = fleet_index(robot) else {
                            robots.misaddressed.push(format!("no robot {robot}"));
                            continue;
                        };
                        if p.status == Status::Found {
                            assert_eq!(p.units, Units::Pixels, "no calibration");
                            let at = (
                                f64::from(p.x) / f64::from(QUANTA_PER_PX),
                                f64::from(p.y) / f64::from(QUANTA_PER_PX),
                            );
                            let truth = truth_px(k, t_us);
                            if (at.0 - truth.0).hypot(at.1 - truth.1) > NEAR_PX {
                                robots.misaddressed.push(format!(
                                    "robot {robot} at frame time {t_us} µs got {at:?}, its LED \
                                     is at {truth:?}"
                                ));
                            }
                            robots.found[usize::from(robot) - 1] += 1;
                        }
                    }
                    Ok(Received::Message(Message::Led(l))) => {
                        if own.is_some_and(|o| o != l.robot) {
                            robots
                                .misaddressed
                                .push(format!("on robot {own:?}'s line: {l:?}"));
                        }
                        if let Some(i) = usize::from(l.robot).checked_sub(1).filter(|&i| i < 2) {
                            robots.requests[i] += 1;
                            let from = u64::from(l.at_us) + u64::from(l.delay_us);
                            robots.dark_us[i] = Some((from, from + u64::from(l.off_us)));
                        }
                    }
                    Ok(Received::Message(
                        m @ (Message::Position(_) | Message::RobotPosition(_)),
                    )) => {
                        robots.misaddressed.push(format!(
                            "on line {own:?}, an update of the wrong kind: {m:?}"
                        ));
                    }
                    Ok(_) => {}
                    Err(e) => panic!("the robots' end saw a bad frame: {e}"),
                }
                drop(robots);
                shared.changed.notify_all();
            }
        }
    })
}

#[test]
fn each_robot_is_identified_by_its_own_blink_over_a_shared_line() {
    identify_over(false);
}

#[test]
fn each_robot_is_identified_by_its_own_blink_over_its_own_line() {
    identify_over(true);
}

/// Runs glint with both robots on one line, or each on its own (`--serial ID=PORT`), and
/// checks what the robots got and what glint reported.
fn identify_over(own_lines: bool) {
    let fleets = fleets();
    let first = fleets[3].robot(0).expect("robot 0");
    let size = format!("{}x{}", first.width_px(), first.height_px());
    let shared = Arc::new(Shared {
        robots: Mutex::new(Robots::default()),
        changed: Condvar::new(),
        stop: AtomicBool::new(false),
    });
    let mut serial_args = Vec::new();
    let mut listeners = Vec::new();
    let lines: &[Option<u8>] = if own_lines {
        &[Some(1), Some(2)]
    } else {
        &[None]
    };
    for &own in lines {
        let (master, name) = pty();
        serial_args.push("--serial".to_string());
        serial_args.push(match own {
            Some(robot) => format!("{robot}={name}"),
            None => name,
        });
        listeners.push(listen(master, own, Arc::clone(&shared)));
    }
    let mut glint: Child = common::glint()
        .args(["track", "--input", "-", "--size", &size, "--fps", "10"])
        .args(["--exposure-us", "2000", "--robots", "2"])
        .args(&serial_args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start glint");
    let mut stdin = glint.stdin.take().expect("stdin");
    let started = Instant::now();
    let mut frame = vec![0u8; first.frame_len_bytes()];
    for n in 0..FRAMES {
        let t_us = n * FRAME_US;
        let lit = {
            let mut robots = shared.robots.lock().unwrap_or_else(PoisonError::into_inner);
            if n >= AHEAD_FRAMES {
                let want_us = (n - AHEAD_FRAMES) * FRAME_US;
                while robots.last_frame_us.is_none_or(|t| t < want_us) {
                    assert!(glint.try_wait().expect("wait").is_none(), "glint stopped");
                    assert!(
                        started.elapsed() < PATIENCE,
                        "no update for frame {want_us} µs"
                    );
                    robots = shared
                        .changed
                        .wait_timeout(robots, Duration::from_millis(20))
                        .unwrap_or_else(PoisonError::into_inner)
                        .0;
                }
            }
            // Bit k: fleet robot k's LED is on at frame time t.
            (0..2).fold(0usize, |bits, k| {
                let id = usize::from(ROBOT_IDS[k]);
                let dark = robots.dark_us[id - 1].is_some_and(|(f, u)| t_us >= f && t_us < u);
                bits | (usize::from(!dark) << k)
            })
        };
        fleets[lit].render(n as usize, &mut frame).expect("render");
        stdin.write_all(&frame).expect("glint reads its input");
    }
    drop(stdin);
    let out = glint.wait_with_output().expect("glint output");
    shared.stop.store(true, Ordering::Relaxed);
    for listener in listeners {
        listener.join().expect("listener");
    }
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "glint failed: {stderr}");
    let robots = shared.robots.lock().unwrap_or_else(PoisonError::into_inner);

    assert!(
        robots.misaddressed.is_empty(),
        "{:#?}\n{stderr}",
        robots.misaddressed
    );
    assert!(
        robots.requests.iter().all(|&r| r >= 1),
        "each robot asked: {:?}",
        robots.requests
    );
    // Identified early: most frames after the first few seconds go to both robots.
    assert!(
        robots.found.iter().all(|&f| f >= (FRAMES / 2) as u32),
        "found updates per robot: {:?}\n{stderr}",
        robots.found
    );

    // The JSON lines: ids bound by blink, each at its own robot's LED.
    let lines: Vec<Value> = String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| serde_json::from_str(l).expect("JSON line"))
        .collect();
    assert_eq!(lines.len() as u64, FRAMES);
    let first_blink = lines
        .iter()
        .position(|l| {
            l["tracks"]
                .as_array()
                .is_some_and(|ts| ts.iter().all(|t| t["id_source"] == "blink"))
        })
        .expect("both robots identified");
    for (n, line) in lines.iter().enumerate() {
        for t in line["tracks"].as_array().expect("tracks") {
            let provisional = t["provisional"].as_bool().expect("provisional");
            let id = t["id"].as_u64().expect("id") as u8;
            assert_eq!(t["id_source"] == "blink", !provisional, "frame {n}: {t}");
            if provisional {
                assert!(
                    id > 16,
                    "frame {n}: a provisional id above every robot's: {t}"
                );
                continue;
            }
            if t["found"] == true {
                let k = fleet_index(id).expect("a robot's id");
                let own = truth_px(k, n as u64 * FRAME_US);
                let at = (t["x"].as_f64().unwrap(), t["y"].as_f64().unwrap());
                assert!(
                    (at.0 - own.0).hypot(at.1 - own.1) < NEAR_PX,
                    "frame {n}: track {id} at {at:?}, robot {id}'s LED at {own:?}"
                );
            }
        }
    }
    assert!(
        first_blink < (FRAMES / 2) as usize,
        "identified only at frame {first_blink}"
    );
}
