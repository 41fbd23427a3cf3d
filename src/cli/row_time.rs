//! `glint row-time`: measures a rolling shutter's row time from the bands a flickering lamp
//! draws across a recording's (or a camera's) frames, for `glint track --row-time-us`.

use std::io::{self, Write};
use std::process::ExitCode;
use std::sync::atomic::AtomicBool;
use std::sync::Arc;

use anyhow::{bail, Context, Result};
use clap::Args;

use glint::frame::FrameSize;
use glint::options::parse_fps;
use glint::row_time::profiles::RowProfiles;
use glint::row_time::{measure, RowTime, MAINS_FLICKER_HZ, MIN_FRAMES};
use glint::source::FrameSource;

use super::{input, signals};

/// Frames read at most.
const MAX_FRAMES: u32 = 1000;

/// The flicker frequencies `--flicker-hz` takes, Hz: mains lamps, and dimmers' faster PWM.
const FLICKER_HZ_RANGE: (f64, f64) = (1.0, 5000.0);

/// The options of `glint row-time`.
#[derive(Debug, Args)]
pub struct RowTimeArgs {
    #[command(flatten)]
    input: input::InputArgs,

    /// Frame size in pixels: sides 1 to 16384, the width even.
    #[arg(long, value_name = "WxH")]
    size: FrameSize,

    /// Frame rate, 0.1 to 1000: of a dump without a sidecar, for timestamps (default 30); of
    /// a camera, to ask for (default: its current one). The bands' motion from frame to frame
    /// is checked against the frame times, so they must be right.
    #[arg(long, value_parser = parse_fps, allow_negative_numbers = true)]
    fps: Option<f64>,

    /// Frames to read, 9 to 1000 (three seconds at 30 fps by default).
    #[arg(long, default_value_t = 90, value_parser = clap::value_parser!(u32).range(MIN_FRAMES as i64..=MAX_FRAMES as i64))]
    frames: u32,

    /// The lamp's flicker frequency, Hz: twice the mains frequency (100 on 50 Hz mains, 120
    /// on 60 Hz). Default: both are tried, and told apart by how the bands move.
    #[arg(long, value_name = "HZ", value_parser = parse_flicker_hz, allow_negative_numbers = true)]
    flicker_hz: Option<f64>,
}

fn parse_flicker_hz(s: &str) -> Result<f64, String> {
    let (lo, hi) = FLICKER_HZ_RANGE;
    match s.trim().parse::<f64>() {
        Ok(v) if (lo..=hi).contains(&v) => Ok(v),
        _ => Err(format!("a flicker frequency is {lo} to {hi} Hz")),
    }
}

pub fn run(args: RowTimeArgs) -> Result<ExitCode> {
    let stop = Arc::new(AtomicBool::new(false));
    signals::stop_on_signals(&stop)?;
    let input::Input { mut source, .. } = input::open(&args.input, args.size, args.fps, &stop)?;
    let mut profiles = RowProfiles::new(args.size.height(), args.frames as usize);
    // A damaged input (a dump cut inside a frame, a camera gone) keeps the whole frames read
    // before it: they are measured, and the damage is reported after, as `glint track` does.
    let mut damage = None;
    while !profiles.is_full() {
        match source.next_frame() {
            Ok(Some((frame, meta))) => {
                profiles.push(&frame, meta.timestamp_us);
            }
            Ok(None) => break,
            Err(e) => {
                damage = Some(e);
                break;
            }
        }
    }
    let tried: Vec<f64> = match args.flicker_hz {
        Some(hz) => vec![hz],
        None => MAINS_FLICKER_HZ.to_vec(),
    };
    let frames = profiles.frames();
    let measured = measure(&profiles, &tried);
    if let Ok(row_time) = &measured {
        let mut stdout = io::stdout().lock();
        write!(stdout, "{}", summary(row_time, args.size))
            .context("writing the row time to standard output")?;
    }
    match (measured, damage) {
        (Ok(_), None) => Ok(ExitCode::SUCCESS),
        (Ok(_), Some(e)) => bail!("after {frames} whole frames: {e}"),
        (Err(no), Some(e)) => {
            bail!("after {frames} whole frames: {e}; no row time from them: {no}")
        }
        (Err(no), None) => bail!("no row time from {frames} frames: {no}"),
    }
}

/// The lines printed for a person.
fn summary(r: &RowTime, size: FrameSize) -> String {
    let readout_ms = r.row_time_us * (size.height() - 1) as f64 * 1e-3;
    format!(
        "row time {:.2} µs (standard error {:.2} µs)\n  from a {} Hz flicker's bands, {:.2} % of \
         the luma deep, over {} pairs of frames {:.1} ms apart\n  the {} rows are read out over \
         {readout_ms:.1} ms; give glint track --row-time-us {:.2}\n",
        r.row_time_us,
        r.standard_error_us,
        r.flicker_hz,
        100.0 * r.band_depth,
        r.pairs,
        r.frame_interval_us as f64 * 1e-3,
        size.height(),
        r.row_time_us,
    )
}
