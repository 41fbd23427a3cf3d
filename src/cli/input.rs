//! Where `glint track` reads frames from: a dump (with its recording's timing when a sidecar
//! lies beside it), standard input, or a camera. Every one of them becomes an [`InputSource`],
//! so they all run through the one monitored per-frame path, `glint::monitor::run`.

use std::fs::{File, OpenOptions};
use std::io::{self, Read};
use std::os::unix::fs::OpenOptionsExt;
use std::path::Path;
#[cfg(feature = "v4l2")]
use std::path::PathBuf;
use std::sync::atomic::AtomicBool;
use std::sync::Arc;
use std::time::Duration;

use anyhow::{anyhow, bail, Context, Result};
use clap::Args;

use glint::frame::{Frame, FrameSize, PixelFormat};
use glint::monitor::{Counts, Monitor, MonitorConfig};
use glint::source::dump::{DumpError, DumpSource};
use glint::source::interruptible::Interruptible;
use glint::source::sidecar::{ReplayError, ReplaySource, Sidecar, SidecarError};
use glint::source::stamped::{StampedError, StampedSource};
#[cfg(feature = "v4l2")]
use glint::source::v4l2::{ReopeningSource, V4l2Error};
use glint::source::{FrameMeta, FrameSource};

#[cfg(feature = "v4l2")]
use super::camera::{self, CameraArgs};

/// Frame rate assumed for a dump without a sidecar when no `--fps` is given.
pub const DEFAULT_DUMP_FPS: f64 = 30.0;

/// Exactly one of the sources.
#[derive(Debug, Args)]
#[group(required = true, multiple = false)]
pub struct SourceArgs {
    /// A raw YUYV dump, or `-` for standard input. When FILE.json (written by `glint record`)
    /// lies beside FILE, the frames get their recorded times, sequence numbers and drops.
    #[arg(long, value_name = "PATH|-")]
    input: Option<String>,

    /// A V4L2 camera, e.g. /dev/video0 (`glint devices` lists them). Runs until Ctrl-C or
    /// SIGTERM; a camera that goes away is reopened when it returns.
    #[cfg(feature = "v4l2")]
    #[arg(long, value_name = "/dev/videoN")]
    device: Option<PathBuf>,
}

/// The input options of `glint track`.
#[derive(Debug, Args)]
pub struct InputArgs {
    #[command(flatten)]
    source: SourceArgs,

    /// Ignore the dump's sidecar: frames are --fps apart and none is dropped.
    #[arg(long, requires = "input")]
    no_sidecar: bool,

    /// Each frame of the input is preceded by its capture time: the end of its exposure on
    /// this host's monotonic clock (CLOCK_MONOTONIC), in µs, 8 bytes little-endian, as a camera
    /// driver stamps its buffers. Positions' ages then count from the exposure, not from the
    /// moment the frame was read (a grabber that knows when its frames were exposed; the
    /// robot-in-the-loop rig).
    #[arg(long, requires = "input", conflicts_with = "no_sidecar")]
    stamped: bool,

    /// The exposure time the frames were made with, µs (a build without camera support takes
    /// it here; with one, the camera's `--exposure-us` says it). 1 to 10000000.
    #[cfg(not(feature = "v4l2"))]
    #[arg(long, value_name = "MICROSECONDS", allow_negative_numbers = true,
          value_parser = clap::value_parser!(u32).range(1..=10_000_000))]
    exposure_us: Option<u32>,

    /// Pixel format of the frames: yuyv, uyvy or grey (8-bit luma, as mono cameras such as
    /// the OV9281 send). Default: the sidecar's format for a recorded dump, else yuyv.
    #[arg(long, value_name = "yuyv|uyvy|grey")]
    format_in: Option<PixelFormat>,

    #[cfg(feature = "v4l2")]
    #[command(flatten)]
    camera: CameraArgs,

    /// Print latency percentiles of each stage on standard error at the end (and with every
    /// summary of a camera run).
    #[arg(long)]
    stats: bool,

    /// Seconds between summaries (frames, fps, drops, found ratio) on standard error while
    /// tracking from a camera, up to 86400; 0 for none.
    #[arg(long, value_name = "SECONDS", default_value_t = 10.0, value_parser = parse_seconds,
          allow_negative_numbers = true)]
    summary_every: f64,
}

impl InputArgs {
    /// The exposure time given with `--exposure-us`: the camera's setting, or the exposure a
    /// recording was made with.
    pub fn exposure_us(&self) -> Option<u32> {
        #[cfg(feature = "v4l2")]
        return self.camera.exposure_us();
        #[cfg(not(feature = "v4l2"))]
        return self.exposure_us;
    }

    /// The mmap buffers a camera will fill, when the input is a camera.
    pub fn camera_buffers(&self) -> Option<u32> {
        #[cfg(feature = "v4l2")]
        if self.source.device.is_some() {
            return Some(self.camera.buffers());
        }
        None
    }

    /// The pixel format given with `--format-in`, or YUYV: the format of dumps without a
    /// sidecar, of standard input, of cameras, and of a background dump.
    pub fn pixel_format(&self) -> PixelFormat {
        self.format_in.unwrap_or_default()
    }

    /// The dump file given with `--input` (not standard input).
    pub fn dump_path(&self) -> Option<&Path> {
        self.source
            .input
            .as_deref()
            .filter(|i| *i != "-")
            .map(Path::new)
    }

    /// What to watch: `--stats`, and a summary every `--summary-every` seconds.
    pub fn monitor_config(&self) -> MonitorConfig {
        MonitorConfig {
            stats: self.stats,
            summary_every: (self.summary_every > 0.0)
                .then(|| Duration::from_secs_f64(self.summary_every)),
        }
    }
}

fn parse_seconds(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v.is_finite() && (0.0..=86_400.0).contains(&v) => Ok(v),
        _ => Err("not a number of seconds from 0 to 86400".to_string()),
    }
}

/// A frame source chosen at run time.
pub enum InputSource {
    /// A dump at a nominal frame rate.
    Dump(DumpSource<Box<dyn Read>>),
    /// A dump with its recording's timing.
    Replay(ReplaySource<Box<dyn Read>>),
    /// Frames each after its capture time.
    Stamped(StampedSource<Box<dyn Read>>),
    /// A camera (boxed: its state is several times the size of a dump's).
    #[cfg(feature = "v4l2")]
    Camera(Box<ReopeningSource>),
}

/// The error of whichever source runs.
#[derive(Debug)]
pub enum InputError {
    Dump(DumpError),
    Replay(ReplayError),
    Stamped(StampedError),
    #[cfg(feature = "v4l2")]
    Camera(V4l2Error),
}

impl std::fmt::Display for InputError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            InputError::Dump(e) => write!(f, "{e}"),
            InputError::Replay(e) => write!(f, "{e}"),
            InputError::Stamped(e) => write!(f, "{e}"),
            #[cfg(feature = "v4l2")]
            InputError::Camera(e) => write!(f, "{e}"),
        }
    }
}

impl std::error::Error for InputError {}

impl FrameSource for InputSource {
    type Error = InputError;

    fn next_frame(&mut self) -> Result<Option<(Frame<'_>, FrameMeta)>, InputError> {
        match self {
            InputSource::Dump(s) => s.next_frame().map_err(InputError::Dump),
            InputSource::Replay(s) => s.next_frame().map_err(InputError::Replay),
            InputSource::Stamped(s) => s.next_frame().map_err(InputError::Stamped),
            #[cfg(feature = "v4l2")]
            InputSource::Camera(s) => s.next_frame().map_err(InputError::Camera),
        }
    }
}

/// An opened input and its watcher.
pub struct Input {
    pub source: InputSource,
    /// Reports are flushed one by one (a pipe or a camera), not in blocks.
    pub live: bool,
    pub monitor: Monitor,
}

/// Opens what `args` name for frames of `size`; `fps` is the `--fps` given, if any. Reading a
/// dump or standard input gives up waiting once `stop` is set.
pub fn open(
    args: &InputArgs,
    size: FrameSize,
    fps: Option<f64>,
    stop: &Arc<AtomicBool>,
) -> Result<Input> {
    #[cfg(feature = "v4l2")]
    if let Some(device) = &args.source.device {
        let fps = camera::whole_fps(fps)?;
        let source = camera::open(device, size, fps, args.pixel_format(), &args.camera)?;
        return Ok(Input {
            source: InputSource::Camera(Box::new(source)),
            live: true,
            monitor: Monitor::new(args.monitor_config()),
        });
    }
    #[cfg(feature = "v4l2")]
    if args.camera.any_given() {
        bail!("camera options (--buffers, --gain, --control, ...) need --device");
    }
    let monitor = Monitor::new(MonitorConfig {
        summary_every: None,
        ..args.monitor_config()
    });
    let Some(input) = args.source.input.as_deref() else {
        bail!("--input or --device is required");
    };
    let fps_or_default = fps.unwrap_or(DEFAULT_DUMP_FPS);
    if input == "-" {
        let stdin: Box<dyn Read> = Box::new(Interruptible::new(io::stdin(), Arc::clone(stop)));
        let dump = DumpSource::try_with_format(stdin, size, fps_or_default, args.pixel_format())?;
        return Ok(Input {
            source: stamped_or_not(args, dump),
            live: true,
            monitor,
        });
    }
    let file = open_without_waiting(Path::new(input))?;
    let metadata = file
        .metadata()
        .with_context(|| format!("cannot read {input}"))?;
    if metadata.is_dir() {
        bail!("{input} is a directory, not a dump");
    }
    let reader: Box<dyn Read> = Box::new(Interruptible::new(file, Arc::clone(stop)));
    let sidecar = if args.no_sidecar || args.stamped {
        None
    } else {
        find_sidecar(Path::new(input), size, metadata.len())?
    };
    let source = match sidecar {
        Some(sidecar) => {
            let recorded = sidecar_format(input, &sidecar, args.format_in)
                .map_err(|e| anyhow!("{e} (--no-sidecar replays the dump without it)"))?;
            if fps.is_some() {
                log::warn!("--fps is ignored: the sidecar's frame times are used");
            }
            let dump = DumpSource::try_with_format(reader, size, fps_or_default, recorded)?;
            InputSource::Replay(ReplaySource::from_dump(dump, sidecar))
        }
        None => stamped_or_not(
            args,
            DumpSource::try_with_format(reader, size, fps_or_default, args.pixel_format())?,
        ),
    };
    Ok(Input {
        source,
        live: false,
        monitor,
    })
}

/// `dump` as it is, or read as stamped frames with `--stamped`.
fn stamped_or_not(args: &InputArgs, dump: DumpSource<Box<dyn Read>>) -> InputSource {
    if args.stamped {
        InputSource::Stamped(StampedSource::new(dump))
    } else {
        InputSource::Dump(dump)
    }
}

/// Opens a dump for reading without waiting: a FIFO opens at once instead of blocking until a
/// writer comes (the reads then wait, see [`Interruptible`]).
pub fn open_without_waiting(input: &Path) -> Result<File> {
    OpenOptions::new()
        .read(true)
        .custom_flags(nix::fcntl::OFlag::O_NONBLOCK.bits())
        .open(input)
        .with_context(|| format!("cannot open {}", input.display()))
}

/// The checked sidecar of `dump`, or `None` when it has none.
fn find_sidecar(dump: &Path, size: FrameSize, dump_bytes: u64) -> Result<Option<Sidecar>> {
    let sidecar = sidecar_of(dump, size, dump_bytes)
        .map_err(|e| anyhow!("{e} (--no-sidecar replays the dump without it)"))?;
    if let Some(sidecar) = &sidecar {
        log::info!(
            "{}: replaying {} frames with their recorded times ({} dropped)",
            Sidecar::path_for(dump).display(),
            sidecar.frames.len(),
            sidecar.dropped()
        );
    }
    Ok(sidecar)
}

/// The sidecar `glint record` wrote beside `dump` (`dump_bytes` long, frames of `size`), or
/// `None` when it has none. A sidecar that does not fit its dump is an error naming it.
pub fn sidecar_of(dump: &Path, size: FrameSize, dump_bytes: u64) -> Result<Option<Sidecar>> {
    let path = Sidecar::path_for(dump);
    match Sidecar::load_for(&path, size, dump_bytes) {
        Ok(sidecar) => Ok(Some(sidecar)),
        Err(SidecarError::Io(e)) if e.kind() == io::ErrorKind::NotFound => Ok(None),
        Err(e) => bail!("{}: {e}", path.display()),
    }
}

/// The pixel format the sidecar of the dump `input` records, unless `--format-in` (`given`)
/// says another: a dump holds frames of one format, and reading them as another gives
/// garbage positions.
pub fn sidecar_format(
    input: &str,
    sidecar: &Sidecar,
    given: Option<PixelFormat>,
) -> Result<PixelFormat> {
    let recorded = sidecar.pixel_format()?;
    if let Some(given) = given.filter(|&f| f != recorded) {
        bail!("the sidecar of {input} says the frames are {recorded}, but --format-in is {given}");
    }
    Ok(recorded)
}

/// Logs the run's drops and, when asked for, prints its latency percentiles.
pub fn report(monitor: &Monitor) {
    let Counts {
        frames, dropped, ..
    } = monitor.totals();
    if dropped > 0 {
        log::info!("{dropped} frames dropped upstream of {frames} processed");
    }
    if let Some(stats) = monitor.stats() {
        super::logger::write_line(format_args!("glint: {stats}"));
    }
}

#[cfg(test)]
mod tests {
    use clap::CommandFactory;

    /// Every subcommand's options fit together (no duplicate names, groups name real options).
    #[test]
    fn the_command_line_is_consistent() {
        super::super::Cli::command().debug_assert();
    }
}
