//! `glint fuse`: several cameras' reports merged into one track per robot
//! (`glint::fuse`), from recorded JSON lines (`--input`, one file per camera) or live from the
//! cameras' `--publish` (`--subscribe`, [`super::fuse_live`]).
//!
//! One JSON line per fused time step goes to standard output; bad lines, reports out of
//! order, cameras without floor numbers and the measured clock offsets go to standard error.
//! With `--serial`, robot 1's fused track also goes to the robot as glint's position packets,
//! through the serial sink `glint track` uses.

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
pub(super) const MAX_CAMERAS: usize = 16;
/// Bad lines reported one by one per camera; the rest are counted.
pub(super) const BAD_LINES_SHOWN: u64 = 5;

#[derive(Debug, Args)]
pub struct FuseArgs {
    /// Robots followed: ids 1 to N (the single-LED line is robot 1).
    #[arg(long, default_value_t = 1, value_name = "N",
          value_parser = clap::value_parser!(u32).range(1..=i64::from(MAX_ROBOTS)))]
    robots: u32,

    /// One camera's recorded JSON lines (from `glint run` or `glint track` with --calib
    /// against the shared marker map): PATH, or NAME=PATH to name the camera (default: the
    /// file's name without its extension). Repeat for each camera, at most 16.
    #[arg(
        long = "input",
        value_name = "[NAME=]PATH",
        required_unless_present = "subscribe",
        conflicts_with = "subscribe"
    )]
    inputs: Vec<String>,

    /// Fuse live instead: subscribe over Zenoh to the JSON lines the cameras publish with
    /// `--publish KEY` (under KEY/CAMERA, at most 16 cameras), timed by their `unix_us`
    /// (the cameras' clocks synced by NTP/PTP). Runs until Ctrl-C, SIGTERM or --seconds.
    #[arg(long, value_name = "KEY")]
    pub(super) subscribe: Option<String>,

    /// With --subscribe: connect to this Zenoh endpoint (`tcp/HOST:PORT`); repeatable. Any
    /// endpoint turns multicast scouting off.
    #[arg(long, value_name = "ENDPOINT", requires = "subscribe")]
    pub(super) zenoh_connect: Vec<String>,

    /// With --subscribe: listen on this Zenoh endpoint (`tcp/ADDR:PORT`), for the cameras to
    /// connect to; repeatable. Any endpoint turns multicast scouting off.
    #[arg(long, value_name = "ENDPOINT", requires = "subscribe")]
    pub(super) zenoh_listen: Vec<String>,

    /// With --subscribe: stop after this many seconds.
    #[arg(long, value_name = "S", requires = "subscribe",
          value_parser = seconds)]
    pub(super) seconds: Option<f64>,

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

/// A positive, finite number of seconds.
fn seconds(text: &str) -> Result<f64, String> {
    match text.parse::<f64>() {
        Ok(s) if s.is_finite() && s > 0.0 && s < 1e9 => Ok(s),
        _ => Err(format!("{text:?} is not a positive number of seconds")),
    }
}

/// Where the fused steps go: standard output, and robot 1's track to the serial link.
pub(super) struct Emitter {
    out: BufWriter<io::StdoutLock<'static>>,
    link: Option<SerialSink>,
    first_us: Option<i64>,
    steps: u64,
    /// The first write error; nothing more is written after it.
    pub(super) error: Option<io::Error>,
    /// Flush every step (live: a reader downstream waits for each).
    flush_each: bool,
}

impl Emitter {
    /// Writes one step; `names` are the cameras' names, by index.
    pub(super) fn emit(&mut self, step: &FusedStep, names: &[String]) {
        if let Some(link) = self.link.as_mut() {
            let first = *self.first_us.get_or_insert(step.t_us);
            send(link, step, self.steps, first);
        }
        self.steps += 1;
        if self.error.is_none() {
            let written = write_step(&mut self.out, step, names).and_then(|()| {
                if self.flush_each {
                    self.out.flush()
                } else {
                    Ok(())
                }
            });
            if let Err(e) = written {
                self.error = Some(e);
            }
        }
    }

    /// Flushes standard output and lets the serial link send what is pending.
    fn finish(mut self) -> Result<()> {
        if let Some(e) = self.error.take() {
            return Err(e).context("cannot write the fused tracks");
        }
        self.out.flush().context("cannot write the fused tracks")?;
        if let Some(mut link) = self.link.take() {
            // Lets the writer send what is pending, then logs the link's counts.
            link.finish().context("serial link")?;
        }
        Ok(())
    }
}

pub fn run(args: FuseArgs) -> Result<ExitCode> {
    if args.serial.is_some() && args.robots > 1 {
        bail!(
            "--serial sends one robot's track (its packets carry no robot id yet): use it with \
             --robots 1"
        );
    }
    let config = FuseConfig {
        robots: args.robots,
        picture_px: args.size.map(|s| (s.width() as u32, s.height() as u32)),
    };
    let offline = args.subscribe.is_none();
    // Checked before the serial port opens, so that a bad input is the one error.
    let inputs = if offline {
        Some(open_inputs(&args)?)
    } else {
        None
    };
    let link = match &args.serial {
        Some(port) => Some(SerialSink::open(port, args.baud)?),
        None => None,
    };
    let mut emitter = Emitter {
        out: BufWriter::new(io::stdout().lock()),
        link,
        first_us: None,
        steps: 0,
        error: None,
        flush_each: !offline,
    };
    let (fuser, names, origins, bad_lines, refused) = match inputs {
        Some((names, paths, feed)) => {
            let mut fuser = Fuser::new(names.len(), config);
            let (bad, refused) =
                fuse_files(&mut fuser, config, feed, &names, &paths, &mut emitter)?;
            let origins = paths.iter().map(|p| p.display().to_string()).collect();
            (fuser, names, origins, bad, refused)
        }
        None => live(&args, config, &mut emitter)?,
    };
    emitter.finish()?;
    summarise(&fuser, &names, &origins, &bad_lines, &refused);
    Ok(ExitCode::SUCCESS)
}

/// `--subscribe`: the fuser, the cameras' names and keys, and their bad and refused lines.
#[cfg(feature = "net")]
fn live(args: &FuseArgs, config: FuseConfig, emitter: &mut Emitter) -> Result<Fused> {
    super::fuse_live::run(args, config, emitter)
}

#[cfg(not(feature = "net"))]
fn live(_args: &FuseArgs, _config: FuseConfig, _emitter: &mut Emitter) -> Result<Fused> {
    bail!("--subscribe needs the network: this glint was built without the `net` feature")
}

/// What a run fused: the fuser, the cameras' names and where each came from, and per camera
/// its bad lines and refused reports.
pub(super) type Fused = (Fuser, Vec<String>, Vec<String>, Vec<u64>, Vec<u64>);

/// The `--input` files: names, paths, and the feed over them.
fn open_inputs(args: &FuseArgs) -> Result<(Vec<String>, Vec<PathBuf>, FileFeed)> {
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
    let feed = FileFeed::open(&paths)?;
    Ok((names, paths, feed))
}

/// Fuses the files' reports in capture-time order; returns per camera the bad lines and the
/// refused reports.
fn fuse_files(
    fuser: &mut Fuser,
    config: FuseConfig,
    mut feed: FileFeed,
    names: &[String],
    paths: &[PathBuf],
    emitter: &mut Emitter,
) -> Result<(Vec<u64>, Vec<u64>)> {
    let mut bad_lines = vec![0u64; names.len()];
    let mut refused = vec![0u64; names.len()];
    let mut outside = false;
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
        if let Err(e) = fuser.push(camera, &report, &mut |step| emitter.emit(step, names)) {
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
        if emitter.error.is_some() {
            break;
        }
    }
    fuser.finish(&mut |step| emitter.emit(step, names));
    Ok((bad_lines, refused))
}

/// The run's summary on standard error: skipped lines, cameras without floor numbers, and the
/// clock offsets.
fn summarise(fuser: &Fuser, names: &[String], origins: &[String], bad: &[u64], refused: &[u64]) {
    for (k, name) in names.iter().enumerate() {
        let path = origins.get(k).map_or("?", String::as_str);
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
