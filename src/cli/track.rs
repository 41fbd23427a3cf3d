//! `glint track`: replay a raw YUYV dump through the pipeline and print one report per frame.

use std::fs::File;
use std::io::{self, BufWriter, Read};
use std::process::ExitCode;

use anyhow::{bail, Context, Result};
use clap::{Args, ValueEnum};

use glint::detect::morph::Kernel;
use glint::detect::skeleton::SkeletonMethod;
use glint::detect::threshold::Threshold;
use glint::detect::DetectorConfig;
use glint::frame::FrameSize;
use glint::pipeline::{self, Pipeline, PipelineConfig, RunSummary};
use glint::sink::{serial, CsvSink, JsonLinesSink, SerialSink, Tee};
use glint::source::dump::DumpSource;
use glint::track::TrackerConfig;

/// Output buffer size: a few hundred report lines.
const OUTPUT_BUFFER_BYTES: usize = 64 * 1024;

#[derive(Debug, Args)]
pub struct TrackArgs {
    /// A raw YUYV dump, or `-` for standard input.
    #[arg(long, value_name = "PATH|-")]
    input: String,

    /// Frame size in pixels.
    #[arg(long, value_name = "WxH")]
    size: FrameSize,

    /// Frame rate of the dump, for timestamps.
    #[arg(long, default_value_t = 30.0, value_parser = parse_fps)]
    fps: f64,

    /// Saturation threshold (luma 0–255), or `auto` to follow each frame's top level.
    #[arg(long, default_value = "auto", value_parser = parse_threshold)]
    threshold: Threshold,

    /// Output format.
    #[arg(long, value_enum, default_value_t = Format::Jsonl)]
    format: Format,

    /// Erosions of the mask before blobs are found (the seed used 10, which erases LEDs
    /// narrower than 21 px).
    #[arg(long, default_value_t = 0, value_name = "N")]
    erode: u32,

    /// Structuring element of the erosions.
    #[arg(long, value_enum, default_value_t = KernelArg::Square)]
    erode_kernel: KernelArg,

    /// The camera's exposure time in microseconds, when known: the streak's length over it
    /// gives the speed within a single frame.
    #[arg(long, value_name = "US", value_parser = clap::value_parser!(u32).range(1..=10_000_000))]
    exposure_us: Option<u32>,

    /// Skeleton for the streak's middle and ends.
    #[arg(long, value_enum, default_value_t = SkeletonArg::Thinning)]
    skeleton: SkeletonArg,

    /// Also send position packets to the robot on this serial port (board/protocol/SPEC.md).
    #[arg(long, value_name = "PORT")]
    serial: Option<String>,

    /// Line rate of --serial, 8N1.
    #[arg(long, default_value_t = serial::DEFAULT_BAUD, value_parser = clap::value_parser!(u32).range(50..=4_000_000))]
    baud: u32,
}

#[derive(Debug, Clone, Copy, ValueEnum)]
enum Format {
    Jsonl,
    Csv,
}

#[derive(Debug, Clone, Copy, ValueEnum)]
enum KernelArg {
    Square,
    Cross,
}

#[derive(Debug, Clone, Copy, ValueEnum)]
enum SkeletonArg {
    /// Guo–Hall thinning: connected and one pixel wide.
    Thinning,
    /// The seed's morphological skeleton.
    Seed,
}

fn parse_fps(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(f) if f.is_finite() && f > 0.0 && f <= 10_000.0 => Ok(f),
        _ => Err(format!("{s:?} is not a frame rate between 0 and 10000")),
    }
}

fn parse_threshold(s: &str) -> Result<Threshold, String> {
    if s == "auto" {
        return Ok(Threshold::Auto);
    }
    s.parse::<u8>()
        .map(Threshold::Fixed)
        .map_err(|_| format!("{s:?} is neither `auto` nor a luma level 0–255"))
}

impl TrackArgs {
    fn pipeline_config(&self) -> PipelineConfig {
        PipelineConfig {
            detector: DetectorConfig {
                threshold: self.threshold,
                erosions: self.erode,
                erosion_kernel: match self.erode_kernel {
                    KernelArg::Square => Kernel::Square,
                    KernelArg::Cross => Kernel::Cross,
                },
                skeleton: match self.skeleton {
                    SkeletonArg::Thinning => SkeletonMethod::Thinning,
                    SkeletonArg::Seed => SkeletonMethod::Morphological,
                },
                ..DetectorConfig::default()
            },
            tracker: TrackerConfig {
                exposure_us: self.exposure_us,
            },
        }
    }
}

pub fn run(args: TrackArgs) -> Result<ExitCode> {
    let live = args.input == "-";
    let reader: Box<dyn Read> = if live {
        Box::new(io::stdin().lock())
    } else {
        let file =
            File::open(&args.input).with_context(|| format!("cannot open {}", args.input))?;
        if file.metadata().map(|m| m.is_dir()).unwrap_or(false) {
            bail!("{} is a directory, not a dump", args.input);
        }
        Box::new(file)
    };
    let mut source = DumpSource::new(reader, args.size, args.fps);
    let mut pipeline = Pipeline::new(args.size, args.pipeline_config());
    let serial = args
        .serial
        .as_deref()
        .map(|port| SerialSink::open(port, args.baud));
    let serial = serial.transpose()?;
    let stdout = BufWriter::with_capacity(OUTPUT_BUFFER_BYTES, io::stdout().lock());
    let (summary, result) = match args.format {
        Format::Jsonl => pipeline::run(
            &mut source,
            &mut pipeline,
            &mut Tee::new(JsonLinesSink::new(stdout, live), serial),
        ),
        Format::Csv => pipeline::run(
            &mut source,
            &mut pipeline,
            &mut Tee::new(CsvSink::new(stdout, live), serial),
        ),
    };
    log_summary(&summary);
    match result {
        Ok(()) => Ok(ExitCode::SUCCESS),
        // A reader that went away (`| head`) is not an error of ours.
        Err(pipeline::RunError::Sink(e)) if e.kind() == io::ErrorKind::BrokenPipe => {
            Ok(ExitCode::SUCCESS)
        }
        Err(e) => Err(e).with_context(|| format!("after {} whole frames", summary.frames)),
    }
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
