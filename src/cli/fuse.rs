//! `glint fuse`: several cameras' reports merged into one track per robot
//! (`glint::fuse`), from recorded JSON lines (`--input`, one file per camera).
//!
//! One JSON line per fused time step goes to standard output; bad lines, reports out of
//! order, cameras without floor numbers and the measured clock offsets go to standard error.
//! With `--serial`, robot 1's fused track also goes to the robot as glint's position packets,
//! through the serial sink `glint track` uses.

use std::cell::RefCell;
use std::collections::BTreeSet;
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{bail, Context, Result};
use clap::Args;

use glint::frame::FrameSize;
use glint::fuse::feed::FileFeed;
use glint::fuse::offset::WARN_OFFSET_US;
use glint::fuse::output::write_step;
use glint::fuse::{FuseConfig, FusedStep, FusedTrack, Fuser, MAX_ROBOTS};
use glint::geometry::FloorUnit;
use glint::sink::mavlink::estimate::metres_per_unit;
use glint::sink::serial::{self, Located};
use glint::sink::{SerialSink, Sink};
use glint::source::clock::monotonic_now_us;
use glint::source::FrameMeta;
use glint::track::TrackState;
use glint_protocol::Units;

use super::logger;

/// Most cameras fused.
const MAX_CAMERAS: usize = 16;
/// Bad lines reported one by one per camera; the rest are counted.
const BAD_LINES_SHOWN: u64 = 5;

#[derive(Debug, Args)]
pub struct FuseArgs {
    /// Robots followed: ids 1 to N (the single-LED line is robot 1).
    #[arg(long, default_value_t = 1, value_name = "N",
          value_parser = clap::value_parser!(u32).range(1..=i64::from(MAX_ROBOTS)))]
    robots: u32,

    /// One camera's recorded JSON lines (from `glint run` or `glint track` with --calib
    /// against the shared marker map): PATH, or NAME=PATH to name the camera (default: the
    /// file's name without its extension). Repeat for each camera, at most 16.
    #[arg(long = "input", value_name = "[NAME=]PATH", required = true)]
    inputs: Vec<String>,

    /// The cameras' picture size, so that a light near a picture's edge counts less (its spot
    /// is cut there). Without it every sighting counts by its uncertainty alone.
    #[arg(long, value_name = "WxH")]
    size: Option<FrameSize>,

    /// Also send the fused track to the robot on this serial port, as glint's position packets
    /// (board/protocol/SPEC.md), one update per fused step. Robot 1 only, until the packets
    /// carry robot ids (issue 14): needs --robots 1.
    #[arg(long, value_name = "PORT")]
    serial: Option<String>,

    /// Line rate of --serial, 8N1: 50 to 4000000 baud.
    #[arg(long, default_value_t = serial::DEFAULT_BAUD, allow_negative_numbers = true,
          value_parser = clap::value_parser!(u32).range(50..=4_000_000))]
    baud: u32,
}

/// Robot 1's fused track to the serial link: its floor position and velocity in millimetres,
/// stamped with the step's capture time (µs since the first step).
fn send(link: &mut SerialSink, step: &FusedStep, index: u64, first_us: i64) {
    let meta = FrameMeta {
        index,
        sequence: index,
        dropped: 0,
        timestamp_us: u64::try_from(step.t_us.saturating_sub(first_us)).unwrap_or(0),
        // The step was read from a file or a network: its age counts from now.
        monotonic_us: monotonic_now_us(),
    };
    // A line without `floor_unit` (glint's always name it) is taken as glint calibrate's cm.
    let mm = 1000.0 * metres_per_unit(step.unit.unwrap_or(FloorUnit::Cm));
    let located = step
        .tracks
        .first()
        .and_then(|t| Some((t, t.floor?)))
        .map(|(t, p)| Located {
            units: Units::Floor,
            position: ((p.x * mm) as f32, (p.y * mm) as f32),
            velocity_per_s: t.velocity.map(|v| ((v.x * mm) as f32, (v.y * mm) as f32)),
            velocity_method: None,
            quality: quality(t),
        });
    // The heartbeat's tracker state: the fused track is followed while some camera sees it.
    let state = if located.is_some() {
        TrackState::Tracking
    } else {
        TrackState::Searching
    };
    link.send(&meta, located.as_ref(), state);
}

/// The serial link's quality scale (85 found, +85 a head, +85 a velocity), for a fused track.
fn quality(track: &FusedTrack) -> u8 {
    const QUALITY_STEP: u8 = 85;
    let steps = 1 + u8::from(track.head) + u8::from(track.velocity.is_some());
    QUALITY_STEP.saturating_mul(steps)
}

/// A camera's name and file.
fn camera(input: &str) -> (String, PathBuf) {
    match input.split_once('=') {
        Some((name, path)) if !name.is_empty() && !name.contains('/') => {
            (name.to_owned(), PathBuf::from(path))
        }
        _ => {
            let path = PathBuf::from(input);
            let name = Path::new(input)
                .file_stem()
                .map_or_else(|| input.to_owned(), |s| s.to_string_lossy().into_owned());
            (name, path)
        }
    }
}

pub fn run(args: FuseArgs) -> Result<ExitCode> {
    if args.inputs.len() > MAX_CAMERAS {
        bail!(
            "{} --input files, more than the {MAX_CAMERAS} cameras glint fuse takes",
            args.inputs.len()
        );
    }
    let (names, paths): (Vec<String>, Vec<PathBuf>) = args.inputs.iter().map(|i| camera(i)).unzip();
    let mut unique = BTreeSet::new();
    for name in &names {
        if !unique.insert(name) {
            bail!("two cameras are named {name:?}: name them with --input NAME=PATH");
        }
    }
    if args.serial.is_some() && args.robots > 1 {
        bail!(
            "--serial sends one robot's track (its packets carry no robot id yet): use it with \
             --robots 1"
        );
    }
    let mut feed = FileFeed::open(&paths)?;
    let mut link = match &args.serial {
        Some(port) => Some(SerialSink::open(port, args.baud)?),
        None => None,
    };
    let mut first_us: Option<i64> = None;
    let config = FuseConfig {
        robots: args.robots,
        picture_px: args.size.map(|s| (s.width() as u32, s.height() as u32)),
    };
    let mut fuser = Fuser::new(names.len(), config);
    let stdout = io::stdout().lock();
    let mut out = BufWriter::new(stdout);
    // Set by the writer closure, read by the loop that feeds it.
    let write_error: RefCell<Option<io::Error>> = RefCell::new(None);
    let mut bad_lines = vec![0u64; names.len()];
    let mut refused = vec![0u64; names.len()];
    let mut outside = false;
    let mut fuser_steps = 0u64;
    {
        let mut emit = |step: &FusedStep| {
            if let Some(link) = link.as_mut() {
                let first = *first_us.get_or_insert(step.t_us);
                send(link, step, fuser_steps, first);
            }
            fuser_steps += 1;
            let mut failed = write_error.borrow_mut();
            if failed.is_none() {
                if let Err(e) = write_step(&mut out, step, &names) {
                    *failed = Some(e);
                }
            }
        };
        loop {
            let next = feed.next(&mut |bad| {
                if let Some(n) = bad_lines.get_mut(bad.camera) {
                    *n += 1;
                    if *n <= BAD_LINES_SHOWN {
                        log::warn!(
                            "{}:{}: {}, skipped",
                            bad.path.display(),
                            bad.line,
                            bad.error
                        );
                    }
                }
            })?;
            let Some((camera, line, report)) = next else {
                break;
            };
            if let (Some(size), false) = (config.picture_px, outside) {
                let beyond = report
                    .sightings
                    .iter()
                    .filter_map(|s| s.position_px)
                    .any(|p| {
                        !(p.x > -1.0
                            && p.y > -1.0
                            && p.x < f64::from(size.0)
                            && p.y < f64::from(size.1))
                    });
                if beyond {
                    outside = true;
                    log::warn!(
                        "{}:{line}: a position outside --size {}x{}: is --size the cameras' \
                         picture size?",
                        paths
                            .get(camera)
                            .map_or(Path::new("?"), |p| p.as_path())
                            .display(),
                        size.0,
                        size.1
                    );
                }
            }
            if let Err(e) = fuser.push(camera, &report, &mut emit) {
                if let Some(n) = refused.get_mut(camera) {
                    *n += 1;
                    if *n <= BAD_LINES_SHOWN {
                        log::warn!(
                            "{}:{line}: {e}",
                            paths
                                .get(camera)
                                .map_or(Path::new("?"), |p| p.as_path())
                                .display()
                        );
                    }
                }
            }
            if write_error.borrow().is_some() {
                break;
            }
        }
        fuser.finish(&mut emit);
    }
    if let Some(e) = write_error.into_inner() {
        return Err(e).context("cannot write the fused tracks");
    }
    out.flush().context("cannot write the fused tracks")?;
    if let Some(mut link) = link {
        // Lets the writer send what is pending, then logs the link's counts.
        link.finish().context("serial link")?;
    }
    summarise(&fuser, &names, &paths, &bad_lines, &refused);
    Ok(ExitCode::SUCCESS)
}

/// The run's summary on standard error: skipped lines, cameras without floor numbers, and the
/// clock offsets.
fn summarise(fuser: &Fuser, names: &[String], paths: &[PathBuf], bad: &[u64], refused: &[u64]) {
    for (k, name) in names.iter().enumerate() {
        let path = paths
            .get(k)
            .map_or(Path::new("?"), |p| p.as_path())
            .display();
        let (b, r) = (
            bad.get(k).copied().unwrap_or(0),
            refused.get(k).copied().unwrap_or(0),
        );
        if b > 0 || r > 0 {
            log::warn!(
                "camera {name} ({path}): {b} bad lines skipped, {r} reports out of order left out"
            );
        }
        if fuser.uncalibrated(k) {
            log::warn!(
                "camera {name} ({path}) reports positions without floor coordinates: run it \
                 with --calib (a calibration against the shared marker map); its reports were \
                 left out"
            );
        }
    }
    let counts = fuser.counts();
    if counts.other_ids > 0 {
        log::warn!(
            "{} sightings of robot ids above --robots left out",
            counts.other_ids
        );
    }
    if counts.stale > 0 {
        log::warn!(
            "{} sightings with stale floor numbers left out",
            counts.stale
        );
    }
    for o in fuser.offsets() {
        let (a, b) = (
            names.get(o.a).map_or("?", String::as_str),
            names.get(o.b).map_or("?", String::as_str),
        );
        let ms = o.offset_us * 1e-3;
        let line = format_args!(
            "clock offset: camera {b} reads {ms:+.2} ms against camera {a} (from {} sightings \
             where both see a robot moving)",
            o.samples
        );
        if o.offset_us.abs() > WARN_OFFSET_US {
            log::warn!(
                "{line}: more than {:.0} ms, check the clocks' sync (NTP/PTP)",
                WARN_OFFSET_US * 1e-3
            );
        } else {
            logger::write_line(format_args!("glint: {line}"));
        }
    }
    logger::write_line(format_args!(
        "glint: fuse: {} reports from {} cameras, {} fused steps",
        counts.reports,
        names.len(),
        counts.steps
    ));
}
