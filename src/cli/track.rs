//! `glint track`: run the pipeline on a raw YUYV dump or a camera and print one report per frame.

use std::io::{self, BufWriter};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::atomic::AtomicBool;
use std::sync::Arc;

use anyhow::{bail, Context, Result};
use clap::{Args, ValueEnum};

use super::serial_ports::{self, SerialArg, SerialPlan};
use super::{calib_args, input, memory, publish, signals};

use glint::budget::{self, MemoryPlan};
use glint::detect::bgdiff::MAX_BACKGROUND_FRAMES;
use glint::detect::MaskMethod;
use glint::frame::FrameSize;
use glint::geometry::CalibrationFile;
use glint::identify::IdentifyConfig;
use glint::monitor::{self, Monitor};
use glint::options::{parse_fps, parse_row_time_us, LedArgs, StreakModelArg};
use glint::pipeline::{self, Pipeline, PipelineConfig, RunSummary};
use glint::sink::mavlink::{self, Identity, ToLocal};
use glint::sink::serial::RobotLines;
use glint::sink::{serial, CsvSink, JsonLinesSink, MavlinkSink, SerialSink, Tee};
use glint::small_file;
use glint::source::dump::DumpSource;
use glint::source::interruptible::Interruptible;
use glint::source::stoppable::Stoppable;
use glint::source::FrameSource;
use glint::track::shutter::RollingShutter;
use glint::track::{RobotsOutOfRange, TrackerConfig, MAX_ROBOTS};

/// Output buffer size: a few hundred report lines.
const OUTPUT_BUFFER_BYTES: usize = 64 * 1024;

#[derive(Debug, Args)]
pub struct TrackArgs {
    #[command(flatten)]
    pub settings: TrackSettings,

    /// Output format.
    #[arg(long, value_enum, default_value_t = Format::Jsonl)]
    format: Format,
}

/// The options `glint track` shares with `glint run` (whose configuration file has the same
/// keys): input, detection, tracking, floor and serial link.
#[derive(Debug, Args)]
pub struct TrackSettings {
    #[command(flatten)]
    pub input: input::InputArgs,

    /// Frame size in pixels: sides 1 to 16384, the width even. What the options need for
    /// frames of this size must fit in --max-memory-mb.
    #[arg(long, value_name = "WxH")]
    pub size: FrameSize,

    /// Frame rate, 0.1 to 1000: of a dump without a sidecar, for timestamps (default 30); of
    /// a camera, to ask for (default: its current one).
    #[arg(long, value_parser = parse_fps, allow_negative_numbers = true)]
    fps: Option<f64>,

    /// The camera's rolling shutter: the time from one row's exposure to the next, µs (the
    /// sensor's line time, or its frame readout time over its rows), up to 1000; `glint
    /// row-time` measures it from a flickering lamp's bands. Velocities are then read as the
    /// LED's, not as the skewed rows show them (6.7 % fast for an LED moving down at 1000 px/s
    /// with 62.5 µs rows). Without it, a global shutter.
    #[arg(long, value_name = "MICROSECONDS", value_parser = parse_row_time_us,
          allow_negative_numbers = true)]
    row_time_us: Option<f32>,

    #[command(flatten)]
    led: LedArgs,

    /// What finds the robot: saturated pixels, pixels that differ from a background, or an
    /// ArUco marker it carries (`aruco`, with `--marker ID`).
    #[arg(long, value_enum, default_value_t = DetectorArg::Saturation)]
    detector: DetectorArg,

    /// With `--detector bgdiff`: learn the background from the first N frames (their
    /// per-pixel median), which are then reported as not found; 1 to 63, each one frame of
    /// luma in memory.
    #[arg(long, default_value_t = 9, value_name = "N", allow_negative_numbers = true,
          value_parser = clap::value_parser!(u16).range(1..=MAX_BACKGROUND_FRAMES as i64))]
    background_frames: u16,

    /// With `--detector bgdiff`: learn the background from a separate raw dump of the empty
    /// scene instead (its first `--background-frames` frames, at least one).
    #[arg(long, value_name = "PATH")]
    pub background: Option<PathBuf>,

    /// With `--detector bgdiff`: the luma difference from the background that counts, 1 to
    /// 255.
    #[arg(long, default_value_t = 60, value_name = "LUMA", allow_negative_numbers = true,
          value_parser = clap::value_parser!(u8).range(1..))]
    diff: u8,

    /// Follow up to N LEDs, one per robot, 1 to 16: each frame's report then holds one track
    /// per robot (`tracks` in JSON lines, one CSV row per robot and frame). With --serial, each
    /// robot is identified by switching its LED off when asked (`id_source` blink), and no
    /// update goes out under a robot's id before that; without, ids come from continuity.
    #[arg(long, default_value_t = 1, value_name = "N", allow_negative_numbers = true,
          value_parser = parse_robots)]
    pub robots: usize,

    #[command(flatten)]
    pub floor: calib_args::FloorArgs,

    /// Also send position packets to the robots (board/protocol/SPEC.md): `PORT`, one line
    /// every robot listens on (a UART, or a radio bridge to all of them), or `ID=PORT` for robot
    /// ID's own line (repeat it per robot; ids 1 to 16, each once).
    #[arg(long, value_name = "PORT|ID=PORT", overrides_with = "no_serial",
          action = clap::ArgAction::Append, value_parser = serial_ports::parse_serial)]
    pub serial: Vec<SerialArg>,

    /// No serial link, whatever a --serial before it (or the settings file's `serial`) says:
    /// try a Pi's settings on a dump without its UART.
    #[arg(long, overrides_with = "serial")]
    no_serial: bool,

    /// `arrival`: send positions extrapolated to the moment each update reaches the robot (and
    /// print them, as `predicted`, in JSON lines): velocity from the streak, bend from the turn
    /// of the velocity between frames. Flagged as predicted in the update's age frame.
    #[arg(long, value_enum, default_value_t = Predict::None)]
    pub predict: Predict,

    /// Line rate of --serial, 8N1: 50 to 4000000 baud.
    #[arg(long, default_value_t = serial::DEFAULT_BAUD, allow_negative_numbers = true,
          value_parser = clap::value_parser!(u32).range(50..=4_000_000))]
    pub baud: u32,

    /// Send MAVLink 2 to an autopilot on --serial instead of glint's packets:
    /// VISION_POSITION_ESTIMATE (and VISION_SPEED_ESTIMATE) in metres, north = floor +x turned
    /// by --mavlink-yaw-offset-deg, and a HEARTBEAT every second. Needs --calib.
    #[arg(long, requires = "serial")]
    pub mavlink: bool,

    /// With --mavlink: the compass bearing of floor +x, in degrees clockwise from north.
    #[arg(long, default_value_t = 0.0, value_name = "DEG", allow_negative_numbers = true,
          value_parser = parse_yaw_offset_deg)]
    mavlink_yaw_offset_deg: f64,

    /// With --mavlink: the vehicle's MAVLink system id (ArduPilot's SYSID_THISMAV).
    #[arg(long, default_value_t = mavlink::DEFAULT_SYSTEM_ID, value_name = "ID",
          value_parser = clap::value_parser!(u8).range(1..))]
    mavlink_system_id: u8,

    #[command(flatten)]
    pub memory: memory::MemoryArgs,

    #[command(flatten)]
    pub publish: publish::PublishArgs,
}

/// What positions go out: as measured, or extrapolated to their arrival.
#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
pub enum Predict {
    /// As measured at the end of the exposure.
    None,
    /// Moved on to the moment the update reaches its reader.
    Arrival,
}

/// The frame rate identification starts from without `--fps` (a camera's usual rate), until it
/// has measured the period from the frames' timestamps.
const DEFAULT_IDENTIFY_FPS: f64 = 30.0;

/// The serial link: glint's own packets (one line, or one per robot), or MAVLink with
/// `--mavlink` (never both).
pub type SerialLink = Tee<Tee<Option<SerialSink>, Option<RobotLines>>, Option<MavlinkSink>>;

/// A number of robots the tracker's tables hold.
pub(super) fn parse_robots(text: &str) -> Result<usize, String> {
    let robots = text
        .parse::<usize>()
        .map_err(|_| format!("{text:?} is not a number of robots (1 to {MAX_ROBOTS})"))?;
    if robots == 0 || robots > MAX_ROBOTS {
        return Err(RobotsOutOfRange(robots).to_string());
    }
    Ok(robots)
}

/// A finite bearing within ±360°.
pub(super) fn parse_yaw_offset_deg(text: &str) -> Result<f64, String> {
    match text.parse::<f64>() {
        Ok(deg) if deg.is_finite() && deg.abs() <= 360.0 => Ok(deg),
        _ => Err(format!(
            "{text:?} is not a bearing in degrees from -360 to 360"
        )),
    }
}

#[derive(Debug, Clone, Copy, ValueEnum)]
enum Format {
    Jsonl,
    Csv,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq, ValueEnum)]
enum DetectorArg {
    /// Saturated pixels (the default).
    Saturation,
    /// Background difference.
    Bgdiff,
    /// An ArUco / AprilTag marker carried by the robot (with `--marker ID`).
    Aruco,
}

impl TrackSettings {
    /// What these settings will allocate, by the options that ask for it.
    pub fn memory_plan(&self) -> MemoryPlan {
        let size = self.size;
        let mut plan = MemoryPlan::new();
        match self.input.camera_buffers() {
            Some(buffers) => plan.add(
                "the camera's buffers",
                format!("--buffers {buffers} × --size {size}"),
                u64::from(buffers).saturating_mul(budget::frame_bytes(size)),
            ),
            None => plan.add(
                "the frame buffer",
                format!("--size {size}"),
                budget::frame_bytes(size),
            ),
        }
        match self.detector {
            DetectorArg::Aruco => plan.add(
                "the marker detector",
                format!("--detector aruco, --size {size}"),
                budget::marker_detector_bytes(size, self.floor.max_perimeter_px())
                    + glint::geometry::recheck::MarkerRecheck::copy_bytes(size) as u64,
            ),
            DetectorArg::Saturation | DetectorArg::Bgdiff => plan.add(
                "the masks and scratch",
                format!("--size {size}"),
                budget::led_detector_bytes(size),
            ),
        }
        // The default model learns the floor too, so the refusal says how to run without it.
        let fit_floor_model = match self.led.streak_model {
            StreakModelArg::Ramps => None,
            StreakModelArg::Fit => Some("fit"),
            StreakModelArg::Auto => Some("auto, the default"),
        };
        if let (true, Some(model)) = (self.detector != DetectorArg::Aruco, fit_floor_model) {
            plan.add(
                "the streak fit's learned floor",
                format!("--size {size} with --streak-model {model}; --streak-model ramps has none"),
                budget::fit_floor_bytes(size),
            );
        }
        // A calibration with a marker map re-detects its markers while tracking; whether the
        // file holds a map is known only once it is read, so the plan assumes it does.
        if self.floor.calib.is_some() && !self.floor.no_recheck {
            plan.add(
                "the marker re-check",
                format!("--calib without --no-recheck, --size {size}"),
                budget::marker_detector_bytes(size, self.floor.max_perimeter_px())
                    + glint::geometry::recheck::MarkerRecheck::copy_bytes(size) as u64,
            );
        }
        if self.detector == DetectorArg::Bgdiff {
            plan.add(
                "the background model",
                format!(
                    "--background-frames {} × --size {size}",
                    self.background_frames
                ),
                budget::background_bytes(size, usize::from(self.background_frames)),
            );
        }
        publish::plan(&self.publish, &mut plan);
        plan
    }

    fn pipeline_config(&self) -> PipelineConfig {
        PipelineConfig {
            detector: self.led.detector_config(match self.detector {
                DetectorArg::Saturation | DetectorArg::Aruco => MaskMethod::Saturation,
                DetectorArg::Bgdiff => MaskMethod::BackgroundDifference {
                    diff_luma: self.diff,
                    frames: usize::from(self.background_frames),
                },
            }),
            tracker: TrackerConfig {
                exposure_us: self.input.exposure_us(),
            },
        }
    }
}

/// A run's parts, opened and checked: everything but the text output.
pub struct Opened {
    /// The input, ending cleanly on Ctrl-C or SIGTERM whatever it is waiting for.
    pub source: Stoppable<input::InputSource>,
    /// Reports are flushed one by one (a pipe or a camera), not in blocks.
    pub live: bool,
    pub monitor: Monitor,
    pub pipeline: Pipeline,
    pub serial: SerialLink,
    /// `--publish`: reports to the network.
    pub publish: Option<publish::PublishSink>,
}

/// Checks that `plan` (these settings' memory, and whatever the caller adds) fits the limit,
/// then opens the input, builds the pipeline (learning a separate background when asked) and
/// opens the serial link and starts publishing, in that order; from then on Ctrl-C and SIGTERM
/// stop the run cleanly.
pub fn open(settings: &TrackSettings, plan: &MemoryPlan) -> Result<Opened> {
    settings.memory.check(plan)?;
    // A bad combination of --serial values is refused before anything is opened.
    settings.serial_plan()?;
    let stop = Arc::new(AtomicBool::new(false));
    signals::stop_on_signals(&stop)?;
    let input::Input {
        source,
        live,
        monitor,
    } = input::open(&settings.input, settings.size, settings.fps, &stop)?;
    let aruco = settings.detector == DetectorArg::Aruco;
    let mut pipeline = calib_args::build_pipeline(
        &settings.floor,
        settings.size,
        aruco,
        settings.robots,
        settings.pipeline_config(),
    )?;
    if let Some(shutter) = settings.row_time_us.and_then(RollingShutter::new) {
        pipeline = pipeline.with_rolling_shutter(shutter);
    }
    if let Some(path) = &settings.background {
        if settings.detector != DetectorArg::Bgdiff {
            bail!("--background goes with --detector bgdiff");
        }
        learn_background(&mut pipeline, path, settings, &stop)?;
    }
    if settings.robots > 1 && settings.serial_plan()? != SerialPlan::None {
        // A link to the robots: identify them by their LEDs. Without one, continuity only.
        let fps = settings.fps.unwrap_or(DEFAULT_IDENTIFY_FPS);
        let frame_period_us = (1e6 / fps).round() as u64;
        let robots = u8::try_from(settings.robots).context("--robots")?;
        let mut identify = IdentifyConfig::new(robots, frame_period_us);
        if let SerialPlan::PerRobot(ports) = settings.serial_plan()? {
            // Only the robots with a line can be asked.
            identify.linked = ports
                .keys()
                .filter_map(|&id| 1u32.checked_shl(u32::from(id).saturating_sub(1)))
                .fold(0, |mask, bit| mask | bit);
        }
        pipeline = pipeline
            .with_identify(identify)
            .context("identifying the robots")?;
    }
    let serial = open_serial(settings, &pipeline)?;
    let publish = publish::open(&settings.publish)?;
    Ok(Opened {
        source: Stoppable::new(source, stop),
        live,
        monitor,
        pipeline,
        serial,
        publish,
    })
}

/// Opens `--serial` with glint's packets, or with MAVLink under `--mavlink`. With several
/// robots: one line shared by all (robot positions), or a line per robot.
fn open_serial(settings: &TrackSettings, pipeline: &Pipeline) -> Result<SerialLink> {
    let several = settings.robots > 1;
    let port = match settings.serial_plan()? {
        SerialPlan::None => return Ok(Tee::new(Tee::new(None, None), None)),
        SerialPlan::PerRobot(ports) => {
            if settings.mavlink {
                bail!("--mavlink talks to one autopilot: give one --serial PORT, not ID=PORT");
            }
            if let Some(robot) = ports.keys().find(|&&k| usize::from(k) > settings.robots) {
                bail!(
                    "--serial {robot}={}: glint follows {} robot(s) (--robots), ids 1 to {}",
                    ports.get(robot).map_or("", String::as_str),
                    settings.robots,
                    settings.robots
                );
            }
            if several && settings.predict == Predict::Arrival {
                bail!("--predict arrival follows one robot: leave it out with --robots");
            }
            let ports: Vec<(u8, String)> = ports.into_iter().collect();
            let lines = RobotLines::open(&ports, settings.baud)?;
            return Ok(Tee::new(Tee::new(None, Some(lines)), None));
        }
        SerialPlan::Shared(port) => port,
    };
    let port = port.as_str();
    if several {
        if settings.mavlink {
            bail!("--mavlink talks to one autopilot: leave it out with --robots");
        }
        if settings.predict == Predict::Arrival {
            bail!("--predict arrival follows one robot: leave it out with --robots");
        }
        let sink = SerialSink::open(port, settings.baud)?;
        return Ok(Tee::new(Tee::new(Some(sink), None), None));
    }
    if !settings.mavlink {
        let sink = SerialSink::open(port, settings.baud)?;
        let sink = match settings.predict {
            Predict::Arrival => sink.predicting(),
            Predict::None => sink,
        };
        return Ok(Tee::new(Tee::new(Some(sink), None), None));
    }
    let (Some(path), Some(floor)) = (settings.floor.calib.as_deref(), pipeline.floor()) else {
        bail!("--mavlink needs --calib: an autopilot takes positions in metres on the floor");
    };
    // Read again for its residual (the pipeline keeps only the mapping); checked already.
    let calibration = small_file::read_text(path, small_file::MAX_SETTINGS_BYTES)
        .map_err(anyhow::Error::from)
        .and_then(|text| Ok(CalibrationFile::parse(&text, settings.size)?))
        .with_context(|| format!("calibration {}", path.display()))?;
    let local = ToLocal::new(
        *floor,
        settings.mavlink_yaw_offset_deg,
        calibration.max_residual_px,
    );
    let identity = Identity {
        system_id: settings.mavlink_system_id,
        component_id: mavlink::VISION_COMPONENT_ID,
    };
    let sink = MavlinkSink::open(port, settings.baud, identity, local)?;
    Ok(Tee::new(Tee::new(None, None), Some(sink)))
}

impl TrackSettings {
    /// The `--serial` values, checked together.
    pub fn serial_plan(&self) -> Result<SerialPlan> {
        serial_ports::plan(&self.serial).map_err(anyhow::Error::msg)
    }
}

pub fn run(args: TrackArgs) -> Result<ExitCode> {
    let Opened {
        mut source,
        live,
        mut monitor,
        mut pipeline,
        serial,
        publish,
    } = open(&args.settings, &args.settings.memory_plan())?;
    let stdout = BufWriter::with_capacity(OUTPUT_BUFFER_BYTES, io::stdout().lock());
    let links = Tee::new(serial, publish);
    let (summary, result) = match args.format {
        Format::Jsonl => monitor::run(
            &mut source,
            &mut pipeline,
            &mut Tee::new(jsonl_sink(stdout, live, &args.settings), links),
            &mut monitor,
        ),
        Format::Csv => monitor::run(
            &mut source,
            &mut pipeline,
            &mut Tee::new(csv_sink(stdout, live, &args.settings), links),
            &mut monitor,
        ),
    };
    input::report(&monitor);
    conclude(&summary, result)
}

/// The JSON lines sink, predicting when `--predict arrival` asks.
pub fn jsonl_sink<W: io::Write>(out: W, live: bool, settings: &TrackSettings) -> JsonLinesSink<W> {
    let sink = JsonLinesSink::new(out, live);
    match settings.predict {
        Predict::Arrival => sink.predicting(),
        Predict::None => sink,
    }
}

/// The CSV sink, with the predicted columns when `--predict arrival` asks.
fn csv_sink<W: io::Write>(out: W, live: bool, settings: &TrackSettings) -> CsvSink<W> {
    let sink = CsvSink::new(out, live);
    match settings.predict {
        Predict::Arrival => sink.predicting(),
        Predict::None => sink,
    }
}

/// Reports the end of a run and turns its outcome into an exit code.
pub fn conclude<E>(
    summary: &RunSummary,
    result: Result<(), pipeline::RunError<E>>,
) -> Result<ExitCode>
where
    pipeline::RunError<E>: std::error::Error + Send + Sync + 'static,
{
    log_summary(summary);
    match result {
        Ok(()) => Ok(ExitCode::SUCCESS),
        // A reader that went away (`| head`) is not an error of ours.
        Err(pipeline::RunError::Sink(e)) if e.kind() == io::ErrorKind::BrokenPipe => {
            Ok(ExitCode::SUCCESS)
        }
        // An empty input says so itself; "after 0 whole frames" would add nothing.
        Err(e) if summary.frames == 0 => Err(e.into()),
        Err(e) => Err(e).with_context(|| format!("after {} whole frames", summary.frames)),
    }
}

/// Feeds the first `--background-frames` frames of a separate dump to the background model.
/// A FIFO that stays quiet gives up once `stop` is set.
fn learn_background(
    pipeline: &mut Pipeline,
    path: &Path,
    args: &TrackSettings,
    stop: &Arc<AtomicBool>,
) -> Result<()> {
    let file = input::open_without_waiting(path).context("background")?;
    let reader = Interruptible::new(file, Arc::clone(stop));
    let fps = args.fps.unwrap_or(input::DEFAULT_DUMP_FPS);
    let mut source =
        DumpSource::try_with_format(reader, args.size, fps, args.input.pixel_format())?;
    let mut learned = 0;
    while learned < args.background_frames {
        match source.next_frame() {
            Ok(Some((frame, _))) => pipeline.learn_background(&frame)?,
            Ok(None) => bail!(
                "background {} has {learned} whole frames, --background-frames wants {}",
                path.display(),
                args.background_frames
            ),
            Err(e) => return Err(e).with_context(|| format!("background {}", path.display())),
        }
        learned += 1;
    }
    Ok(())
}

fn log_summary(summary: &RunSummary) {
    log::info!(
        "{} frames, LED found in {}, {} blinded, {} with too many blobs",
        summary.frames,
        summary.found,
        summary.blinded,
        summary.overflowed
    );
}
