//! Captures frames from a V4L2 camera with glint's `V4l2Source` and prints one JSON line per
//! frame. The VM tests (tests/vivid.rs) run it inside a guest against the kernel's vivid driver.
//!
//! ```text
//! capture_probe --device /dev/video0 --size 640x480 --frames 20 [--fps 10] [--buffers 4]
//!               [--reopen] [--stall-ms 2000] [--control NAME=VALUE]... [--exposure-us N]
//! capture_probe --list
//! ```
//!
//! Lines: `{"event":"open",...}` with the negotiated format, `{"event":"controls",...}`, then per
//! frame `{"event":"frame","index":..,"seq":..,"dropped":..,"t_us":..,"id":..,"hash":".."}`
//! where `id` is the little-endian u32 of the first four luma bytes and `hash` the FNV-1a 64 of
//! the frame's rows without padding. A failure prints `{"event":"error",...}` and exits 2.

use std::process::ExitCode;
use std::time::Duration;

use anyhow::Context;
use clap::Parser;
use glint::frame::{Frame, FrameSize};
use glint::source::v4l2::{
    devices, CaptureConfig, ControlRequest, NamedControl, ReopeningSource, V4l2Error, V4l2Source,
};
use glint::source::{FrameMeta, FrameSource};

#[derive(Parser)]
struct Args {
    #[arg(long, default_value = "/dev/video0")]
    device: String,
    #[arg(long, default_value = "640x480")]
    size: FrameSize,
    #[arg(long)]
    fps: Option<u32>,
    #[arg(long, default_value_t = 10)]
    frames: u64,
    #[arg(long, default_value_t = 4)]
    buffers: u32,
    /// Reopen the device after faults instead of failing.
    #[arg(long)]
    reopen: bool,
    #[arg(long, default_value_t = 2000)]
    stall_ms: u64,
    #[arg(long = "control")]
    controls: Vec<NamedControl>,
    #[arg(long)]
    exposure_us: Option<u32>,
    /// List capture devices and exit.
    #[arg(long)]
    list: bool,
}

/// Log records to stderr, so faults and reopening show in the guest log.
struct StderrLog;

impl log::Log for StderrLog {
    fn enabled(&self, _: &log::Metadata<'_>) -> bool {
        true
    }
    fn log(&self, record: &log::Record<'_>) {
        eprintln!("{}: {}", record.level(), record.args());
    }
    fn flush(&self) {}
}

fn json_string(s: &str) -> String {
    let mut out = String::with_capacity(s.len() + 2);
    out.push('"');
    for c in s.chars() {
        match c {
            '"' => out.push_str("\\\""),
            '\\' => out.push_str("\\\\"),
            c if (c as u32) < 0x20 => out.push_str(&format!("\\u{:04x}", c as u32)),
            c => out.push(c),
        }
    }
    out.push('"');
    out
}

/// FNV-1a 64 over the frame's rows, padding excluded.
fn frame_hash(frame: &Frame<'_>) -> u64 {
    const OFFSET: u64 = 0xcbf2_9ce4_8422_2325;
    const PRIME: u64 = 0x0000_0100_0000_01b3;
    frame
        .rows()
        .flatten()
        .fold(OFFSET, |h, &b| (h ^ u64::from(b)).wrapping_mul(PRIME))
}

fn frame_id(frame: &Frame<'_>) -> u32 {
    let luma = |x| u32::from(frame.luma(x, 0).unwrap_or(0));
    luma(0) | luma(1) << 8 | luma(2) << 16 | luma(3) << 24
}

fn print_frame(frame: &Frame<'_>, meta: &FrameMeta) {
    println!(
        "{{\"event\":\"frame\",\"index\":{},\"seq\":{},\"dropped\":{},\"t_us\":{},\"stride\":{},\"id\":{},\"hash\":\"{:016x}\"}}",
        meta.index,
        meta.sequence,
        meta.dropped,
        meta.timestamp_us,
        frame.stride_bytes(),
        frame_id(frame),
        frame_hash(frame)
    );
}

fn capture<S: FrameSource<Error = V4l2Error>>(
    source: &mut S,
    frames: u64,
) -> Result<(), V4l2Error> {
    for _ in 0..frames {
        match source.next_frame()? {
            Some((frame, meta)) => print_frame(&frame, &meta),
            None => break,
        }
    }
    Ok(())
}

fn print_open(source: &V4l2Source) {
    let n = source.negotiated();
    println!(
        "{{\"event\":\"open\",\"width\":{},\"height\":{},\"stride\":{},\"buffers\":{},\"fps\":{}}}",
        n.size.width(),
        n.size.height(),
        n.stride_bytes,
        source.buffer_count(),
        n.fps.map_or("null".to_string(), |f| format!("{f:.3}"))
    );
}

fn run(args: &Args) -> Result<(), V4l2Error> {
    let mut config = CaptureConfig::new(&args.device, args.size, args.fps);
    config.buffer_count = args.buffers;
    config.stall_timeout = Duration::from_millis(args.stall_ms);
    let controls = ControlRequest {
        exposure_us: args.exposure_us,
        named: args.controls.clone(),
        ..ControlRequest::default()
    };
    if args.reopen {
        let mut source = ReopeningSource::open(config, controls)?;
        if let Some(inner) = source.current() {
            print_open(inner);
        }
        capture(&mut source, args.frames)?;
        println!("{{\"event\":\"end\",\"reopens\":{}}}", source.reopens());
    } else {
        let mut source = V4l2Source::open_with(&config)?;
        print_open(&source);
        if !controls.is_empty() {
            let report = source.apply_controls(&controls);
            let refused = report.refused().count();
            println!(
                "{{\"event\":\"controls\",\"set\":{},\"refused\":{},\"report\":{}}}",
                report.outcomes.len() - refused,
                refused,
                json_string(&report.to_string())
            );
        }
        capture(&mut source, args.frames)?;
        println!("{{\"event\":\"end\",\"reopens\":0}}");
    }
    Ok(())
}

fn main() -> anyhow::Result<ExitCode> {
    log::set_logger(&StderrLog).map_err(|e| anyhow::anyhow!("installing the logger: {e}"))?;
    log::set_max_level(log::LevelFilter::Info);
    let args = Args::parse();
    if args.list {
        for device in devices::list_devices().context("listing /dev")? {
            match device {
                Ok(info) => println!("{info}"),
                Err(e) => println!("{e}"),
            }
        }
        return Ok(ExitCode::SUCCESS);
    }
    match run(&args) {
        Ok(()) => Ok(ExitCode::SUCCESS),
        Err(e) => {
            println!(
                "{{\"event\":\"error\",\"fault\":{},\"disconnected\":{},\"message\":{}}}",
                e.is_device_fault(),
                matches!(e, V4l2Error::Disconnected { .. }),
                json_string(&e.to_string())
            );
            Ok(ExitCode::from(2))
        }
    }
}
