//! `glint calibrate`: find ArUco markers at known floor positions in a raw dump (YUYV, UYVY or
//! a mono camera's GREY), fit the camera (lens and pose over the floor) to them, and write the
//! calibration as a documented TOML file (version 2, see `glint::geometry::calibration_file`).
//!
//! Each named marker's corners are averaged over every frame of a dump it is seen in (noise
//! falls with the square root of the frame count: within one dump the camera and the markers
//! are taken to stay put), then all corners of all seen markers are fitted at once. Markers of
//! the map that this camera does not see are listed and left out.
//!
//! Several dumps (`--input` repeated) are several views of the floor for one lens: a board of
//! markers moved to another part of the picture between them, say, so that the lens is seen
//! bending everywhere. Each view gets its own pose, all share the lens, and the pose written is
//! that of `--floor-view` (the camera's place over the floor it will track).

use std::collections::BTreeSet;
use std::fmt::Write as _;
use std::fs::File;
use std::io::{self, Read, Write as _};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::str::FromStr;

use anyhow::{bail, Context, Result};
use clap::Args;

use glint::budget::{self, MemoryPlan};
use glint::detect::aruco::{Detector, DetectorConfig, Dictionary};
use glint::frame::{FrameSize, PixelFormat};
use glint::geometry::camera_fit::{LENS_UNDETERMINED_PX, LENS_WEAK_PX, MAX_VIEWS};
use glint::geometry::lens_file;
use glint::geometry::{
    fit_camera_views, CalibrationRecord, CameraFit, LensChoice, MarkerPlacement, Point,
    RecordedMarker, ViewCorners,
};
use glint::small_file;
use glint::source::dump::{DumpError, DumpSource};
use glint::source::FrameSource;

use super::input::{sidecar_format, sidecar_of};
use super::memory::MemoryArgs;

/// Nominal frame rate given to the dump source; calibration does not use timestamps.
const NOMINAL_FPS: f64 = 30.0;

#[derive(Debug, Args)]
pub struct CalibrateArgs {
    /// A raw dump (YUYV unless --format-in or its sidecar says otherwise), or `-` for
    /// standard input. Repeat (up to 4) for several views of the
    /// floor fitted with one lens and a pose each: a board of markers moved to other parts of
    /// the picture between them. All views are dumps of --size.
    #[arg(long, value_name = "PATH|-", required = true)]
    input: Vec<String>,

    /// With several --input: the view (1 = the first) whose pose over the floor is written,
    /// and whose markers are the map kept in the calibration: the camera's place for tracking.
    #[arg(long, value_name = "N", default_value_t = 1)]
    floor_view: usize,

    /// Frame size in pixels: sides 1 to 16384, the width even.
    #[arg(long, value_name = "WxH")]
    size: FrameSize,

    /// A marker on the floor: its id, the side of its black square in cm, and optionally the
    /// floor position of its printed top-left corner (default 0,0). Repeat for a marker map.
    #[arg(long = "marker", value_name = "ID:SIZE_CM[@X,Y]", required = true)]
    markers: Vec<MarkerArg>,

    /// Marker dictionary (OpenCV's name, e.g. DICT_6X6_250 or APRILTAG_36h11).
    #[arg(long, default_value = "DICT_6X6_250")]
    dict: Dictionary,

    /// The lens: `fit` it with the pose from the markers (they must spread over the
    /// picture), assume an `ideal` distortion-free one (principal point at the centre), or read
    /// a lens calibrated elsewhere from FILE (OpenCV's camera YAML or ROS's camera_info YAML;
    /// the pose is then fitted alone).
    #[arg(long, value_name = "fit|ideal|FILE", default_value = "fit")]
    lens: LensArg,

    /// Pixel format of the dumps: yuyv, uyvy or grey (8-bit luma, as mono cameras such as
    /// the OV9281 send). Default: the format a dump's sidecar records (`glint record` writes
    /// one), else yuyv.
    #[arg(long, value_name = "yuyv|uyvy|grey")]
    format_in: Option<PixelFormat>,

    /// Where to write the calibration.
    #[arg(long, value_name = "FILE")]
    out: PathBuf,

    #[command(flatten)]
    memory: MemoryArgs,
}

/// The `--lens` argument.
#[derive(Debug, Clone)]
enum LensArg {
    Fit,
    Ideal,
    File(PathBuf),
}

impl FromStr for LensArg {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Ok(match s {
            "fit" => LensArg::Fit,
            "ideal" => LensArg::Ideal,
            "" => return Err("is empty; give fit, ideal or a lens file".to_owned()),
            path => LensArg::File(PathBuf::from(path)),
        })
    }
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

/// What one view (one dump) gives: each named marker's corners averaged over its frames.
struct View {
    frames: u64,
    markers: Vec<RecordedMarker>,
    /// Named markers not seen in this view.
    unseen: Vec<u16>,
    /// Every marker id detected, named or not.
    seen_ids: BTreeSet<u16>,
}

/// The views, for the summary.
struct Views<'a> {
    /// 1-based.
    floor_view: usize,
    each: &'a [String],
}

/// The pixel format of view `input`: `--format-in` when given, else what the dump's sidecar
/// records, else YUYV. A sidecar that contradicts `--format-in`, or one that does not fit its
/// dump, is refused, as `glint track` refuses it.
fn view_format(input: &str, size: FrameSize, given: Option<PixelFormat>) -> Result<PixelFormat> {
    // Standard input has no sidecar, and a missing dump is reported when it is opened.
    let dump_bytes = (input != "-")
        .then(|| Path::new(input).metadata().ok())
        .flatten()
        .filter(|m| m.is_file())
        .map(|m| m.len());
    let sidecar = match dump_bytes {
        Some(dump_bytes) => sidecar_of(Path::new(input), size, dump_bytes)?,
        None => None,
    };
    match sidecar {
        Some(sidecar) => sidecar_format(input, &sidecar, given),
        None => Ok(given.unwrap_or_default()),
    }
}

/// Opens a dump for reading: `-` is standard input; a regular file's length must be a whole
/// number of `format` frames of `size`, or it is a dump of another size or format (or a cut
/// one).
fn open_dump(input: &str, size: FrameSize, format: PixelFormat) -> Result<Box<dyn Read>> {
    if input == "-" {
        return Ok(Box::new(io::stdin().lock()));
    }
    let file = File::open(input).with_context(|| format!("cannot open {input}"))?;
    let meta = file.metadata().ok();
    if meta.as_ref().is_some_and(|m| m.is_dir()) {
        bail!("{input} is a directory, not a dump");
    }
    let frame_bytes = size.frame_bytes_as(format) as u64;
    if let Some(len) = meta.filter(|m| m.is_file()).map(|m| m.len()) {
        if len > 0 && frame_bytes > 0 && len % frame_bytes != 0 {
            bail!(
                "{input}: {len} bytes is not a whole number of {size} frames ({frame_bytes} \
                 bytes each as {format}); every view must be a dump of --size {size}"
            );
        }
    }
    Ok(Box::new(file))
}

/// Reads one view: detects the markers in every frame of the dump and averages each named
/// marker's corners over the frames it is seen in.
fn read_view(
    input: &str,
    size: FrameSize,
    format_in: Option<PixelFormat>,
    detector: &mut Detector,
    placements: &[MarkerPlacement],
) -> Result<View> {
    let format = view_format(input, size, format_in)?;
    let mut source =
        DumpSource::try_with_format(open_dump(input, size, format)?, size, NOMINAL_FPS, format)?;
    let mut sums = vec![CornerSums::default(); placements.len()];
    let mut seen_ids = BTreeSet::new();
    let mut frames = 0u64;
    let mut capped_frames = 0u64;
    loop {
        let (frame, _meta) = match source.next_frame() {
            Ok(Some(next)) => next,
            Ok(None) => break,
            Err(DumpError::Empty) => {
                bail!("{input} holds no whole frame of {size}")
            }
            Err(e) => return Err(e).with_context(|| format!("after {frames} whole frames")),
        };
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
                    "{input}, frame {}: marker {} seen more than once; frame skipped for it",
                    frames - 1,
                    p.id
                ),
                _ => {}
            }
        }
        if detector.stats().capped {
            if capped_frames == 0 {
                log::warn!(
                    "{input}, frame {}: marker detection hit its cost cap (a cluttered frame); \
                     part of the frame was not searched",
                    frames - 1
                );
            }
            capped_frames += 1;
        }
    }
    if capped_frames > 0 {
        log::warn!(
            "{input}: marker detection hit its cost cap in {capped_frames} of {frames} frames; \
             markers there may have been missed"
        );
    }
    let mut markers = Vec::new();
    let mut unseen = Vec::new();
    for (p, s) in placements.iter().zip(&sums) {
        if s.frames == 0 {
            unseen.push(p.id);
            continue;
        }
        let n = f64::from(s.frames);
        markers.push(RecordedMarker {
            placement: *p,
            frames_seen: s.frames,
            corners_px: s.sums.map(|[x, y]| Point::new(x / n, y / n)),
        });
    }
    Ok(View {
        frames,
        markers,
        unseen,
        seen_ids,
    })
}

/// Reads a lens file (OpenCV's or ROS's camera YAML): a regular file only, opened without
/// waiting (a FIFO is refused rather than waited on), and of at most the parser's size cap, so
/// that a device or a huge file is refused rather than read whole.
fn read_lens(path: &std::path::Path, size: FrameSize) -> Result<glint::geometry::Lens> {
    let text = small_file::read_text(path, lens_file::MAX_LENS_FILE_BYTES as u64)
        .with_context(|| format!("lens {}", path.display()))?;
    lens_file::parse(&text, size).with_context(|| format!("lens {}", path.display()))
}

/// Refuses a map whose markers share floor (their paper squares overlap).
fn check_overlaps(placements: &[MarkerPlacement]) -> Result<()> {
    for (i, a) in placements.iter().enumerate() {
        for b in &placements[..i] {
            let apart_x = a.origin.x >= b.origin.x + b.size || b.origin.x >= a.origin.x + a.size;
            let apart_y = a.origin.y >= b.origin.y + b.size || b.origin.y >= a.origin.y + a.size;
            if !(apart_x || apart_y) {
                bail!(
                    "markers {} and {} overlap on the map ({}:{}@{},{} and {}:{}@{},{}); \
                     check their positions",
                    b.id,
                    a.id,
                    b.id,
                    b.size,
                    b.origin.x,
                    b.origin.y,
                    a.id,
                    a.size,
                    a.origin.x,
                    a.origin.y
                );
            }
        }
    }
    Ok(())
}

pub fn run(args: CalibrateArgs) -> Result<ExitCode> {
    let placements: Vec<MarkerPlacement> = args.markers.iter().map(|m| m.0).collect();
    for (i, p) in placements.iter().enumerate() {
        if placements[..i].iter().any(|q| q.id == p.id) {
            bail!("marker {} is named more than once", p.id);
        }
    }
    let config = DetectorConfig::new(args.dict);
    let mut plan = MemoryPlan::new();
    let size = args.size;
    plan.add(
        "the frame buffer",
        format!("--size {size}"),
        budget::frame_bytes(size),
    );
    plan.add(
        "the marker detector",
        format!("--size {size}"),
        budget::marker_detector_bytes(size, config.max_perimeter_px),
    );
    args.memory.check(&plan)?;
    check_overlaps(&placements)?;
    let (choice, lens_source) = match &args.lens {
        LensArg::Fit => (LensChoice::Fit, "fitted".to_owned()),
        LensArg::Ideal => (LensChoice::Ideal, "ideal".to_owned()),
        LensArg::File(path) => {
            let lens = read_lens(path, args.size)?;
            (LensChoice::Known(lens), path.display().to_string())
        }
    };
    let count = args.input.len();
    if count > MAX_VIEWS {
        bail!("{count} --input views: at most {MAX_VIEWS} are fitted together");
    }
    if args.input.iter().filter(|i| *i == "-").count() > 1 {
        bail!("standard input (-) can be only one of the views");
    }
    if !(1..=count).contains(&args.floor_view) {
        bail!(
            "--floor-view {}: there are {count} view(s), numbered from 1",
            args.floor_view
        );
    }
    let mut detector = Detector::new(args.size, config);
    let mut views = Vec::with_capacity(count);
    for (i, input) in args.input.iter().enumerate() {
        // Name the view only when there are several: one dump reads as it always has.
        let name = (count > 1).then(|| format!("view {} ({input})", i + 1));
        let read = read_view(input, args.size, args.format_in, &mut detector, &placements);
        let view = match &name {
            Some(name) => read.with_context(|| name.clone())?,
            None => read?,
        };
        if view.markers.is_empty() {
            let seen: Vec<String> = view.seen_ids.iter().map(u16::to_string).collect();
            let seen = if seen.is_empty() {
                "no markers at all".to_owned()
            } else {
                format!("markers seen: {}", seen.join(", "))
            };
            let prefix = name.map(|n| format!("{n}: ")).unwrap_or_default();
            bail!(
                "{prefix}none of the named markers was seen in any of {} frames with {} ({seen})",
                view.frames,
                args.dict
            );
        }
        views.push(view);
    }
    let corners: Vec<(Vec<Point>, Vec<Point>)> = views
        .iter()
        .map(|v| {
            v.markers
                .iter()
                .flat_map(|m| m.placement.corners().into_iter().zip(m.corners_px))
                .unzip()
        })
        .collect();
    let view_corners: Vec<ViewCorners> = corners
        .iter()
        .map(|(floor, screen)| ViewCorners { floor, screen })
        .collect();
    let floor_view = args.floor_view - 1;
    let fit = fit_camera_views(&view_corners, floor_view, args.size, choice)
        .context("calibration failed")?;
    if matches!(args.lens, LensArg::Fit) && !fit.determined() {
        let regions: Vec<&str> = fit.regions_above(LENS_UNDETERMINED_PX).collect();
        let over = if count > 1 {
            format!(" of {count} views")
        } else {
            String::new()
        };
        bail!(
            "the markers{over} do not determine the lens: the mapping is uncertain by up to \
             {:.1} px in the {} of the picture; put markers there (the lens shows most near the \
             edges and corners), or pass --lens ideal to assume a distortion-free lens",
            fit.picture_uncertainty_px,
            regions.join(", ")
        );
    }
    let frames = views.iter().map(|v| v.frames).sum();
    let view_summary = views
        .iter()
        .zip(&corners)
        .map(|(v, (floor, _))| format!("{} corners over {} frames", floor.len(), v.frames))
        .collect::<Vec<_>>();
    let Some(floor) = views.into_iter().nth(floor_view) else {
        bail!("--floor-view {}: no such view", args.floor_view);
    };
    let record = CalibrationRecord {
        size: args.size,
        dictionary: args.dict,
        frames,
        lens_source,
        camera: fit.camera,
        markers: floor.markers,
        unseen: floor.unseen,
    };
    let toml = record.to_toml()?;
    std::fs::write(&args.out, toml)
        .with_context(|| format!("cannot write {}", args.out.display()))?;
    // The file is written; a closed or full standard output is not worth a panic.
    let mut stdout = io::stdout().lock();
    let views = (count > 1).then_some(Views {
        floor_view: args.floor_view,
        each: &view_summary,
    });
    write!(stdout, "{}", summary(&record, &fit, views)?)
        .and_then(|()| writeln!(stdout, "wrote {}", args.out.display()))
        .context("writing the summary to standard output")?;
    Ok(ExitCode::SUCCESS)
}

/// The lines printed for a person.
fn summary(record: &CalibrationRecord, fit: &CameraFit, views: Option<Views>) -> Result<String> {
    let mut s = String::new();
    let lens = &fit.camera.lens;
    match views {
        None => writeln!(
            s,
            "calibrated from {} corners of {} marker(s) over {} frames: residual rms {:.3} px, max {:.3} px",
            fit.corners,
            record.markers.len(),
            record.frames,
            fit.rms_residual_px,
            fit.max_residual_px
        )?,
        Some(views) => {
            writeln!(
                s,
                "calibrated from {} corners in {} views over {} frames: residual rms {:.3} px, max {:.3} px",
                fit.corners,
                fit.views,
                record.frames,
                fit.rms_residual_px,
                fit.max_residual_px
            )?;
            for (i, each) in views.each.iter().enumerate() {
                let floor = if i + 1 == views.floor_view {
                    " (the floor pose written)"
                } else {
                    ""
                };
                writeln!(s, "  view {}: {each}{floor}", i + 1)?;
            }
            writeln!(
                s,
                "  the map kept is the floor view's {} marker(s) (their residuals below)",
                record.markers.len()
            )?;
        }
    }
    if !record.unseen.is_empty() {
        let ids: Vec<String> = record.unseen.iter().map(u16::to_string).collect();
        writeln!(s, "  not seen (left out): marker {}", ids.join(", "))?;
    }
    writeln!(
        s,
        "  lens ({}): fx {:.1} fy {:.1} cx {:.1} cy {:.1} px, k1 {:.4} k2 {:.4} p1 {:.5} p2 {:.5} k3 {:.4}",
        record.lens_source, lens.fx, lens.fy, lens.cx, lens.cy, lens.k1, lens.k2, lens.p1, lens.p2, lens.k3
    )?;
    writeln!(
        s,
        "  camera {:.1} cm above the floor",
        fit.camera.pose.height()
    )?;
    writeln!(
        s,
        "  expected floor error (1 sigma, corner noise {:.3} px): up to {:.1} mm over the markers' area, {:.1} mm over the whole picture; mapping uncertain by up to {:.2} px",
        fit.noise_px,
        10.0 * fit.markers_area_uncertainty,
        10.0 * fit.picture_uncertainty,
        fit.picture_uncertainty_px
    )?;
    let weak: Vec<&str> = fit.regions_above(LENS_WEAK_PX).collect();
    if !weak.is_empty() {
        writeln!(
            s,
            "  more markers in the {} of the picture would pin the lens down better",
            weak.join(", ")
        )?;
    }
    for m in &record.markers {
        let r = glint::geometry::calibration_record::corner_residuals_px(
            &fit.camera,
            &m.placement,
            &m.corners_px,
        )?;
        writeln!(
            s,
            "  marker {:>4} ({} frames): corner residuals {:.3} {:.3} {:.3} {:.3} px",
            m.placement.id, m.frames_seen, r[0], r[1], r[2], r[3]
        )?;
    }
    Ok(s)
}
