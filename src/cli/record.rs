//! `glint record`: captures frames from a camera into a raw dump plus its sidecar (size, format,
//! strides, and each frame's sequence number and time), so that `glint track --input` replays
//! them elsewhere with the real timing and drops.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::{Duration, Instant};

use anyhow::{Context, Result};
use clap::Args;

use glint::budget::{self, MemoryPlan};
use glint::frame::{FrameSize, PixelFormat};
use glint::source::record::DumpRecorder;
use glint::source::sidecar::{FrameTiming, Sidecar};
use glint::source::v4l2::ReopeningSource;
use glint::source::FrameSource;

use super::camera::{self, CameraArgs};
use super::memory::MemoryArgs;

/// Frames the dump's write buffer holds.
const WRITE_BUFFER_FRAMES: usize = 2;

/// The highest frame rate a camera is asked for.
const MAX_RECORD_FPS: i64 = 1_000;

/// Most frames one recording takes: over 90 hours at 30 fps.
const MAX_RECORD_FRAMES: u64 = 10_000_000;

/// How often progress is logged during a long recording.
const PROGRESS_EVERY: Duration = Duration::from_secs(10);

#[derive(Debug, Args)]
pub struct RecordArgs {
    /// The camera, e.g. /dev/video0 (`glint devices` lists them).
    #[arg(long, value_name = "/dev/videoN")]
    device: PathBuf,

    /// Frame size in pixels: sides 1 to 16384, the width even.
    #[arg(long, value_name = "WxH")]
    size: FrameSize,

    /// Frame rate to ask for, 1 to 1000 (default: the camera's current one).
    #[arg(long, value_name = "FPS", allow_negative_numbers = true,
          value_parser = clap::value_parser!(u32).range(1..=MAX_RECORD_FPS))]
    fps: Option<u32>,

    /// Frames to record, 1 to 10000000 (their timing is kept in memory, 16 bytes each);
    /// Ctrl-C stops earlier and keeps what was recorded.
    #[arg(long, value_name = "N", allow_negative_numbers = true,
          value_parser = clap::value_parser!(u64).range(1..=MAX_RECORD_FRAMES))]
    frames: u64,

    /// The dump to write (unpadded rows); the sidecar goes beside it as FILE.json.
    #[arg(long, value_name = "FILE.yuv")]
    out: PathBuf,

    /// Pixel format to ask the camera for: yuyv, uyvy or grey. The sidecar records it.
    #[arg(long, value_name = "yuyv|uyvy|grey", default_value_t = PixelFormat::Yuyv)]
    format_in: PixelFormat,

    #[command(flatten)]
    camera: CameraArgs,

    #[command(flatten)]
    memory: MemoryArgs,
}

pub fn run(args: RecordArgs) -> Result<ExitCode> {
    let frames = usize::try_from(args.frames).context("--frames is too large")?;
    let size = args.size;
    let mut plan = MemoryPlan::new();
    plan.add(
        "the camera's buffers",
        format!("--buffers {} × --size {size}", args.camera.buffers()),
        u64::from(args.camera.buffers()).saturating_mul(budget::frame_bytes(size)),
    );
    plan.add(
        "the write buffer",
        format!("--size {size}"),
        WRITE_BUFFER_FRAMES as u64 * budget::frame_bytes(size),
    );
    plan.add(
        "the frame timings",
        format!("--frames {}", args.frames),
        args.frames
            .saturating_mul(std::mem::size_of::<FrameTiming>() as u64),
    );
    args.memory.check(&plan)?;
    let mut source = camera::open(
        &args.device,
        args.size,
        args.fps,
        args.format_in,
        &args.camera,
    )?;
    let negotiated = source.current().map(|s| *s.negotiated());
    let file =
        File::create(&args.out).with_context(|| format!("cannot create {}", args.out.display()))?;
    let frame_bytes = args.size.frame_bytes_as(args.format_in);
    let writer = BufWriter::with_capacity(frame_bytes * WRITE_BUFFER_FRAMES, file);
    let mut recorder = DumpRecorder::new(writer, args.size, frames)?;

    // Whatever stops the capture, the frames recorded so far are kept with their sidecar.
    let captured = capture(&mut source, &mut recorder, frames);
    let recorded = recorder.frames();
    let (_, timings) = recorder
        .finish()
        .with_context(|| format!("cannot write {}", args.out.display()))?;
    let mut sidecar = Sidecar::new(
        args.size,
        negotiated.map_or(args.size.row_bytes_as(args.format_in), |n| n.stride_bytes),
        timings,
    )
    .with_format(args.format_in);
    sidecar.fps = negotiated.and_then(|n| n.fps);
    sidecar.device = Some(args.device.display().to_string());
    let sidecar_path = Sidecar::path_for(&args.out);
    write_sidecar(&sidecar, &sidecar_path)?;
    log::info!(
        "recorded {recorded} frames ({} dropped) to {} and {}",
        sidecar.dropped(),
        args.out.display(),
        sidecar_path.display()
    );
    captured?;
    if recorded < frames {
        log::warn!("stopped after {recorded} of {frames} frames");
    }
    Ok(ExitCode::SUCCESS)
}

/// Records frames until `frames` are in or the source stops (Ctrl-C).
fn capture<W: Write>(
    source: &mut ReopeningSource,
    recorder: &mut DumpRecorder<W>,
    frames: usize,
) -> Result<()> {
    let mut last_progress = Instant::now();
    while recorder.frames() < frames {
        match source.next_frame()? {
            Some((frame, meta)) => recorder.record(&frame, &meta)?,
            None => break,
        }
        if last_progress.elapsed() >= PROGRESS_EVERY {
            log::info!("{} of {frames} frames recorded", recorder.frames());
            last_progress = Instant::now();
        }
    }
    Ok(())
}

fn write_sidecar(sidecar: &Sidecar, path: &std::path::Path) -> Result<()> {
    let file = File::create(path).with_context(|| format!("cannot create {}", path.display()))?;
    sidecar
        .write(BufWriter::new(file))
        .with_context(|| format!("cannot write {}", path.display()))
}
