//! One run of the whole loop, in real time:
//!
//! ```text
//!  physics (1 kHz) ──states──▶ camera (30 fps, rendered) ──YUYV──▶ glint run (stdin)
//!       ▲                                                              │ --serial
//!       │ wheel commands, LED                                          ▼
//!  UART1 pty ◀── firmware in qemu (mps2-an386) ◀── UART0 pty ◀── wire (baud) ◀── pty pair
//! ```
//!
//! Times are on the monotonic clock, the one glint stamps frames with: the rig knows when each
//! exposure ended, when the frame was handed to glint (glint's capture time for a frame read
//! from a pipe), and when each wheel command came back, so it can check the age the firmware
//! reports against the truth.

use std::collections::VecDeque;
use std::fs::File;
use std::io::{self, BufRead, BufReader, Read, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread;
use std::time::Duration;

use anyhow::{bail, Context, Result};
use glint::source::clock::monotonic_now_us;
use serialport::{SerialPort, TTYPort};

use super::board::Board;
use super::camera::{RigCamera, EXPOSURE_US, FPS, HEIGHT_PX, WIDTH_PX};
use super::drive::{DiffDrive, DriveParams, WheelSpeeds, STEP_S};
use super::lines::{self, Line};
use super::path::{FigureEight, PathError};
use super::wire;
use crate::stats::Spread;

/// The simulated robot's build: a 12 cm axle, 0.8 m/s motors with a 30 ms lag.
pub const RIG_DRIVE: DriveParams = DriveParams {
    wheel_base_m: 0.12,
    max_wheel_speed_m_s: 0.8,
    motor_lag_s: 0.03,
};
/// Path errors count from this long after the first wheel command: the start from rest.
const SETTLE_S: f64 = 1.0;
/// The frames' exposures end this long after the physics starts (it needs a past to draw).
const FIRST_EXPOSURE_S: f64 = 0.1;
/// Robot states kept for the camera, s.
const HISTORY_S: f64 = 0.5;
/// The driven path is kept every this many physics steps, for the plot.
const TRACE_EVERY_STEPS: u64 = 10;
/// Microseconds per second.
const US_PER_S: f64 = 1e6;
/// Ages on arrival beyond this (p95) mean the machine could not keep the loop in real time, ms.
const REAL_TIME_AGE_MS: f64 = 100.0;
/// How long glint may take to finish after its input ends.
const GLINT_EXIT_WAIT: Duration = Duration::from_secs(10);

/// What a run needs.
#[derive(Debug, Clone)]
pub struct LoopConfig {
    /// Seconds of frames.
    pub seconds: f64,
    /// The firmware moves positions on by their age.
    pub compensate: bool,
    /// The `glint` binary.
    pub glint: PathBuf,
    /// The firmware's ELF for mps2-an386.
    pub firmware: PathBuf,
    /// `qemu-system-arm`.
    pub qemu: PathBuf,
    /// The serial line's baud rate.
    pub baud: u32,
    /// Seed of the sensor noise.
    pub seed: u64,
    /// Where the calibration and glint's log go.
    pub work_dir: PathBuf,
}

/// What a run measured.
#[derive(Debug, Clone)]
pub struct LoopReport {
    /// Distance from the robot to the planned path, every physics step after the start, mm.
    pub path_error_mm: Spread,
    /// From the end of an exposure to its wheel command coming back (the position's age when
    /// the firmware acted on it, truth), ms.
    pub age_on_arrival_ms: Spread,
    /// The firmware's age minus the truth since glint's capture of the frame, ms (signed).
    pub age_error_ms: Vec<f64>,
    /// From the end of an exposure to the frame handed to glint (rendering, waiting for glint
    /// to take it), ms.
    pub delivery_ms: Spread,
    /// Rendering alone, ms.
    pub render_ms: Spread,
    /// Frames rendered.
    pub frames: usize,
    /// Wheel commands received (one per position update that reached the firmware).
    pub updates: usize,
    /// Frames whose update did not come back with the light in view.
    pub lost: usize,
    /// Garbled lines from the firmware.
    pub garbled: usize,
    /// The robot's path, m, every 10 ms.
    pub driven_m: Vec<(f64, f64)>,
}

/// A wheel command as it came back.
#[derive(Debug, Clone, Copy)]
struct Reply {
    command: lines::Command,
    /// When its line's first bytes arrived, monotonic µs.
    at_us: u64,
}

/// Everything the threads share.
struct World {
    robot: DiffDrive,
    /// Simulated time, monotonic µs of the last step.
    now_us: u64,
    /// (time µs, position m) of the recent steps.
    history: VecDeque<(u64, (f64, f64))>,
    /// Commands not yet applied, with their arrival times.
    commands: VecDeque<(u64, WheelSpeeds)>,
    /// LED switches not yet applied, and the LED now.
    led_events: VecDeque<(u64, bool)>,
    led_on: bool,
    /// (time µs, LED) of the recent steps.
    led_history: VecDeque<(u64, bool)>,
    first_command_us: Option<u64>,
    errors_m: Vec<f64>,
    driven_m: Vec<(f64, f64)>,
    steps: u64,
    replies: Vec<Reply>,
    garbled: usize,
}

fn lock(world: &Mutex<World>) -> MutexGuard<'_, World> {
    // A panicked thread leaves the world as it was: the run's figures say what happened.
    world.lock().unwrap_or_else(|e| e.into_inner())
}

impl World {
    /// Advances the physics to `until_us` in steps of [`STEP_S`].
    fn advance(&mut self, until_us: u64, path: &PathError) {
        let step_us = (STEP_S * US_PER_S) as u64;
        while self.now_us + step_us <= until_us {
            let t = self.now_us + step_us;
            while let Some(&(at, cmd)) = self.commands.front() {
                if at > t {
                    break;
                }
                self.robot.set_command(cmd);
                self.first_command_us.get_or_insert(at);
                self.commands.pop_front();
            }
            while let Some(&(at, on)) = self.led_events.front() {
                if at > t {
                    break;
                }
                self.led_on = on;
                self.led_events.pop_front();
            }
            self.robot.step();
            self.now_us = t;
            self.steps += 1;
            let at = self.robot.position_m;
            self.history.push_back((t, at));
            self.led_history.push_back((t, self.led_on));
            let keep_from = t.saturating_sub((HISTORY_S * US_PER_S) as u64);
            while self.history.front().is_some_and(|&(h, _)| h < keep_from) {
                self.history.pop_front();
            }
            while self
                .led_history
                .front()
                .is_some_and(|&(h, _)| h < keep_from)
            {
                self.led_history.pop_front();
            }
            if self
                .first_command_us
                .is_some_and(|f| t > f + (SETTLE_S * US_PER_S) as u64)
            {
                self.errors_m.push(path.distance_m(at));
            }
            if self.steps.is_multiple_of(TRACE_EVERY_STEPS) && self.first_command_us.is_some() {
                self.driven_m.push(at);
            }
        }
    }

    /// The robot's position at `t_us` (the nearest step at or before it).
    fn position_at(&self, t_us: u64) -> Option<(f64, f64)> {
        self.history
            .iter()
            .rev()
            .find(|&&(h, _)| h <= t_us)
            .map(|&(_, p)| p)
    }

    /// Whether the LED was on at `t_us`.
    fn led_at(&self, t_us: u64) -> bool {
        self.led_history
            .iter()
            .rev()
            .find(|&&(h, _)| h <= t_us)
            .is_none_or(|&(_, on)| on)
    }
}

/// Renders the calibration frame and runs `glint calibrate` on it.
fn calibrate(config: &LoopConfig, camera: &mut RigCamera, start_m: (f64, f64)) -> Result<PathBuf> {
    let mut frame = vec![0u8; camera.frame_len_bytes()];
    camera.render(0, start_m, start_m, true, &mut frame)?;
    let dump = config.work_dir.join("calibration.yuyv");
    std::fs::write(&dump, &frame).with_context(|| format!("cannot write {}", dump.display()))?;
    let calib = config.work_dir.join("calibration.toml");
    let mut cmd = Command::new(&config.glint);
    cmd.arg("calibrate").arg("--input").arg(&dump).args([
        "--size",
        &format!("{WIDTH_PX}x{HEIGHT_PX}"),
        "--lens",
        "ideal",
    ]);
    for marker in camera.marker_args() {
        cmd.args(["--marker", &marker]);
    }
    let out = cmd
        .arg("--out")
        .arg(&calib)
        .output()
        .with_context(|| format!("cannot run {}", config.glint.display()))?;
    if !out.status.success() {
        bail!(
            "glint calibrate failed: {}",
            String::from_utf8_lossy(&out.stderr).trim()
        );
    }
    Ok(calib)
}

/// Starts `glint run` on standard input with its serial port on `port`.
fn start_glint(config: &LoopConfig, calib: &Path, port: &str) -> Result<Child> {
    let log = config.work_dir.join("glint.log");
    let log = File::create(&log).with_context(|| format!("cannot create {}", log.display()))?;
    Command::new(&config.glint)
        .args(["run", "--input", "-"])
        .args(["--size", &format!("{WIDTH_PX}x{HEIGHT_PX}")])
        .args(["--fps", &FPS.to_string()])
        .arg("--calib")
        .arg(calib)
        .args(["--serial", port, "--baud", &config.baud.to_string()])
        .stdin(Stdio::piped())
        .stdout(Stdio::null())
        .stderr(log)
        .spawn()
        .with_context(|| format!("cannot start {}", config.glint.display()))
}

/// Reads the firmware's lines until `stop`.
fn read_replies(mut port: TTYPort, world: Arc<Mutex<World>>, stop: Arc<AtomicBool>) {
    let mut pending = Vec::new();
    // Arrival of the first byte of the line being read.
    let mut line_at_us = None;
    let mut buf = [0u8; 256];
    while !stop.load(Ordering::Relaxed) {
        let n = match port.read(&mut buf) {
            Ok(n) => n,
            Err(e) if e.kind() == io::ErrorKind::TimedOut => continue,
            Err(_) => break,
        };
        let at_us = monotonic_now_us();
        for &b in buf.get(..n).unwrap_or(&[]) {
            line_at_us.get_or_insert(at_us);
            if b != b'\n' {
                pending.push(b);
                continue;
            }
            let line_at = line_at_us.take().unwrap_or(at_us);
            let parsed = std::str::from_utf8(&pending).ok().and_then(lines::parse);
            pending.clear();
            let mut w = lock(&world);
            match parsed {
                Some(Line::Wheels(command)) => {
                    let speeds = WheelSpeeds {
                        left_m_s: f64::from(command.left_mm_s) * 1e-3,
                        right_m_s: f64::from(command.right_mm_s) * 1e-3,
                    };
                    w.commands.push_back((line_at, speeds));
                    w.replies.push(Reply {
                        command,
                        at_us: line_at,
                    });
                }
                Some(Line::Led(on)) => w.led_events.push_back((line_at, on)),
                Some(Line::Other) => {}
                None => w.garbled += 1,
            }
        }
    }
}

/// Runs the physics in real time until `stop`.
fn run_physics(world: Arc<Mutex<World>>, stop: Arc<AtomicBool>) {
    let path = PathError::new(&FigureEight::RIG);
    while !stop.load(Ordering::Relaxed) {
        lock(&world).advance(monotonic_now_us(), &path);
        thread::sleep(Duration::from_micros(500));
    }
}

/// One frame handed to glint.
#[derive(Debug, Clone, Copy)]
struct Handed {
    exposure_end_us: u64,
    rendered_us: u64,
    handed_us: u64,
}

/// Runs the loop once.
pub fn run_loop(config: &LoopConfig) -> Result<LoopReport> {
    let path = FigureEight::RIG;
    let (start_m, heading) = path.start();
    let mut camera = RigCamera::new(config.seed)?;
    let calib = calibrate(config, &mut camera, start_m)?;

    let board = Board::start(&config.qemu, &config.firmware, config.compensate)?;
    let (mut glint_side, glint_port) = TTYPort::pair().context("cannot open a pty pair")?;
    glint_side
        .set_timeout(wire::POLL)
        .context("setting the pty's timeout")?;
    let port_name = glint_port.name().context("the pty pair's name")?;
    let mut glint = start_glint(config, &calib, &port_name)?;
    let mut stdin = glint.stdin.take().context("glint's standard input")?;

    let stop = Arc::new(AtomicBool::new(false));
    let origin_us = monotonic_now_us();
    let world = Arc::new(Mutex::new(World {
        robot: DiffDrive::new(RIG_DRIVE, start_m, heading),
        now_us: origin_us,
        history: VecDeque::new(),
        commands: VecDeque::new(),
        led_events: VecDeque::new(),
        led_on: true,
        led_history: VecDeque::new(),
        first_command_us: None,
        errors_m: Vec::new(),
        driven_m: Vec::new(),
        steps: 0,
        replies: Vec::new(),
        garbled: 0,
    }));
    let uart0 = board.uart0.try_clone_native().context("cloning UART0")?;
    let baud = config.baud;
    let wire_stop = Arc::clone(&stop);
    let wire =
        thread::spawn(move || wire::forward(glint_side, uart0, baud, &wire_stop).map(|_| ()));
    let replies = {
        let (port, world, stop) = (board.uart1_reader()?, Arc::clone(&world), Arc::clone(&stop));
        thread::spawn(move || read_replies(port, world, stop))
    };
    let physics = {
        let (world, stop) = (Arc::clone(&world), Arc::clone(&stop));
        thread::spawn(move || run_physics(world, stop))
    };

    let frames = (config.seconds * FPS).round() as usize;
    let mut handed = Vec::with_capacity(frames);
    let mut frame = vec![0u8; camera.frame_len_bytes()];
    let exposure_us = u64::from(EXPOSURE_US);
    let outcome = (|| -> Result<()> {
        for i in 0..frames {
            let end_us = origin_us + ((FIRST_EXPOSURE_S + i as f64 / FPS) * US_PER_S) as u64;
            // Wait for the physics to pass the exposure's end.
            let (start, end, lit) = loop {
                {
                    let w = lock(&world);
                    if w.now_us >= end_us {
                        let start = w.position_at(end_us - exposure_us);
                        let end = w.position_at(end_us);
                        let lit = w.led_at(end_us - exposure_us / 2);
                        break (start.unwrap_or(start_m), end.unwrap_or(start_m), lit);
                    }
                }
                thread::sleep(Duration::from_micros(300));
            };
            camera.render(i, start, end, lit, &mut frame)?;
            let rendered_us = monotonic_now_us();
            stdin
                .write_all(&frame)
                .context("writing a frame to glint")?;
            handed.push(Handed {
                exposure_end_us: end_us,
                rendered_us,
                handed_us: monotonic_now_us(),
            });
        }
        Ok(())
    })();
    // Let the last updates come back, then stop everything.
    thread::sleep(Duration::from_millis(200));
    drop(stdin);
    stop.store(true, Ordering::Relaxed);
    let _ = physics.join();
    let _ = replies.join();
    let exited = wait_with_timeout(&mut glint, GLINT_EXIT_WAIT);
    drop(glint_port);
    let _ = wire.join();
    drop(board);
    outcome?;
    if !exited {
        bail!("glint did not exit after its input ended");
    }
    let w = lock(&world);
    report(&w, &handed)
}

/// Waits for `child` to exit, killing it after `timeout`; whether it exited by itself.
fn wait_with_timeout(child: &mut Child, timeout: Duration) -> bool {
    let deadline = std::time::Instant::now() + timeout;
    while std::time::Instant::now() < deadline {
        if let Ok(Some(_)) = child.try_wait() {
            return true;
        }
        thread::sleep(Duration::from_millis(20));
    }
    let _ = child.kill();
    let _ = child.wait();
    false
}

/// The frame index of a glint frame time.
fn frame_of(timestamp_us: u32) -> usize {
    (f64::from(timestamp_us) * FPS / US_PER_S).round() as usize
}

fn report(w: &World, handed: &[Handed]) -> Result<LoopReport> {
    let mut age_on_arrival_ms = Vec::new();
    let mut age_error_ms = Vec::new();
    let mut found_frames = vec![false; handed.len()];
    for r in &w.replies {
        let Some(h) = handed.get(frame_of(r.command.timestamp_us)) else {
            continue;
        };
        if r.command.steering {
            if let Some(f) = found_frames.get_mut(frame_of(r.command.timestamp_us)) {
                *f = true;
            }
        }
        age_on_arrival_ms.push(r.at_us.saturating_sub(h.exposure_end_us) as f64 * 1e-3);
        if let Some(age_us) = r.command.age_us {
            let truth_us = r.at_us as f64 - h.handed_us as f64;
            age_error_ms.push((f64::from(age_us) - truth_us) * 1e-3);
        }
    }
    let delivery: Vec<f64> = handed
        .iter()
        .map(|h| (h.handed_us - h.exposure_end_us) as f64 * 1e-3)
        .collect();
    let render: Vec<f64> = handed
        .windows(2)
        .map(|p| (p[1].rendered_us - p[1].exposure_end_us.max(p[0].handed_us)) as f64 * 1e-3)
        .collect();
    let errors_mm: Vec<f64> = w.errors_m.iter().map(|e| e * 1e3).collect();
    Ok(LoopReport {
        path_error_mm: Spread::of(&errors_mm)
            .context("the robot never drove: no wheel command came back")?,
        age_on_arrival_ms: Spread::of(&age_on_arrival_ms)
            .context("no wheel command answered a frame")?,
        age_error_ms,
        delivery_ms: Spread::of(&delivery).context("no frame was rendered")?,
        render_ms: Spread::of(&render).context("fewer than two frames")?,
        frames: handed.len(),
        updates: w.replies.len(),
        lost: found_frames.iter().filter(|f| !**f).count(),
        garbled: w.garbled,
        driven_m: w.driven_m.clone(),
    })
}

impl LoopReport {
    /// Whether the loop kept real time: every frame handed to glint within a frame period of
    /// its exposure, and the updates back within 100 ms (p95). A machine too busy for that
    /// measures its own load, not the loop.
    pub fn kept_real_time(&self) -> bool {
        self.delivery_ms.p95 <= 1e3 / FPS && self.age_on_arrival_ms.p95 <= REAL_TIME_AGE_MS
    }

    /// The last line `glint-loop` prints.
    pub fn summary_line(&self) -> String {
        format!(
            "loop: path error p50 {:.1} mm p95 {:.1} mm, age on arrival p50 {:.1} ms p95 {:.1} ms, \
             updates {}, lost {}",
            self.path_error_mm.median,
            self.path_error_mm.p95,
            self.age_on_arrival_ms.median,
            self.age_on_arrival_ms.p95,
            self.updates,
            self.lost
        )
    }

    /// The spread of |firmware's age − truth|, ms.
    pub fn age_disagreement_ms(&self) -> Option<Spread> {
        let abs: Vec<f64> = self.age_error_ms.iter().map(|e| e.abs()).collect();
        Spread::of(&abs)
    }
}

/// Reads a file's last lines, for an error message.
pub fn tail(path: &Path, lines: usize) -> String {
    let Ok(file) = File::open(path) else {
        return String::new();
    };
    let all: Vec<String> = BufReader::new(file).lines().map_while(Result::ok).collect();
    all[all.len().saturating_sub(lines)..].join("\n")
}
