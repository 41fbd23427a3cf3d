//! `glint fuse`: several cameras' reports merged into one track per robot
//! (`glint::fuse`), from recorded JSON lines (`--input`, one file per camera) or live from the
//! cameras' `--publish` (`--subscribe`, [`super::fuse_live`]).
//!
//! One JSON line per fused time step goes to standard output; bad lines, reports out of
//! order, cameras without floor numbers and the measured clock offsets go to standard error.
//! The fused tracks can also go to the robots, through the sinks `glint track` uses: with
//! `--serial PORT`, glint's position packets (one robot's plain updates; with `--robots N`, a
//! robot position per robot, carrying its id), with `--serial ID=PORT` each robot's own line,
//! with `--mavlink` MAVLink to one autopilot; and with `--publish KEY`, over Zenoh
//! ([`super::fuse_net`]).

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
use glint::fuse::{FuseConfig, FusedStep, Fuser};
use glint::sink::mavlink;
use glint::sink::serial;

use super::fuse_links::RobotLink;
use super::serial_ports::{self, SerialArg};
use super::track::{parse_robots, parse_yaw_offset_deg};
use super::{fuse_net, logger};

/// Most cameras fused.
pub(super) const MAX_CAMERAS: usize = 16;
/// Bad lines reported one by one per camera; the rest are counted.
pub(super) const BAD_LINES_SHOWN: u64 = 5;

#[derive(Debug, Args)]
#[command(group(clap::ArgGroup::new("network").args(["subscribe", "publish"]).multiple(true)))]
pub struct FuseArgs {
    /// Robots followed: ids 1 to N, 1 to 16 as `glint track` follows (the single-LED line is
    /// robot 1).
    #[arg(long, default_value_t = 1, value_name = "N", allow_negative_numbers = true,
          value_parser = parse_robots)]
    pub(super) robots: usize,

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

    /// Publish the fused steps over Zenoh: each step's JSON line under KEY/fused, its
    /// compact binary form under KEY/fused/bin (README: "Several cameras, one arena"). A slow
    /// network drops steps (counted), never the fusing.
    #[arg(long, value_name = "KEY")]
    pub(super) publish: Option<String>,

    /// With --subscribe or --publish (one session serves both): connect to this Zenoh
    /// endpoint (`tcp/HOST:PORT`); repeatable. Any endpoint turns multicast scouting off.
    #[arg(long, value_name = "ENDPOINT", requires = "network")]
    pub(super) zenoh_connect: Vec<String>,

    /// With --subscribe or --publish: listen on this Zenoh endpoint (`tcp/ADDR:PORT`), for the
    /// cameras (and subscribers) to connect to; repeatable. Any endpoint turns multicast
    /// scouting off.
    #[arg(long, value_name = "ENDPOINT", requires = "network")]
    pub(super) zenoh_listen: Vec<String>,

    /// With --subscribe: stop after this many seconds.
    #[arg(long, value_name = "S", requires = "subscribe",
          value_parser = seconds)]
    pub(super) seconds: Option<f64>,

    /// The cameras' picture size, so that a light near a picture's edge counts less (its spot
    /// is cut there). Without it every sighting counts by its uncertainty alone.
    #[arg(long, value_name = "WxH")]
    size: Option<FrameSize>,

    /// Also send the fused tracks to the robots as glint's position packets
    /// (board/protocol/SPEC.md), one update per robot and fused step: `PORT`, one line every
    /// robot listens on (with --robots N, each update a robot position carrying its id), or
    /// `ID=PORT` for robot ID's own line (repeat it per robot).
    #[arg(long, value_name = "PORT|ID=PORT", action = clap::ArgAction::Append,
          value_parser = serial_ports::parse_serial)]
    pub(super) serial: Vec<SerialArg>,

    /// Send MAVLink 2 to an autopilot on --serial instead of glint's packets: robot 1's fused
    /// track as VISION_POSITION_ESTIMATE (covariance from the fused track's uncertainty) and
    /// VISION_SPEED_ESTIMATE, north = floor +x turned by --mavlink-yaw-offset-deg, and a
    /// HEARTBEAT every second.
    #[arg(long, requires = "serial")]
    pub(super) mavlink: bool,

    /// With --mavlink: the compass bearing of floor +x, in degrees clockwise from north.
    #[arg(long, default_value_t = 0.0, value_name = "DEG", allow_negative_numbers = true,
          value_parser = parse_yaw_offset_deg)]
    pub(super) mavlink_yaw_offset_deg: f64,

    /// With --mavlink: the vehicle's MAVLink system id (ArduPilot's SYSID_THISMAV).
    #[arg(long, default_value_t = mavlink::DEFAULT_SYSTEM_ID, value_name = "ID",
          value_parser = clap::value_parser!(u8).range(1..))]
    pub(super) mavlink_system_id: u8,

    /// Line rate of --serial, 8N1: 50 to 4000000 baud.
    #[arg(long, default_value_t = serial::DEFAULT_BAUD, allow_negative_numbers = true,
          value_parser = clap::value_parser!(u32).range(50..=4_000_000))]
    pub(super) baud: u32,
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

/// Where the fused steps go: standard output, the robots, the network.
pub(super) struct Emitter {
    out: BufWriter<io::StdoutLock<'static>>,
    robots: RobotLink,
    publish: Option<fuse_net::Publisher>,
    /// The step's JSON line, written once for standard output and the network.
    line: Vec<u8>,
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
        let first = *self.first_us.get_or_insert(step.t_us);
        self.robots.send(step, self.steps, first);
        self.steps += 1;
        self.line.clear();
        if let Err(e) = write_step(&mut self.line, step, names) {
            self.error.get_or_insert(e);
            return;
        }
        if let Some(publisher) = self.publish.as_mut() {
            fuse_net::publish(publisher, &self.line, step);
        }
        if self.error.is_none() {
            let written = self.out.write_all(&self.line).and_then(|()| {
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

    /// Flushes standard output, lets the links send what is pending, and closes the network.
    fn finish(mut self, network: Option<fuse_net::Network>) -> Result<()> {
        let written = match self.error.take() {
            Some(e) => Err(e),
            None => self.out.flush(),
        };
        let robots = self.robots.finish();
        if let Some(publisher) = self.publish.as_mut() {
            fuse_net::finish(publisher);
        }
        drop(self.publish.take());
        if let Some(network) = network {
            fuse_net::close(network);
        }
        written.context("cannot write the fused tracks")?;
        robots
    }
}

pub fn run(args: FuseArgs) -> Result<ExitCode> {
    let config = FuseConfig {
        robots: u32::try_from(args.robots).unwrap_or(1),
        picture_px: args.size.map(|s| (s.width() as u32, s.height() as u32)),
    };
    let offline = args.subscribe.is_none();
    // Checked before the serial port opens, so that a bad input is the one error.
    let inputs = if offline {
        Some(open_inputs(&args)?)
    } else {
        None
    };
    let robots = RobotLink::open(&args)?;
    let network = fuse_net::open(&args)?;
    let publish = fuse_net::publisher(&args, network.as_ref())?;
    let mut emitter = Emitter {
        out: BufWriter::new(io::stdout().lock()),
        robots,
        publish,
        line: Vec::new(),
        first_us: None,
        steps: 0,
        error: None,
        flush_each: !offline,
    };
    let fused = match (inputs, network.as_ref()) {
        (Some((names, paths, feed)), _) => {
            let mut fuser = Fuser::new(names.len(), config);
            fuse_files(&mut fuser, config, feed, &names, &paths, &mut emitter).map(
                |(bad, refused)| {
                    let origins = paths.iter().map(|p| p.display().to_string()).collect();
                    (fuser, names, origins, bad, refused)
                },
            )
        }
        (None, Some(network)) => live(&args, config, network, &mut emitter),
        (None, None) => Err(anyhow::anyhow!("--subscribe without a network session")),
    };
    let finished = emitter.finish(network);
    let (fuser, names, origins, bad_lines, refused) = fused?;
    finished?;
    summarise(&fuser, &names, &origins, &bad_lines, &refused);
    Ok(ExitCode::SUCCESS)
}

/// `--subscribe`: the fuser, the cameras' names and keys, and their bad and refused lines.
#[cfg(feature = "net")]
fn live(
    args: &FuseArgs,
    config: FuseConfig,
    network: &fuse_net::Network,
    emitter: &mut Emitter,
) -> Result<Fused> {
    super::fuse_live::run(args, config, &network.session, emitter)
}

#[cfg(not(feature = "net"))]
fn live(
    _args: &FuseArgs,
    _config: FuseConfig,
    network: &fuse_net::Network,
    _emitter: &mut Emitter,
) -> Result<Fused> {
    match *network {}
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
