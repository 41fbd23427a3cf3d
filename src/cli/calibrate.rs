//! `glint calibrate`: find ArUco markers at known floor positions in a raw YUYV dump and write
//! the screen ↔ floor calibration as a documented TOML file.
//!
//! Each named marker's corners are averaged over every frame it is seen in (noise falls with
//! the square root of the frame count), then all corners of all named markers are fitted at once.

use std::collections::BTreeSet;
use std::fmt::Write as _;
use std::fs::File;
use std::io::{self, Read};
use std::path::PathBuf;
use std::process::ExitCode;
use std::str::FromStr;

use anyhow::{bail, Context, Result};
use clap::Args;
use nalgebra::Matrix3;

use glint::frame::FrameSize;
use glint::geometry::aruco::{Detector, DetectorConfig, Dictionary, Marker};
use glint::geometry::{calibrate, Calibration, MarkerPlacement, Point};
use glint::source::dump::DumpSource;
use glint::source::FrameSource;

/// Nominal frame rate given to the dump source; calibration does not use timestamps.
const NOMINAL_FPS: f64 = 30.0;

#[derive(Debug, Args)]
pub struct CalibrateArgs {
    /// A raw YUYV dump, or `-` for standard input.
    #[arg(long, value_name = "PATH|-")]
    input: String,

    /// Frame size in pixels.
    #[arg(long, value_name = "WxH")]
    size: FrameSize,

    /// A marker on the floor: its id, the side of its black square in cm, and optionally the
    /// floor position of its printed top-left corner (default 0,0). Repeat for a marker map.
    #[arg(long = "marker", value_name = "ID:SIZE_CM[@X,Y]", required = true)]
    markers: Vec<MarkerArg>,

    /// Marker dictionary (OpenCV's name, e.g. DICT_6X6_250 or APRILTAG_36h11).
    #[arg(long, default_value = "DICT_6X6_250")]
    dict: Dictionary,

    /// Where to write the calibration.
    #[arg(long, value_name = "FILE")]
    out: PathBuf,
}

/// One `--marker ID:SIZE_CM[@X,Y]` argument.
#[derive(Debug, Clone, Copy)]
struct MarkerArg(MarkerPlacement);

impl FromStr for MarkerArg {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        let usage = || format!("{s:?} is not ID:SIZE_CM[@X,Y], e.g. 23:20 or 5:15@120,40");
        let (id_size, at) = match s.split_once('@') {
            Some((a, b)) => (a, Some(b)),
            None => (s, None),
        };
        let (id, size) = id_size.split_once(':').ok_or_else(usage)?;
        let id: u16 = id.trim().parse().map_err(|_| usage())?;
        let size: f64 = size.trim().parse().map_err(|_| usage())?;
        if !(size.is_finite() && size > 0.0) {
            return Err(format!("marker {id}: size {size} cm must be positive"));
        }
        let origin = match at {
            None => Point::new(0.0, 0.0),
            Some(xy) => {
                let (x, y) = xy.split_once(',').ok_or_else(usage)?;
                let x: f64 = x.trim().parse().map_err(|_| usage())?;
                let y: f64 = y.trim().parse().map_err(|_| usage())?;
                if !(x.is_finite() && y.is_finite()) {
                    return Err(usage());
                }
                Point::new(x, y)
            }
        };
        Ok(MarkerArg(MarkerPlacement { id, size, origin }))
    }
}

/// Corner sums of one named marker over the frames it was seen in.
#[derive(Debug, Clone, Copy, Default)]
struct CornerSums {
    sums: [[f64; 2]; 4],
    frames: u32,
}

pub fn run(args: CalibrateArgs) -> Result<ExitCode> {
    let placements: Vec<MarkerPlacement> = args.markers.iter().map(|m| m.0).collect();
    for (i, p) in placements.iter().enumerate() {
        if placements[..i].iter().any(|q| q.id == p.id) {
            bail!("marker {} is named more than once", p.id);
        }
    }
    let reader: Box<dyn Read> = if args.input == "-" {
        Box::new(io::stdin().lock())
    } else {
        let file =
            File::open(&args.input).with_context(|| format!("cannot open {}", args.input))?;
        if file.metadata().map(|m| m.is_dir()).unwrap_or(false) {
            bail!("{} is a directory, not a dump", args.input);
        }
        Box::new(file)
    };
    let mut source = DumpSource::new(reader, args.size, NOMINAL_FPS);
    let mut detector = Detector::new(args.size, DetectorConfig::new(args.dict));
    let mut sums = vec![CornerSums::default(); placements.len()];
    let mut seen_ids = BTreeSet::new();
    let mut frames = 0u64;
    let mut capped_frames = 0u64;
    while let Some((frame, _meta)) = source
        .next_frame()
        .with_context(|| format!("after {frames} whole frames"))?
    {
        frames += 1;
        let markers = detector.detect(&frame, None)?;
        seen_ids.extend(markers.iter().map(|m| m.id));
        for (p, sum) in placements.iter().zip(sums.iter_mut()) {
            let mut matching = markers.iter().filter(|m| m.id == p.id);
            match (matching.next(), matching.next()) {
                (Some(m), None) => {
                    for (s, c) in sum.sums.iter_mut().zip(&m.corners) {
                        s[0] += c.x;
                        s[1] += c.y;
                    }
                    sum.frames += 1;
                }
                (Some(_), Some(_)) => log::warn!(
                    "frame {}: marker {} seen more than once; frame skipped for it",
                    frames - 1,
                    p.id
                ),
                _ => {}
            }
        }
        if detector.stats().capped {
            if capped_frames == 0 {
                log::warn!(
                    "frame {}: marker detection hit its cost cap (a cluttered frame); \
                     part of the frame was not searched",
                    frames - 1
                );
            }
            capped_frames += 1;
        }
    }
    if frames == 0 {
        bail!("{} holds no whole frame of {}", args.input, args.size);
    }
    if capped_frames > 0 {
        log::warn!(
            "marker detection hit its cost cap in {capped_frames} of {frames} frames; \
             markers there may have been missed"
        );
    }
    for (p, sum) in placements.iter().zip(&sums) {
        if sum.frames == 0 {
            let seen: Vec<String> = seen_ids.iter().map(u16::to_string).collect();
            let seen = if seen.is_empty() {
                "no markers at all".to_owned()
            } else {
                format!("markers seen: {}", seen.join(", "))
            };
            bail!(
                "marker {} was not seen in any of {frames} frames with {} ({seen})",
                p.id,
                args.dict
            );
        }
    }
    let averaged: Vec<Marker> = placements
        .iter()
        .zip(&sums)
        .map(|(p, s)| {
            let n = f64::from(s.frames);
            Marker {
                id: p.id,
                corners: s.sums.map(|[x, y]| Point::new(x / n, y / n)),
                corrected_bits: 0,
                refined: true,
            }
        })
        .collect();
    let calibration = calibrate(&averaged, &placements).context("calibration failed")?;
    let report = Report {
        size: args.size,
        dict: args.dict,
        frames,
        placements: &placements,
        sums: &sums,
        averaged: &averaged,
        calibration: &calibration,
    };
    let toml = report.toml()?;
    std::fs::write(&args.out, toml)
        .with_context(|| format!("cannot write {}", args.out.display()))?;
    print!("{}", report.summary()?);
    println!("wrote {}", args.out.display());
    Ok(ExitCode::SUCCESS)
}

/// Everything the calibration file and the printed summary say.
struct Report<'a> {
    size: FrameSize,
    dict: Dictionary,
    frames: u64,
    placements: &'a [MarkerPlacement],
    sums: &'a [CornerSums],
    averaged: &'a [Marker],
    calibration: &'a Calibration,
}

impl Report<'_> {
    /// Reprojection residual of each corner of a marker, pixels.
    fn residuals_px(&self, p: &MarkerPlacement, m: &Marker) -> Result<[f64; 4]> {
        let mut out = [0.0; 4];
        for (k, (f, s)) in p.corners().iter().zip(&m.corners).enumerate() {
            out[k] = (self.calibration.mapping.floor_to_screen(f)? - s).norm();
        }
        Ok(out)
    }

    /// The documented TOML file.
    fn toml(&self) -> Result<String> {
        let c = self.calibration;
        let h = c.mapping.floor_to_screen_homography();
        let inv = h.inverse()?;
        let matrix = |m: &Matrix3<f64>| {
            (0..3)
                .map(|r| format!("[{:?}, {:?}, {:?}]", m[(r, 0)], m[(r, 1)], m[(r, 2)]))
                .collect::<Vec<_>>()
                .join(", ")
        };
        let mut t = String::new();
        writeln!(
            t,
            "# glint floor calibration, written by `glint calibrate`."
        )?;
        writeln!(t, "#")?;
        writeln!(
            t,
            "# Screen coordinates are pixels of the camera image: x to the right, y down,"
        )?;
        writeln!(
            t,
            "# pixel centres at whole numbers (as OpenCV). Floor coordinates are in the"
        )?;
        writeln!(
            t,
            "# units of the marker sizes (cm), on a map of the floor seen from above."
        )?;
        writeln!(t)?;
        writeln!(
            t,
            "# The camera image this calibration belongs to; another size is refused."
        )?;
        writeln!(t, "width_px = {}", self.size.width())?;
        writeln!(t, "height_px = {}", self.size.height())?;
        writeln!(t, "units = \"cm\"")?;
        writeln!(t, "dictionary = \"{}\"", self.dict)?;
        writeln!(
            t,
            "# Frames read; each marker's corners are averaged over the frames it is seen in."
        )?;
        writeln!(t, "frames = {}", self.frames)?;
        writeln!(t)?;
        writeln!(t, "[homography]")?;
        writeln!(
            t,
            "# Row-major 3x3 matrices: [x_px, y_px, w] ~ floor_to_screen * [x_cm, y_cm, 1],"
        )?;
        writeln!(
            t,
            "# and the inverse for screen to floor (divide by the third component)."
        )?;
        writeln!(t, "floor_to_screen = [{}]", matrix(h.matrix()))?;
        writeln!(t, "screen_to_floor = [{}]", matrix(inv.matrix()))?;
        writeln!(t)?;
        writeln!(t, "[residuals]")?;
        writeln!(
            t,
            "# Distances between the detected (averaged) corners and the floor corners mapped"
        )?;
        writeln!(
            t,
            "# to the screen, in pixels. Four corners of one marker fit exactly (zero)."
        )?;
        writeln!(t, "corners = {}", c.corners)?;
        writeln!(t, "rms_px = {:?}", c.rms_residual_px)?;
        writeln!(t, "max_px = {:?}", c.max_residual_px)?;
        for ((p, s), m) in self.placements.iter().zip(self.sums).zip(self.averaged) {
            let corners = m
                .corners
                .iter()
                .map(|q| format!("[{:?}, {:?}]", q.x, q.y))
                .collect::<Vec<_>>()
                .join(", ");
            let residuals = self
                .residuals_px(p, m)?
                .map(|r| format!("{r:?}"))
                .join(", ");
            writeln!(t)?;
            writeln!(t, "[[marker]]")?;
            writeln!(t, "id = {}", p.id)?;
            writeln!(t, "size_cm = {:?}", p.size)?;
            writeln!(
                t,
                "# Floor position of the printed top-left corner; the top edge runs along +x."
            )?;
            writeln!(t, "origin_cm = [{:?}, {:?}]", p.origin.x, p.origin.y)?;
            writeln!(t, "frames_seen = {}", s.frames)?;
            writeln!(
                t,
                "# Top-left, top-right, bottom-right, bottom-left as printed."
            )?;
            writeln!(t, "corners_px = [{corners}]")?;
            writeln!(t, "residuals_px = [{residuals}]")?;
        }
        Ok(t)
    }

    /// The lines printed for a person.
    fn summary(&self) -> Result<String> {
        let mut s = String::new();
        let c = self.calibration;
        writeln!(
            s,
            "calibrated from {} corners of {} marker(s) over {} frames: residual rms {:.3} px, max {:.3} px",
            c.corners,
            self.placements.len(),
            self.frames,
            c.rms_residual_px,
            c.max_residual_px
        )?;
        for ((p, sums), m) in self.placements.iter().zip(self.sums).zip(self.averaged) {
            let r = self.residuals_px(p, m)?;
            writeln!(
                s,
                "  marker {:>4} ({} frames): corner residuals {:.3} {:.3} {:.3} {:.3} px",
                p.id, sums.frames, r[0], r[1], r[2], r[3]
            )?;
        }
        Ok(s)
    }
}
