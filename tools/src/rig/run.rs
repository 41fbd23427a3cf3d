//! One run of the whole loop, in real time:
//!
//! ```text
//!  physics (1 kHz) ──states──▶ camera (30 fps, rendered) ──▶ delivery (camera delay)
//!       ▲                                                            │ stamped YUYV
//!       │ wheel commands, LED                                        ▼
//!       │                                              glint run --input - --stamped
//!       │                                                            │ --serial
//!       │                                                            ▼
//!  UART1 pty ◀── firmware in qemu (mps2-an386) ◀── UART0 pty ◀── wire (baud) ◀── pty pair
//! ```
//!
//! Times are on the monotonic clock, the one glint and a camera driver stamp frames with. Like a
//! USB webcam, the rig delivers each frame a configured delay after its exposure ended (sensor
//! readout, USB transfer, driver buffering), stamped with the end of its exposure as a V4L2
//! driver stamps its buffers, so the ages glint sends count the delay. The rig knows when each
//! exposure ended and when the firmware reckoned each position's age (its clock, qemu's virtual
//! clock, runs with the host's monotonic clock), so it can check that age against the truth.

use std::collections::{HashMap, VecDeque};
use std::fs::File;
use std::io::{self, BufRead, BufReader, Read, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Stdio};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{mpsc, Arc, Mutex, MutexGuard};
use std::thread;
use std::time::Duration;

use anyhow::{bail, Context, Result};
use glint::source::clock::monotonic_now_us;
use glint::source::stamped::STAMP_BYTES;
use glint_protocol::{encode, Decoder, Message, Received, MAX_LED_WIRE_LEN};
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
/// Ages on arrival beyond the camera's delay by this (p95) mean the machine could not keep the
/// loop in real time, ms.
const REAL_TIME_AGE_MS: f64 = 100.0;
/// A USB webcam's delivery delay, from the end of the exposure to the frame in the host's hands,
/// is 30 to 100 ms (readout, USB transfer, the driver's buffering); the rig's default.
pub const DEFAULT_CAMERA_DELAY_MS: u32 = 70;
/// Frames rendered and waiting for their delivery, at most (a delay of up to 8 periods).
const FRAMES_IN_FLIGHT: usize = 8;
/// How long the camera waits after an exposure's end before drawing its frame, at most, µs
/// (never more than half the camera's delay, so that the frame is still handed over on time).
/// The firmware's LED lines come through qemu and the pty after the moment they carry (a line
/// alone takes 1–2 ms at 115200 baud, and a frame is drawn 2 ms after its exposure's middle);
/// a frame drawn before its line arrived would show the LED as it had been, and the frames
/// would disagree with the rig's own truth. The wait costs nothing: a frame is handed over
/// only after the camera's delay. Late switches are counted all the same
/// ([`LoopReport::led_switches_late`]).
const LED_SETTLE_US: u64 = 30_000;
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
    /// From the end of each exposure to the frame handed to glint, µs: a camera's delivery
    /// delay (rendering counts in it; a delay shorter than the rendering delivers as soon as it
    /// is rendered).
    pub camera_delay_us: u64,
    /// Seed of the sensor noise.
    pub seed: u64,
    /// Where the calibration and glint's log go.
    pub work_dir: PathBuf,
    /// Run `glint latency` with this many requests instead of `glint run`: it asks the firmware
    /// to switch the LED off, the firmware tells the simulator, and the renderer draws it dark.
    pub latency_trials: Option<u32>,
}

/// How long the firmware keeps its LED off per request of `glint latency` on the rig, ms: a few
/// frames, so that a run of 20 requests takes about 8 s.
const LATENCY_OFF_MS: u32 = 100;

/// What a run measured.
#[derive(Debug, Clone)]
pub struct LoopReport {
    /// Distance from the robot to the planned path, every physics step after the start, mm.
    pub path_error_mm: Spread,
    /// From the end of an exposure to its wheel command coming back (the position's age when
    /// the firmware acted on it, truth), ms.
    pub age_on_arrival_ms: Spread,
    /// The firmware's age minus the truth (from the end of the exposure to the moment the
    /// firmware reckoned the age), ms (signed).
    pub age_error_ms: Vec<f64>,
    /// Of each age's shortfall: the part before the board (the wire handing the last byte on
    /// later than glint's age said: the wire's thread scheduled late), and the rest (qemu
    /// delivering it, the firmware reading it), ms, for the updates the wire saw.
    pub short_before_board_ms: Vec<f64>,
    pub short_after_wire_ms: Vec<f64>,
    /// How late the firmware read each age frame after the wire handed its last byte on
    /// (qemu delivering it, the emulated core scheduled late), ms, for the updates the wire saw.
    pub board_read_late_ms: Vec<f64>,
    /// The firmware's age minus the truth, from the moment its link read the age frame on
    /// (`age_error_ms` with `board_read_late_ms` taken out): what the firmware itself
    /// reckons, without an emulator's lateness that no real UART has, ms (signed).
    pub age_error_from_receipt_ms: Vec<f64>,
    /// From the end of an exposure to the frame handed to glint (the camera's delay, or the
    /// rendering when it takes longer), ms.
    pub delivery_ms: Spread,
    /// How late frames were handed to glint after their due time (exposure end + delay), ms.
    pub late_ms: Spread,
    /// The camera's delay configured, ms.
    pub camera_delay_ms: f64,
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
    /// Per LED request of `glint latency`: from glint writing it (and the delay it asked for)
    /// to the simulator's LED going dark (the line time, the firmware's reaction, the way back
    /// to the simulator), truth, ms.
    pub led_dark_after_request_ms: Vec<f64>,
    /// LED switches whose line arrived after the camera had drawn a frame that should have
    /// shown them (the firmware's line later than the rig's settling time): while there are
    /// any, the frames disagree with `led_dark_after_request_ms`.
    pub led_switches_late: usize,
    /// What `glint latency` printed.
    pub glint_stdout: String,
}

/// A wheel command as it came back.
#[derive(Debug, Clone, Copy)]
struct Reply {
    command: lines::Command,
    /// When its line's first bytes arrived, monotonic µs.
    at_us: u64,
    /// When its line's last byte arrived: the firmware read its clock before writing that.
    end_us: u64,
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
    /// When glint wrote each LED request (monotonic µs), from the wire, and the delay it asked
    /// for.
    led_requests_us: Vec<u64>,
    /// When the simulator's LED went dark.
    led_dark_us: Vec<u64>,
    /// The middle of the last exposure whose LED the camera drew, monotonic µs.
    led_drawn_until_us: u64,
    /// LED switches that arrived after a frame that should have shown them was drawn.
    led_switches_late: usize,
    /// The firmware's clock on the monotonic clock so far (see [`firmware_clock_offset_us`]).
    clock_offset_us: Option<i64>,
    /// Per position update, by its frame time: how much later than glint's age said the wire
    /// handed its age frame's last byte to the board, µs.
    wire_late_us: HashMap<u32, WireSeen>,
}

/// When the wire handed an age frame's last byte on, by the frame time of its position.
#[derive(Debug, Clone, Copy)]
struct WireSeen {
    /// Against the moment glint's age said, µs (positive: later).
    late_us: i64,
    /// On the monotonic clock, µs.
    due_us: u64,
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

    /// Switches the LED at `at_us`: the steps already taken from then on are put right, later
    /// ones follow.
    fn switch_led(&mut self, at_us: u64, on: bool) {
        for (t, lit) in self.led_history.iter_mut().rev() {
            if *t < at_us {
                break;
            }
            *lit = on;
        }
        self.led_events.push_back((at_us, on));
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

/// Starts `glint run` (or `glint latency`) on standard input with its serial port on `port`.
fn start_glint(config: &LoopConfig, calib: &Path, port: &str) -> Result<Child> {
    let create = |name: &str| {
        let path = config.work_dir.join(name);
        File::create(&path).with_context(|| format!("cannot create {}", path.display()))
    };
    let mut cmd = Command::new(&config.glint);
    match config.latency_trials {
        None => cmd.arg("run").stdout(Stdio::null()),
        Some(trials) => cmd
            .arg("latency")
            .args(["--trials", &trials.to_string()])
            .args(["--off-ms", &LATENCY_OFF_MS.to_string()])
            .args(["--seed", &config.seed.to_string()])
            .args(["--exposure-us", &EXPOSURE_US.to_string()])
            .stdout(create(GLINT_STDOUT)?),
    };
    cmd.args(["--input", "-", "--stamped"])
        .args(["--size", &format!("{WIDTH_PX}x{HEIGHT_PX}")])
        .args(["--fps", &FPS.to_string()])
        .arg("--calib")
        .arg(calib)
        .args(["--serial", port, "--baud", &config.baud.to_string()])
        .stdin(Stdio::piped())
        .stderr(create("glint.log")?)
        .spawn()
        .with_context(|| format!("cannot start {}", config.glint.display()))
}

/// Where glint's standard output goes, in the work directory.
const GLINT_STDOUT: &str = "glint.out";

/// What glint writes, as the wire reads it: when glint wrote each LED request (it carries the
/// frame time its last byte leaves, `at_us`, from which its line time is taken back), and how
/// much later than glint's age said the wire hands each age frame's last byte to the board
/// (the wire's own schedule, followed byte by byte as [`wire::forward`] keeps it).
struct WireTap {
    decoder: Decoder,
    /// Frame time 0 on the monotonic clock: the first exposure's end.
    frame_origin_us: u64,
    byte_ns: u64,
    /// When the wire's line is next free, ns.
    free_ns: u64,
    /// The frame time of the last position update.
    position_us: Option<u32>,
    world: Arc<Mutex<World>>,
}

impl WireTap {
    fn take(&mut self, chunk: &[u8], read_us: u64) {
        self.free_ns = self.free_ns.max(read_us * 1_000);
        for &byte in chunk {
            self.free_ns += self.byte_ns;
            let due_us = self.free_ns / 1_000;
            // Byte by byte, so that each frame ends at its own byte's time.
            let events: Vec<_> = self.decoder.feed(&[byte]).collect();
            for event in events {
                match event {
                    Ok(Received::Message(Message::Position(p))) => {
                        self.position_us = Some(p.timestamp_us);
                    }
                    Ok(Received::Message(Message::Age(a))) => {
                        let Some(t) = self.position_us.take() else {
                            continue;
                        };
                        let said_us = self.frame_origin_us + u64::from(t) + u64::from(a.age_us);
                        lock(&self.world).wire_late_us.insert(
                            t,
                            WireSeen {
                                late_us: due_us as i64 - said_us as i64,
                                due_us,
                            },
                        );
                    }
                    Ok(Received::Message(message @ Message::Led(_))) => self.request(&message),
                    _ => {}
                }
            }
        }
    }

    fn request(&mut self, message: &Message) {
        {
            let Message::Led(request) = *message else {
                return;
            };
            let mut out = [0u8; MAX_LED_WIRE_LEN];
            let len = encode(message, &mut out).map_or(MAX_LED_WIRE_LEN, <[u8]>::len);
            let line_us = len as u64 * self.byte_ns / 1_000;
            let leaves_us = self.frame_origin_us + u64::from(request.at_us);
            // The delay glint asks for is no latency: the moment asked for is the request's.
            let asked_us = leaves_us.saturating_sub(line_us) + u64::from(request.delay_us);
            lock(&self.world).led_requests_us.push(asked_us);
        }
    }
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
                    let offset = at_us as i64 - i64::from(command.clock_us);
                    w.clock_offset_us = Some(w.clock_offset_us.map_or(offset, |o| o.min(offset)));
                    let speeds = WheelSpeeds {
                        left_m_s: f64::from(command.left_mm_s) * 1e-3,
                        right_m_s: f64::from(command.right_mm_s) * 1e-3,
                    };
                    w.commands.push_back((line_at, speeds));
                    w.replies.push(Reply {
                        command,
                        at_us: line_at,
                        end_us: at_us,
                    });
                }
                Some(Line::Led { on, clock_us }) => {
                    // The LED switched when the firmware's clock said, not when its line was
                    // read here: the history is put right from then on.
                    let at = w
                        .clock_offset_us
                        .map_or(line_at, |o| (i64::from(clock_us) + o).max(0) as u64)
                        .min(line_at);
                    if at <= w.led_drawn_until_us {
                        w.led_switches_late += 1;
                    }
                    w.switch_led(at, on);
                    if !on {
                        w.led_dark_us.push(at);
                    }
                }
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

/// A rendered frame on its way to glint: the stamp (its exposure's end) then the pixels.
struct InFlight {
    exposure_end_us: u64,
    rendered_us: u64,
    stamped: Vec<u8>,
}

/// Sleeps until the monotonic clock reads `t_us` (a sleep overshoots by tens of µs, which the
/// delivery's figures show).
fn sleep_until_us(t_us: u64) {
    let now = monotonic_now_us();
    if t_us > now {
        thread::sleep(Duration::from_micros(t_us - now));
    }
}

/// Hands each rendered frame to glint `delay_us` after its exposure ended, as a camera's
/// driver hands it over after readout and transfer, and sends the buffer back for the next.
fn deliver(
    mut stdin: impl Write,
    frames: mpsc::Receiver<InFlight>,
    spent: mpsc::SyncSender<Vec<u8>>,
    delay_us: u64,
) -> Result<Vec<Handed>> {
    let mut handed = Vec::new();
    for f in frames {
        sleep_until_us(f.exposure_end_us + delay_us);
        match stdin.write_all(&f.stamped) {
            Ok(()) => {}
            // glint latency stops reading when its requests are done.
            Err(e) if e.kind() == io::ErrorKind::BrokenPipe => break,
            Err(e) => return Err(e).context("writing a frame to glint"),
        }
        handed.push(Handed {
            exposure_end_us: f.exposure_end_us,
            rendered_us: f.rendered_us,
            handed_us: monotonic_now_us(),
        });
        let _ = spent.send(f.stamped);
    }
    Ok(handed)
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
    let stdin = glint.stdin.take().context("glint's standard input")?;

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
        led_requests_us: Vec::new(),
        led_dark_us: Vec::new(),
        led_drawn_until_us: 0,
        led_switches_late: 0,
        clock_offset_us: None,
        wire_late_us: HashMap::new(),
    }));
    let uart0 = board.uart0.try_clone_native().context("cloning UART0")?;
    let baud = config.baud;
    let wire_stop = Arc::clone(&stop);
    let mut tap = WireTap {
        decoder: Decoder::new(),
        frame_origin_us: origin_us + (FIRST_EXPOSURE_S * US_PER_S) as u64,
        byte_ns: wire::byte_time_ns(baud),
        free_ns: 0,
        position_us: None,
        world: Arc::clone(&world),
    };
    let wire = thread::spawn(move || {
        wire::forward(glint_side, uart0, baud, &wire_stop, |chunk, at_us| {
            tap.take(chunk, at_us)
        })
        .map(|_| ())
    });
    let replies = {
        let (port, world, stop) = (board.uart1_reader()?, Arc::clone(&world), Arc::clone(&stop));
        thread::spawn(move || read_replies(port, world, stop))
    };
    let physics = {
        let (world, stop) = (Arc::clone(&world), Arc::clone(&stop));
        thread::spawn(move || run_physics(world, stop))
    };

    let frames = (config.seconds * FPS).round() as usize;
    let (to_glint, in_flight) = mpsc::sync_channel::<InFlight>(FRAMES_IN_FLIGHT);
    let (spent_tx, spent) = mpsc::sync_channel::<Vec<u8>>(FRAMES_IN_FLIGHT);
    let delivery = {
        let delay_us = config.camera_delay_us;
        thread::spawn(move || deliver(stdin, in_flight, spent_tx, delay_us))
    };
    let stamped_len = STAMP_BYTES + camera.frame_len_bytes();
    let exposure_us = u64::from(EXPOSURE_US);
    let settle_us = LED_SETTLE_US.min(config.camera_delay_us / 2);
    let outcome = (|| -> Result<()> {
        for i in 0..frames {
            let end_us = origin_us + ((FIRST_EXPOSURE_S + i as f64 / FPS) * US_PER_S) as u64;
            // Wait for the physics to pass the exposure's end, and the LED's lines to settle.
            let (start, end, lit) = loop {
                {
                    let mut w = lock(&world);
                    if w.now_us >= end_us + settle_us {
                        let start = w.position_at(end_us - exposure_us);
                        let end = w.position_at(end_us);
                        let middle_us = end_us - exposure_us / 2;
                        let lit = w.led_at(middle_us);
                        w.led_drawn_until_us = middle_us;
                        break (start.unwrap_or(start_m), end.unwrap_or(start_m), lit);
                    }
                }
                thread::sleep(Duration::from_micros(300));
            };
            let mut stamped = match spent.try_recv() {
                Ok(buffer) => buffer,
                Err(_) => vec![0u8; stamped_len],
            };
            let (stamp, pixels) = stamped.split_at_mut(STAMP_BYTES);
            stamp.copy_from_slice(&end_us.to_le_bytes());
            camera.render(i, start, end, lit, pixels)?;
            let frame = InFlight {
                exposure_end_us: end_us,
                rendered_us: monotonic_now_us(),
                stamped,
            };
            if to_glint.send(frame).is_err() {
                break; // the delivery stopped: its error says why
            }
        }
        Ok(())
    })();
    drop(to_glint);
    let delivered = delivery
        .join()
        .unwrap_or_else(|_| Err(anyhow::anyhow!("the delivery thread panicked")));
    // Let the last updates come back, then stop everything.
    thread::sleep(Duration::from_millis(200));
    stop.store(true, Ordering::Relaxed);
    let _ = physics.join();
    let _ = replies.join();
    let exited = wait_with_timeout(&mut glint, GLINT_EXIT_WAIT);
    drop(glint_port);
    let _ = wire.join();
    drop(board);
    outcome?;
    let handed = delivered?;
    if !exited {
        bail!("glint did not exit after its input ended");
    }
    let w = lock(&world);
    let mut report = report(&w, &handed, config.camera_delay_us)?;
    if config.latency_trials.is_some() {
        let out = config.work_dir.join(GLINT_STDOUT);
        report.glint_stdout = std::fs::read_to_string(&out)
            .with_context(|| format!("cannot read {}", out.display()))?;
    }
    Ok(report)
}

/// Per LED request, from its writing to the first darkening of the LED after it, ms.
fn led_dark_after_request_ms(w: &World) -> Vec<f64> {
    w.led_requests_us
        .iter()
        .filter_map(|&asked| {
            let dark = w.led_dark_us.iter().find(|&&d| d >= asked)?;
            Some((dark - asked) as f64 * 1e-3)
        })
        .collect()
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

/// The firmware's clock on the host's monotonic clock, µs: qemu's virtual clock runs with the
/// host's monotonic clock from an offset of its own. The firmware reads its clock before it
/// writes the last part of a line, so each line ends on the host some time after the reading
/// it carries, and the offset is the least difference (that of the line that came back
/// fastest). The line's start would not do: the firmware may be held up between its first
/// bytes and the clock reading.
fn firmware_clock_offset_us(replies: &[Reply]) -> Option<i64> {
    replies
        .iter()
        .map(|r| r.end_us as i64 - i64::from(r.command.clock_us))
        .min()
}

fn report(w: &World, handed: &[Handed], camera_delay_us: u64) -> Result<LoopReport> {
    let mut age_on_arrival_ms = Vec::new();
    let mut age_error_ms = Vec::new();
    let (mut short_before_board_ms, mut short_after_wire_ms) = (Vec::new(), Vec::new());
    let (mut board_read_late_ms, mut age_error_from_receipt_ms) = (Vec::new(), Vec::new());
    let mut found_frames = vec![false; handed.len()];
    let offset_us = firmware_clock_offset_us(&w.replies).unwrap_or(0);
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
            let reckoned_us = i64::from(r.command.clock_us) + offset_us;
            let truth_us = reckoned_us - h.exposure_end_us as i64;
            let error_us = i64::from(age_us) - truth_us;
            age_error_ms.push(error_us as f64 * 1e-3);
            if let Some(seen) = w.wire_late_us.get(&r.command.timestamp_us) {
                short_before_board_ms.push(seen.late_us as f64 * 1e-3);
                short_after_wire_ms.push((-error_us - seen.late_us) as f64 * 1e-3);
                if let Some(received_us) = r.command.received_us {
                    let read_us =
                        reckoned_us - i64::from(r.command.clock_us.wrapping_sub(received_us));
                    let read_late_us = read_us - seen.due_us as i64;
                    board_read_late_ms.push(read_late_us as f64 * 1e-3);
                    age_error_from_receipt_ms.push((error_us + read_late_us) as f64 * 1e-3);
                }
            }
        }
    }
    let delivery: Vec<f64> = handed
        .iter()
        .map(|h| (h.handed_us - h.exposure_end_us) as f64 * 1e-3)
        .collect();
    let late: Vec<f64> = handed
        .iter()
        .map(|h| {
            h.handed_us
                .saturating_sub(h.exposure_end_us + camera_delay_us) as f64
                * 1e-3
        })
        .collect();
    let render: Vec<f64> = handed
        .windows(2)
        .map(|p| (p[1].rendered_us - p[1].exposure_end_us.max(p[0].rendered_us)) as f64 * 1e-3)
        .collect();
    let errors_mm: Vec<f64> = w.errors_m.iter().map(|e| e * 1e3).collect();
    Ok(LoopReport {
        path_error_mm: Spread::of(&errors_mm)
            .context("the robot never drove: no wheel command came back")?,
        age_on_arrival_ms: Spread::of(&age_on_arrival_ms)
            .context("no wheel command answered a frame")?,
        age_error_ms,
        short_before_board_ms,
        short_after_wire_ms,
        board_read_late_ms,
        age_error_from_receipt_ms,
        delivery_ms: Spread::of(&delivery).context("no frame was rendered")?,
        late_ms: Spread::of(&late).context("no frame was rendered")?,
        camera_delay_ms: camera_delay_us as f64 * 1e-3,
        render_ms: Spread::of(&render).context("fewer than two frames")?,
        frames: handed.len(),
        updates: w.replies.len(),
        lost: found_frames.iter().filter(|f| !**f).count(),
        garbled: w.garbled,
        driven_m: w.driven_m.clone(),
        led_dark_after_request_ms: led_dark_after_request_ms(w),
        led_switches_late: w.led_switches_late,
        glint_stdout: String::new(),
    })
}

impl LoopReport {
    /// Whether the loop kept real time: every frame handed to glint within a frame period of
    /// its due time (the exposure's end and the camera's delay), and the updates back within
    /// 100 ms of that (p95). A machine too busy for that measures its own load, not the loop.
    pub fn kept_real_time(&self) -> bool {
        self.late_ms.p95 <= 1e3 / FPS
            && self.age_on_arrival_ms.p95 <= self.camera_delay_ms + REAL_TIME_AGE_MS
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
