//! `glint fuse`: several cameras' reports merged into one track per robot
//! (`glint::fuse`), from recorded JSON lines (`--input`, one file per camera).
//!
//! One JSON line per fused time step goes to standard output; bad lines, reports out of
//! order, cameras without floor numbers and the measured clock offsets go to standard error.

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
use glint::fuse::{FuseConfig, Fuser, MAX_ROBOTS};

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
    let mut feed = FileFeed::open(&paths)?;
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
    {
        let mut emit = |step: &glint::fuse::FusedStep| {
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
