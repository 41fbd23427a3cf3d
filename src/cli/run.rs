//! `glint run`: the long-running mode for a tracker beside the track. Camera → tracker → floor
//! → serial link, plus optional JSON lines, with every setting in one file (`--config`, see
//! [`super::run_config`]) whose keys are the options of `glint track`. It logs a one-line status
//! periodically, keeps going through camera and serial faults (the camera source and the serial
//! sink reopen what went away) and through a failing JSON output, and stops cleanly on SIGTERM.

use std::fs::OpenOptions;
use std::io::{self, BufWriter, Write};
use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{Context, Result};
use clap::Args;

use glint::budget::{self, MemoryPlan};
use glint::geometry::CalibrationFile;
use glint::monitor::{self, Monitor};
use glint::sink::{BestEffort, PreviewSink, Tee};
use glint::small_file;

use super::logger;
use super::track::{self, Opened, TrackSettings};

/// Where `--preview` serves without an address: this machine only.
const DEFAULT_PREVIEW_ADDR: &str = "127.0.0.1:8080";

/// Buffer of the JSON lines output (flushed after every line).
const JSONL_BUFFER_BYTES: usize = 16 * 1024;

/// Options of `glint run`; each may also be a key of the `--config` file.
#[derive(Debug, Args)]
pub struct RunArgs {
    /// Settings file (TOML). Its keys are the long names of these options (`device`, `size`,
    /// `exposure-us`, `calib`, `serial`, `jsonl`, ...); options on the command line override it.
    /// A regular file of at most 1 MB.
    #[arg(long, value_name = "FILE")]
    config: Option<PathBuf>,

    #[command(flatten)]
    settings: TrackSettings,

    /// Also write the reports as JSON lines (those of `glint track`) to this file, appended, or
    /// `-` for standard output. A failing output is logged and dropped; tracking goes on.
    #[arg(long, value_name = "PATH|-")]
    jsonl: Option<String>,

    /// Serve a live page for aiming the camera (the frame, the saturation mask, the streak and
    /// track, the frame rate) on this address; on 127.0.0.1:8080 when given no value (or
    /// `preview = true`). Frames are copied only while a viewer is connected, at 2 Hz.
    #[arg(long, value_name = "ADDR:PORT", num_args = 0..=1,
          default_missing_value = DEFAULT_PREVIEW_ADDR)]
    preview: Option<SocketAddr>,
}

pub fn run(args: RunArgs) -> Result<ExitCode> {
    // The status lines are the point of a long run: info level at least.
    if log::max_level() < log::LevelFilter::Info {
        log::set_max_level(log::LevelFilter::Info);
    }
    if let Some(config) = &args.config {
        log::info!("settings from {}", config.display());
    }
    check_files(&args)?;
    args.settings.serial_plan()?;
    let jsonl = args.jsonl.as_deref().map(open_jsonl).transpose()?;
    let Opened {
        mut source,
        mut pipeline,
        serial,
        publish,
        ..
    } = track::open(&args.settings, &memory_plan(&args))?;
    // Unlike `glint track`, every run reports its status, whatever the source.
    let mut monitor = Monitor::new(args.settings.input.monitor_config());
    let jsonl =
        jsonl.map(|out| BestEffort::new("jsonl", track::jsonl_sink(out, true, &args.settings)));
    let preview = args
        .preview
        .map(|addr| start_preview(addr, &args.settings))
        .transpose()?;
    let mut sink = Tee::new(Tee::new(jsonl, preview), Tee::new(serial, publish));
    let (summary, result) = monitor::run(&mut source, &mut pipeline, &mut sink, &mut monitor);
    let totals = monitor.totals();
    log::info!(
        "stopped after {} frames ({} dropped upstream, {} log lines lost)",
        totals.frames,
        totals.dropped,
        logger::dropped_lines()
    );
    if let Some(stats) = monitor.stats() {
        log::info!("whole run: {}", stats.one_line());
    }
    track::conclude(&summary, result)
}

/// What the run will allocate: the tracking's needs, and the preview's.
fn memory_plan(args: &RunArgs) -> MemoryPlan {
    let mut plan = args.settings.memory_plan();
    if args.preview.is_some() {
        let size = args.settings.size;
        plan.add(
            "the preview",
            format!("--preview, --size {size}"),
            budget::preview_bytes(size),
        );
    }
    plan
}

/// Starts the preview server and says where it is (the address actually bound, for port 0).
fn start_preview(addr: SocketAddr, settings: &TrackSettings) -> Result<PreviewSink> {
    // The calibration was checked when the pipeline was built; here its markers and its camera
    // (for the floor grid) are read.
    let (markers, camera) = match settings.floor.calib.as_deref() {
        Some(path) => {
            let text = small_file::read_text(path, small_file::MAX_SETTINGS_BYTES)
                .with_context(|| format!("calib = {:?}: cannot read it", path.display()))?;
            let camera = CalibrationFile::parse(&text, settings.size)
                .with_context(|| format!("calib = {:?}", path.display()))?
                .floor
                .camera()
                .copied();
            let markers = CalibrationFile::marker_corners_px(&text)
                .with_context(|| format!("calib = {:?}", path.display()))?;
            (markers, camera)
        }
        None => (Vec::new(), None),
    };
    let mut preview = PreviewSink::start(addr, settings.size, markers)
        .with_context(|| format!("preview = \"{addr}\": cannot serve there"))?;
    if let Some(camera) = camera {
        preview = preview.with_floor_camera(camera);
    }
    log::info!("preview on http://{}/", preview.local_addr());
    Ok(preview)
}

/// The files the settings name exist, so a typo stops start-up with the key that holds it.
fn check_files(args: &RunArgs) -> Result<()> {
    let s = &args.settings;
    let named = [
        ("calib", s.floor.calib.as_deref()),
        ("background", s.background.as_deref()),
    ];
    for (key, path) in named {
        if let Some(path) = path {
            check_file(key, path)?;
        }
    }
    if let Some(path) = s.input.dump_path() {
        check_file("input", path)?;
    }
    Ok(())
}

fn check_file(key: &str, path: &Path) -> Result<()> {
    std::fs::metadata(path)
        .map(|_| ())
        .with_context(|| format!("{key} = {:?}: cannot read it", path.display().to_string()))
}

/// The JSON lines output: a file (appended, so a restarted service keeps its history) or
/// standard output.
fn open_jsonl(target: &str) -> Result<BufWriter<Box<dyn Write>>> {
    let out: Box<dyn Write> = if target == "-" {
        Box::new(io::stdout())
    } else {
        let file = OpenOptions::new()
            .create(true)
            .append(true)
            .open(target)
            .with_context(|| format!("jsonl = {target:?}: cannot open it for writing"))?;
        Box::new(file)
    };
    Ok(BufWriter::with_capacity(JSONL_BUFFER_BYTES, out))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_missing_file_is_named_by_its_key() {
        let e = check_file("calib", Path::new("/nonexistent/calib.toml")).unwrap_err();
        let text = format!("{e:#}");
        assert!(
            text.starts_with("calib = \"/nonexistent/calib.toml\""),
            "{text}"
        );
    }

    #[test]
    fn jsonl_is_appended_to() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("out.jsonl");
        std::fs::write(&path, "old\n").unwrap();
        let mut out = open_jsonl(path.to_str().unwrap()).unwrap();
        out.write_all(b"new\n").unwrap();
        out.flush().unwrap();
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "old\nnew\n");
        match open_jsonl("/nonexistent/dir/out.jsonl") {
            Err(e) => assert!(format!("{e:#}").starts_with("jsonl = "), "{e:#}"),
            Ok(_) => panic!("a file in a missing directory opened"),
        }
    }
}
