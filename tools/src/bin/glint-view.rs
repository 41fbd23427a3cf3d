//! `glint-view`: one frame of a raw YUYV dump as a PNG, with what glint saw drawn on it.
//!
//! The dump is replayed through the real pipeline from its first frame up to the one asked
//! for, so that frame is processed exactly as `glint track` processes it (state carried from
//! frame to frame included, once tracking has any). The overlay then shows the saturation
//! mask, the skeleton, the chosen blob, glint's answers and, given a truth CSV from
//! `glint-scene`, the ground truth.

use std::fs::File;
use std::io::{self, BufReader, Read};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{bail, Context, Result};
use clap::{Parser, ValueEnum};
use glint::detect::MaskMethod;
use glint::frame::FrameSize;
use glint::options::{parse_fps, LedArgs};
use glint::pipeline::{Pipeline, PipelineConfig};
use glint::source::dump::DumpSource;
use glint::source::FrameSource;
use glint::track::TrackerConfig;
use glint_tools::overlay::{Overlay, YuvRange};
use glint_tools::scene::{read_truth_csv, Truth};

/// Draw one frame of a YUYV dump with glint's mask, skeleton, detections and the ground truth.
#[derive(Parser, Debug)]
#[command(version, about)]
pub(crate) struct Args {
    /// A raw YUYV dump, or `-` for standard input.
    #[arg(long, value_name = "PATH|-")]
    input: String,
    /// Frame size in pixels.
    #[arg(long, value_name = "WxH")]
    size: FrameSize,
    /// The 0-based index of the frame to draw.
    #[arg(long, value_name = "N")]
    frame: u64,
    /// Where to write the PNG.
    #[arg(long, value_name = "FILE.png")]
    out: PathBuf,
    /// Ground truth written by `glint-scene` (NAME.truth.csv).
    #[arg(long, value_name = "TRUTH.csv")]
    truth: Option<PathBuf>,
    /// Frame rate of the dump, for timestamps (as `glint track --fps`).
    #[arg(long, default_value_t = 30.0, value_parser = parse_fps)]
    fps: f64,
    /// The detector's options, exactly as `glint track` takes them.
    #[command(flatten)]
    led: LedArgs,
    /// The camera's exposure time, as `glint track --exposure-us`.
    #[arg(long, value_name = "US", value_parser = clap::value_parser!(u32).range(1..=10_000_000))]
    exposure_us: Option<u32>,
    /// How the camera codes its YUV, for display only (auto: guessed from the frame's luma).
    #[arg(long, value_enum, default_value_t = RangeArg::Auto)]
    range: RangeArg,
}

#[derive(Debug, Clone, Copy, ValueEnum)]
enum RangeArg {
    Auto,
    Full,
    Studio,
}

impl Args {
    /// The pipeline settings `glint track` would use with the same options.
    fn pipeline_config(&self) -> PipelineConfig {
        PipelineConfig {
            detector: self.led.detector_config(MaskMethod::Saturation),
            tracker: TrackerConfig {
                exposure_us: self.exposure_us,
            },
        }
    }
}

fn main() -> ExitCode {
    match run(Args::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("glint-view: {e:#}");
            ExitCode::FAILURE
        }
    }
}

fn run(args: Args) -> Result<()> {
    let truth = match &args.truth {
        Some(path) => Some(truth_of_frame(path, args.frame)?),
        None => None,
    };
    let reader = open_dump(&args)?;
    let mut source = DumpSource::new(reader, args.size, args.fps);
    let mut pipeline = Pipeline::new(args.size, args.pipeline_config())?;
    let mut processed = 0u64;
    loop {
        let (frame, meta) = match source.next_frame() {
            Ok(Some(next)) => next,
            Ok(None) => bail!(
                "frame {} is past the end of {}: it holds {processed} frames of {}",
                args.frame,
                args.input,
                args.size
            ),
            Err(e) => {
                return Err(e)
                    .with_context(|| format!("before frame {} of {}", args.frame, args.input))
            }
        };
        let report = pipeline.process(&frame, meta);
        processed += 1;
        if meta.index < args.frame {
            continue;
        }
        let range = match args.range {
            RangeArg::Auto => YuvRange::guess(&frame),
            RangeArg::Full => YuvRange::Full,
            RangeArg::Studio => YuvRange::Studio,
        };
        let title = Path::new(&args.input)
            .file_name()
            .map_or(args.input.clone(), |n| n.to_string_lossy().into_owned());
        let mut overlay = Overlay::from_report(frame, &pipeline, &report, range).with_title(title);
        if let Some(t) = &truth {
            overlay = overlay.with_truth(t);
        }
        let image = overlay.render();
        image
            .canvas
            .save_png(&args.out)
            .with_context(|| format!("cannot write {}", args.out.display()))?;

        match report.position {
            Some(p) => println!(
                "frame {}: found, mid {:.3} {:.3}, x,y {:.3} {:.3} ({})",
                args.frame,
                p.mid_px.0,
                p.mid_px.1,
                p.position_px.0,
                p.position_px.1,
                p.position_method.name()
            ),
            None => println!("frame {}: not found", args.frame),
        }
        if let Some(t) = &truth {
            let pair = |x: Option<f64>, y: Option<f64>| {
                x.zip(y)
                    .map_or("-".into(), |(x, y)| format!("{x:.3} {y:.3}"))
            };
            println!(
                "truth: mid {}, x,y {}",
                pair(t.mid_x_px, t.mid_y_px),
                pair(t.x_px, t.y_px)
            );
        }
        println!(
            "wrote {} ({}x{})",
            args.out.display(),
            image.canvas.width(),
            image.canvas.height()
        );
        return Ok(());
    }
}

/// The dump as a reader. A file is checked up front, so a frame past its end is refused
/// before anything is processed.
fn open_dump(args: &Args) -> Result<Box<dyn Read>> {
    if args.input == "-" {
        return Ok(Box::new(io::stdin().lock()));
    }
    let file = File::open(&args.input).with_context(|| format!("cannot open {}", args.input))?;
    let metadata = file
        .metadata()
        .with_context(|| format!("cannot read {}", args.input))?;
    if metadata.is_dir() {
        bail!("{} is a directory, not a dump", args.input);
    }
    if metadata.is_file() {
        let frame_bytes = args.size.frame_bytes() as u64;
        let frames = metadata.len() / frame_bytes.max(1);
        if args.frame >= frames {
            let trailing = metadata.len() % frame_bytes.max(1);
            let trailing_note = if trailing > 0 {
                format!(" and {trailing} trailing bytes (is --size right?)")
            } else {
                String::new()
            };
            bail!(
                "frame {} is past the end of {}: it holds {frames} whole frames of {} \
                 ({frame_bytes} bytes each){trailing_note}",
                args.frame,
                args.input,
                args.size
            );
        }
    }
    Ok(Box::new(BufReader::new(file)))
}

/// The truth CSV's row for `frame`.
fn truth_of_frame(path: &Path, frame: u64) -> Result<Truth> {
    let file = File::open(path).with_context(|| format!("cannot open {}", path.display()))?;
    let truths = read_truth_csv(BufReader::new(file))
        .with_context(|| format!("cannot read {}", path.display()))?;
    let rows = truths.len();
    truths
        .into_iter()
        .find(|t| t.frame as u64 == frame)
        .with_context(|| {
            format!(
                "{} has no row for frame {frame} ({rows} rows)",
                path.display()
            )
        })
}
