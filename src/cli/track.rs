//! `glint track`: run the pipeline on a raw YUYV dump or a camera and print one report per frame.

use std::fs::File;
use std::io::{self, BufWriter};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{bail, Context, Result};
use clap::{Args, ValueEnum};

use super::{calib_args, input};

use glint::detect::bgdiff::MAX_BACKGROUND_FRAMES;
use glint::detect::MaskMethod;
use glint::frame::FrameSize;
use glint::monitor::{self, Monitor};
use glint::options::{parse_fps, LedArgs};
use glint::pipeline::{self, Pipeline, PipelineConfig, RunSummary};
use glint::sink::{serial, CsvSink, JsonLinesSink, SerialSink, Tee};
use glint::source::dump::DumpSource;
use glint::source::FrameSource;
use glint::track::TrackerConfig;

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

    /// Frame size in pixels.
    #[arg(long, value_name = "WxH")]
    pub size: FrameSize,

    /// Frame rate: of a dump without a sidecar, for timestamps (default 30); of a camera, to
    /// ask for (default: its current one).
    #[arg(long, value_parser = parse_fps)]
    fps: Option<f64>,

    #[command(flatten)]
    led: LedArgs,

    /// What finds the robot: saturated pixels, pixels that differ from a background, or an
    /// ArUco marker it carries (`aruco`, with `--marker ID`).
    #[arg(long, value_enum, default_value_t = DetectorArg::Saturation)]
    detector: DetectorArg,

    /// With `--detector bgdiff`: learn the background from the first N frames (their
    /// per-pixel median), which are then reported as not found.
    #[arg(long, default_value_t = 9, value_name = "N",
          value_parser = clap::value_parser!(u16).range(1..=MAX_BACKGROUND_FRAMES as i64))]
    background_frames: u16,

    /// With `--detector bgdiff`: learn the background from a separate raw dump of the empty
    /// scene instead (its first `--background-frames` frames, at least one).
    #[arg(long, value_name = "PATH")]
    pub background: Option<PathBuf>,

    /// With `--detector bgdiff`: the luma difference from the background that counts.
    #[arg(long, default_value_t = 60, value_name = "LUMA",
          value_parser = clap::value_parser!(u8).range(1..))]
    diff: u8,

    #[command(flatten)]
    pub floor: calib_args::FloorArgs,

    /// Also send position packets to the robot on this serial port (board/protocol/SPEC.md).
    #[arg(long, value_name = "PORT")]
    pub serial: Option<String>,

    /// Line rate of --serial, 8N1.
    #[arg(long, default_value_t = serial::DEFAULT_BAUD, value_parser = clap::value_parser!(u32).range(50..=4_000_000))]
    baud: u32,
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
    pub source: input::InputSource,
    /// Reports are flushed one by one (a pipe or a camera), not in blocks.
    pub live: bool,
    pub monitor: Monitor,
    pub pipeline: Pipeline,
    pub serial: Option<SerialSink>,
}

/// Opens the input, builds the pipeline (learning a separate background when asked) and opens
/// the serial link, in that order.
pub fn open(settings: &TrackSettings) -> Result<Opened> {
    let input::Input {
        source,
        live,
        monitor,
    } = input::open(&settings.input, settings.size, settings.fps)?;
    let aruco = settings.detector == DetectorArg::Aruco;
    let mut pipeline = calib_args::build_pipeline(
        &settings.floor,
        settings.size,
        aruco,
        settings.pipeline_config(),
    )?;
    if let Some(path) = &settings.background {
        if settings.detector != DetectorArg::Bgdiff {
            bail!("--background goes with --detector bgdiff");
        }
        learn_background(&mut pipeline, path, settings)?;
    }
    let serial = settings
        .serial
        .as_deref()
        .map(|port| SerialSink::open(port, settings.baud))
        .transpose()?;
    Ok(Opened {
        source,
        live,
        monitor,
        pipeline,
        serial,
    })
}

pub fn run(args: TrackArgs) -> Result<ExitCode> {
    let Opened {
        mut source,
        live,
        mut monitor,
        mut pipeline,
        serial,
    } = open(&args.settings)?;
    let stdout = BufWriter::with_capacity(OUTPUT_BUFFER_BYTES, io::stdout().lock());
    let (summary, result) = match args.format {
        Format::Jsonl => monitor::run(
            &mut source,
            &mut pipeline,
            &mut Tee::new(JsonLinesSink::new(stdout, live), serial),
            &mut monitor,
        ),
        Format::Csv => monitor::run(
            &mut source,
            &mut pipeline,
            &mut Tee::new(CsvSink::new(stdout, live), serial),
            &mut monitor,
        ),
    };
    input::report(&monitor);
    conclude(&summary, result)
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
        Err(e) => Err(e).with_context(|| format!("after {} whole frames", summary.frames)),
    }
}

/// Feeds the first `--background-frames` frames of a separate dump to the background model.
fn learn_background(pipeline: &mut Pipeline, path: &Path, args: &TrackSettings) -> Result<()> {
    let file =
        File::open(path).with_context(|| format!("cannot open background {}", path.display()))?;
    let fps = args.fps.unwrap_or(input::DEFAULT_DUMP_FPS);
    let mut source = DumpSource::with_format(file, args.size, fps, args.input.pixel_format());
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
