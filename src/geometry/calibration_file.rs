//! Reading the calibration file that `glint calibrate` writes, for `glint track --calib`.
//!
//! A wrong mapping is worse than none: every floor position and speed would be silently off. So
//! the file is checked from end to end before tracking starts, and each problem is refused with
//! one line naming it.
//!
//! **Version 2** (`version = 2`, what this glint writes: a lens, a pose and the marker map).
//! Every field is required: `width_px`, `height_px`, `units`, `frames`, `unseen`, `[lens]`
//! (`fx fy cx cy k1 k2 p1 p2 k3`), `[pose]` (`rotation`, `translation_cm`, `height_cm`),
//! `[residuals]` (`corners`, `rms_px`, `max_px`), and at least one `[[marker]]` (`id`,
//! `size_cm`, `origin_cm`, `corners_px`, `residuals_px`); `dictionary`, `source` and
//! `frames_seen` are for people and optional. Checked: the frame size; `units` is `cm`, as
//! every floor key says (`_cm`); the lens is finite, sane and does not fold over inside the
//! picture; the rotation is a rotation and the camera above the floor, at the height recorded;
//! every corner is inside the frame and its recorded residual is what the lens and pose give;
//! the `[residuals]` summary agrees with the markers'.
//!
//! **Version 1** (no `version` key: files written by earlier glint, still read, as an ideal lens
//! and an LED on the floor). Required: `width_px`, `height_px`, `units`, `[homography]
//! floor_to_screen, screen_to_floor`, and at least one `[[marker]]` as above. Optional, because
//! earlier files may lack them, but checked when present: `frames`, and the `[residuals]`
//! section (`corners`, `rms_px`, `max_px`). Checked: the frame size; `units` is `cm`; both
//! matrices are finite, non-singular, and inverses of each other; each marker's corners are
//! inside the frame and its residuals are what the matrix gives; the corners lie on one side of
//! the floor's horizon, which also tells the mapping which side of the horizon is floor.

use core::fmt;

use nalgebra::{Matrix3, Vector3};
use serde::Deserialize;

use super::calibration::MarkerPlacement;
use super::calibration_record::CALIBRATION_VERSION;
use super::camera::{CameraError, CameraModel, Lens, Pose};
use super::floor::{FloorStage, FloorUnit};
use super::homography::{FloorMapping, Homography, HomographyError, Point};
use crate::detect::aruco::Dictionary;
use crate::frame::{FrameSize, SizeError};

/// The two matrices must be each other's inverse to this relative precision (they are written
/// with all the digits of an `f64`, so a correct file agrees to about 1e-15).
const INVERSE_TOLERANCE: f64 = 1e-9;
/// A recorded corner residual may differ from the recomputed one by this much (pixels).
const RESIDUAL_TOLERANCE_PX: f64 = 0.01;
/// The recorded camera height may differ from the pose's by this much (cm; it is written with
/// all the digits of an `f64`).
const HEIGHT_TOLERANCE_CM: f64 = 1e-6;

/// The file's layout, both versions; which optional parts each version needs is checked in
/// [`CalibrationFile::parse`].
#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct FileLayout {
    version: Option<i64>,
    width_px: u32,
    height_px: u32,
    units: String,
    dictionary: Option<String>,
    frames: Option<u64>,
    unseen: Option<Vec<u16>>,
    homography: Option<MatricesLayout>,
    lens: Option<LensLayout>,
    pose: Option<PoseLayout>,
    residuals: Option<ResidualsLayout>,
    #[serde(default)]
    marker: Vec<MarkerLayout>,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct LensLayout {
    /// Where the lens came from, for people.
    #[serde(rename = "source")]
    _source: Option<String>,
    fx: f64,
    fy: f64,
    cx: f64,
    cy: f64,
    k1: f64,
    k2: f64,
    p1: f64,
    p2: f64,
    k3: f64,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct PoseLayout {
    rotation: [[f64; 3]; 3],
    translation_cm: [f64; 3],
    height_cm: f64,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct ResidualsLayout {
    corners: usize,
    rms_px: f64,
    max_px: f64,
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct MatricesLayout {
    floor_to_screen: [[f64; 3]; 3],
    screen_to_floor: [[f64; 3]; 3],
}

#[derive(Debug, Deserialize)]
#[serde(deny_unknown_fields)]
struct MarkerLayout {
    id: u16,
    size_cm: f64,
    origin_cm: [f64; 2],
    frames_seen: Option<u32>,
    corners_px: [[f64; 2]; 4],
    residuals_px: [f64; 4],
}

/// The floor unit every floor key of the file carries (`size_cm`, `origin_cm`, ...).
const FILE_UNIT: FloorUnit = FloorUnit::Cm;

/// Which of the two matrices.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MatrixName {
    /// `floor_to_screen`.
    FloorToScreen,
    /// `screen_to_floor`.
    ScreenToFloor,
}

impl fmt::Display for MatrixName {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            MatrixName::FloorToScreen => "homography.floor_to_screen",
            MatrixName::ScreenToFloor => "homography.screen_to_floor",
        })
    }
}

/// Why a calibration file cannot be used.
#[derive(Debug, Clone, PartialEq)]
pub enum CalibrationFileError {
    /// Not TOML, or a field is missing or of the wrong type. `line` is 1-based.
    Syntax {
        line: Option<usize>,
        message: String,
    },
    /// The recorded frame size is not a valid frame size.
    BadFrameSize(SizeError),
    /// The file was made for frames of another size.
    OtherFrameSize { file: FrameSize, frames: FrameSize },
    /// `units` is not a known unit.
    UnknownUnits(String),
    /// `units` names another unit than the file's numbers are in.
    UnitsDisagree(FloorUnit),
    /// The version is not one this glint reads.
    Version(i64),
    /// A field the file's version requires is missing.
    Missing(&'static str),
    /// The lens cannot be used.
    Lens(CameraError),
    /// The pose is not a pose (not a rotation, or the camera not above the floor).
    Pose(CameraError),
    /// `[pose] height_cm` is not the height the rotation and translation give.
    HeightMismatch { recorded_cm: f64, actual_cm: f64 },
    /// A marker is said to be seen in more frames than were read.
    FramesSeen { id: u16, seen: u32, frames: u64 },
    /// A `[residuals]` number is not what the markers give.
    SummaryMismatch {
        field: &'static str,
        recorded: f64,
        actual: f64,
    },
    /// `dictionary` is not a known dictionary.
    UnknownDictionary(String),
    /// A matrix entry is NaN or infinite.
    NonFinite(MatrixName),
    /// A matrix cannot be a view of the floor.
    Degenerate(MatrixName, HomographyError),
    /// The two matrices are not inverses of each other.
    MatricesDisagree,
    /// No `[[marker]]` entries: nothing tells which side of the horizon the floor is.
    NoMarkers,
    /// A marker's size or position is not a positive / finite number.
    BadMarker { id: u16 },
    /// A marker's recorded corner is not inside the frame.
    CornerOutsideFrame { id: u16, corner: usize },
    /// A marker's recorded residual is not what the matrix gives.
    ResidualMismatch {
        id: u16,
        corner: usize,
        recorded_px: f64,
        actual_px: f64,
    },
    /// The marker corners do not fit a view of the floor (e.g. on both sides of the horizon).
    Mapping(HomographyError),
}

impl fmt::Display for CalibrationFileError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            CalibrationFileError::Syntax {
                line: Some(line),
                message,
            } => write!(f, "line {line}: {message}"),
            CalibrationFileError::Syntax {
                line: None,
                message,
            } => write!(f, "{message}"),
            CalibrationFileError::BadFrameSize(e) => write!(f, "width_px, height_px: {e}"),
            CalibrationFileError::OtherFrameSize { file, frames } => write!(
                f,
                "made for {file} frames, but the frames are {frames}; calibrate again at {frames}"
            ),
            CalibrationFileError::UnknownUnits(u) => {
                write!(f, "units {u:?}: must be one of mm, cm, m, in")
            }
            CalibrationFileError::UnitsDisagree(u) => write!(
                f,
                "units = \"{u}\", but the file's floor numbers are in cm (size_cm, origin_cm, \
                 translation_cm): units must be \"cm\""
            ),
            CalibrationFileError::Version(v) => write!(
                f,
                "version {v} is not one this glint reads (1 or {CALIBRATION_VERSION}; a newer \
                 glint may have written it)"
            ),
            CalibrationFileError::Missing(field) => write!(f, "missing field `{field}`"),
            CalibrationFileError::Lens(e) => write!(f, "[lens]: {e}"),
            CalibrationFileError::FramesSeen { id, seen, frames } => write!(
                f,
                "marker {id}: frames_seen = {seen}, but only {frames} frames were read"
            ),
            CalibrationFileError::Pose(e) => write!(f, "[pose]: {e}"),
            CalibrationFileError::HeightMismatch {
                recorded_cm,
                actual_cm,
            } => write!(
                f,
                "[pose] height_cm is {recorded_cm} but the rotation and translation put the \
                 camera {actual_cm:.3} cm up (were the numbers edited?)"
            ),
            CalibrationFileError::SummaryMismatch {
                field,
                recorded,
                actual,
            } => write!(
                f,
                "[residuals] {field} is {recorded} but the markers give {actual:.4} (were the \
                 numbers edited?)"
            ),
            CalibrationFileError::UnknownDictionary(d) => write!(f, "dictionary {d:?} is unknown"),
            CalibrationFileError::NonFinite(m) => write!(f, "{m} has a NaN or infinite entry"),
            CalibrationFileError::Degenerate(m, e) => write!(f, "{m}: {e}"),
            CalibrationFileError::MatricesDisagree => write!(
                f,
                "homography.floor_to_screen and homography.screen_to_floor are not inverses of \
                 each other (was one edited?)"
            ),
            CalibrationFileError::NoMarkers => write!(
                f,
                "no [[marker]] entries; their corners tell which side of the horizon is floor"
            ),
            CalibrationFileError::BadMarker { id } => write!(
                f,
                "marker {id}: size_cm must be positive and origin_cm finite"
            ),
            CalibrationFileError::CornerOutsideFrame { id, corner } => write!(
                f,
                "marker {id}: corner {corner} of corners_px is not inside the frame"
            ),
            CalibrationFileError::ResidualMismatch {
                id,
                corner,
                recorded_px,
                actual_px,
            } => write!(
                f,
                "marker {id}: corner {corner} is {actual_px:.3} px from where the calibration \
                 puts it, but the file records {recorded_px:.3} px (were the numbers edited?)"
            ),
            CalibrationFileError::Mapping(e) => write!(f, "the marker corners: {e}"),
        }
    }
}

impl core::error::Error for CalibrationFileError {}

/// A validated calibration.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CalibrationFile {
    /// The file's version (1: a homography only; 2: lens and pose).
    pub version: u32,
    /// The frame size it was made for (equal to the frames it was checked against).
    pub size: FrameSize,
    /// The dictionary its markers were found with, when recorded.
    pub dictionary: Option<Dictionary>,
    /// The floor stage to put in the pipeline.
    pub floor: FloorStage,
    /// Largest recorded corner residual, pixels.
    pub max_residual_px: f64,
    /// Root-mean-square recorded corner residual, pixels.
    pub rms_residual_px: f64,
}

impl CalibrationFile {
    /// The corners (TL, TR, BR, BL, pixels) of the markers a calibration was made from, for
    /// drawing them; `text` should have passed [`CalibrationFile::parse`].
    pub fn marker_corners_px(text: &str) -> Result<Vec<[(f32, f32); 4]>, CalibrationFileError> {
        let layout: FileLayout = toml::from_str(text).map_err(|e| syntax_error(text, &e))?;
        Ok(layout
            .marker
            .iter()
            .map(|m| m.corners_px.map(|[x, y]| (x as f32, y as f32)))
            .collect())
    }

    /// The marker map a calibration was made from; `text` should have passed
    /// [`CalibrationFile::parse`].
    pub fn marker_map(text: &str) -> Result<Vec<MarkerPlacement>, CalibrationFileError> {
        let layout: FileLayout = toml::from_str(text).map_err(|e| syntax_error(text, &e))?;
        Ok(layout
            .marker
            .iter()
            .map(|m| MarkerPlacement {
                id: m.id,
                size: m.size_cm,
                origin: Point::new(m.origin_cm[0], m.origin_cm[1]),
            })
            .collect())
    }

    /// Parses and checks `text` (the file's contents) for frames of `frames`.
    pub fn parse(text: &str, frames: FrameSize) -> Result<Self, CalibrationFileError> {
        let layout: FileLayout = toml::from_str(text).map_err(|e| syntax_error(text, &e))?;
        let version = match layout.version {
            None | Some(1) => 1,
            Some(v) if v == i64::from(CALIBRATION_VERSION) => CALIBRATION_VERSION,
            Some(v) => return Err(CalibrationFileError::Version(v)),
        };
        let size = FrameSize::new(layout.width_px, layout.height_px)
            .map_err(CalibrationFileError::BadFrameSize)?;
        if size != frames {
            return Err(CalibrationFileError::OtherFrameSize { file: size, frames });
        }
        let unit: FloorUnit = layout
            .units
            .parse()
            .map_err(|_| CalibrationFileError::UnknownUnits(layout.units.clone()))?;
        if unit != FILE_UNIT {
            return Err(CalibrationFileError::UnitsDisagree(unit));
        }
        let dictionary = match &layout.dictionary {
            Some(name) => Some(
                name.parse::<Dictionary>()
                    .map_err(|_| CalibrationFileError::UnknownDictionary(name.clone()))?,
            ),
            None => None,
        };
        if version >= 2 {
            for (present, field) in [
                (layout.frames.is_some(), "frames"),
                (layout.unseen.is_some(), "unseen"),
                (layout.lens.is_some(), "lens"),
                (layout.pose.is_some(), "pose"),
                (layout.residuals.is_some(), "residuals"),
            ] {
                if !present {
                    return Err(CalibrationFileError::Missing(field));
                }
            }
        }
        if layout.marker.is_empty() {
            return Err(CalibrationFileError::NoMarkers);
        }
        let floor = match (&layout.lens, &layout.pose, &layout.homography) {
            (Some(lens), Some(pose), _) if version >= 2 => {
                let camera = camera_model(lens, pose, size)?;
                for m in &layout.marker {
                    check_marker(m, size, |f| camera.project(f, 0.0).ok())?;
                }
                FloorStage::from_camera(camera, unit)
            }
            (_, _, Some(matrices)) if version == 1 => {
                homography_stage(matrices, &layout, size, unit)?
            }
            _ => {
                return Err(CalibrationFileError::Missing(if version == 1 {
                    "homography"
                } else {
                    "lens"
                }))
            }
        };
        if let Some(frames) = layout.frames {
            for m in &layout.marker {
                if let Some(seen) = m.frames_seen.filter(|&s| u64::from(s) > frames) {
                    return Err(CalibrationFileError::FramesSeen {
                        id: m.id,
                        seen,
                        frames,
                    });
                }
            }
        }
        if let Some(summary) = &layout.residuals {
            check_summary(summary, &layout.marker)?;
        }
        let max_residual_px = layout
            .marker
            .iter()
            .flat_map(|m| m.residuals_px)
            .fold(0.0f64, f64::max);
        let corners = 4 * layout.marker.len();
        let rms_residual_px = (layout
            .marker
            .iter()
            .flat_map(|m| m.residuals_px)
            .map(|r| r * r)
            .sum::<f64>()
            / corners as f64)
            .sqrt();
        Ok(CalibrationFile {
            version,
            size,
            dictionary,
            floor,
            max_residual_px,
            rms_residual_px,
        })
    }
}

/// The floor stage of a version-1 file: its two matrices, checked against each other and the
/// markers.
fn homography_stage(
    matrices: &MatricesLayout,
    layout: &FileLayout,
    size: FrameSize,
    unit: FloorUnit,
) -> Result<FloorStage, CalibrationFileError> {
    let to_screen = homography(&matrices.floor_to_screen, MatrixName::FloorToScreen)?;
    let to_floor = homography(&matrices.screen_to_floor, MatrixName::ScreenToFloor)?;
    if !inverses(to_screen.matrix(), to_floor.matrix()) {
        return Err(CalibrationFileError::MatricesDisagree);
    }
    let mut corners = Vec::with_capacity(4 * layout.marker.len());
    for m in &layout.marker {
        check_marker(m, size, |f| to_screen.apply(f).ok())?;
        corners.extend(m.corners_px.iter().map(|&[x, y]| Point::new(x, y)));
    }
    let mapping = FloorMapping::from_floor_to_screen(to_screen, &corners)
        .map_err(CalibrationFileError::Mapping)?;
    FloorStage::new(mapping, unit).map_err(CalibrationFileError::Mapping)
}

/// The lens and pose of a version-2 file, checked.
fn camera_model(
    lens: &LensLayout,
    pose: &PoseLayout,
    size: FrameSize,
) -> Result<CameraModel, CalibrationFileError> {
    let lens = Lens {
        fx: lens.fx,
        fy: lens.fy,
        cx: lens.cx,
        cy: lens.cy,
        k1: lens.k1,
        k2: lens.k2,
        p1: lens.p1,
        p2: lens.p2,
        k3: lens.k3,
    };
    lens.check(size).map_err(CalibrationFileError::Lens)?;
    let r = Matrix3::from_fn(|r, c| pose.rotation[r][c]);
    let [tx, ty, tz] = pose.translation_cm;
    let pose_model = Pose::new(r, Vector3::new(tx, ty, tz)).map_err(CalibrationFileError::Pose)?;
    let actual_cm = pose_model.height();
    if actual_cm.is_nan() || actual_cm <= 0.0 {
        return Err(CalibrationFileError::Pose(CameraError::BehindCamera));
    }
    let height_agrees = (pose.height_cm - actual_cm).abs() <= HEIGHT_TOLERANCE_CM;
    if !height_agrees {
        return Err(CalibrationFileError::HeightMismatch {
            recorded_cm: pose.height_cm,
            actual_cm,
        });
    }
    Ok(CameraModel {
        lens,
        pose: pose_model,
    })
}

/// Checks the `[residuals]` summary against the markers' own residuals.
fn check_summary(
    summary: &ResidualsLayout,
    markers: &[MarkerLayout],
) -> Result<(), CalibrationFileError> {
    let all: Vec<f64> = markers.iter().flat_map(|m| m.residuals_px).collect();
    let corners = all.len();
    if summary.corners != corners {
        return Err(CalibrationFileError::SummaryMismatch {
            field: "corners",
            recorded: summary.corners as f64,
            actual: corners as f64,
        });
    }
    let rms = (all.iter().map(|r| r * r).sum::<f64>() / corners.max(1) as f64).sqrt();
    let max = all.iter().copied().fold(0.0f64, f64::max);
    for (field, recorded, actual) in [
        ("rms_px", summary.rms_px, rms),
        ("max_px", summary.max_px, max),
    ] {
        // Written so that NaN is refused too.
        let agrees = (recorded - actual).abs() <= RESIDUAL_TOLERANCE_PX;
        if !agrees {
            return Err(CalibrationFileError::SummaryMismatch {
                field,
                recorded,
                actual,
            });
        }
    }
    Ok(())
}

/// Names the line and, when that line assigns a key, the key of a TOML error: the parser's
/// own rendering is several lines long, with a picture of the line.
fn syntax_error(text: &str, e: &toml::de::Error) -> CalibrationFileError {
    let message = e.message().trim();
    let Some(start) = e.span().map(|s| s.start.min(text.len())) else {
        return CalibrationFileError::Syntax {
            line: None,
            message: message.to_owned(),
        };
    };
    let before = text.get(..start).unwrap_or("");
    let line = 1 + before.matches('\n').count();
    let key = text
        .lines()
        .nth(line - 1)
        .and_then(|l| l.split_once('='))
        .map(|(k, _)| k.trim())
        .filter(|k| {
            !k.is_empty()
                && k.chars()
                    .all(|c| c.is_ascii_alphanumeric() || matches!(c, '_' | '-' | '.'))
        });
    CalibrationFileError::Syntax {
        line: Some(line),
        message: match key {
            Some(k) => format!("{k}: {message}"),
            None => message.to_owned(),
        },
    }
}

fn homography(rows: &[[f64; 3]; 3], name: MatrixName) -> Result<Homography, CalibrationFileError> {
    if rows.iter().flatten().any(|v| !v.is_finite()) {
        return Err(CalibrationFileError::NonFinite(name));
    }
    let m = Matrix3::from_fn(|r, c| rows[r][c]);
    Homography::from_matrix(m).map_err(|e| CalibrationFileError::Degenerate(name, e))
}

/// Whether `a · b` is a multiple of the identity (homographies are defined up to scale).
fn inverses(a: &Matrix3<f64>, b: &Matrix3<f64>) -> bool {
    let a = a / a.norm();
    let b = b / b.norm();
    let product = a * b;
    let scale = product.trace() / 3.0;
    if !scale.is_finite() || scale.abs() < f64::EPSILON {
        return false;
    }
    (product / scale - Matrix3::identity()).amax() <= INVERSE_TOLERANCE
}

/// Checks one marker entry against the frame and the calibration's floor→screen mapping.
fn check_marker(
    m: &MarkerLayout,
    size: FrameSize,
    to_screen: impl Fn(&Point) -> Option<Point>,
) -> Result<(), CalibrationFileError> {
    let placement = MarkerPlacement {
        id: m.id,
        size: m.size_cm,
        origin: Point::new(m.origin_cm[0], m.origin_cm[1]),
    };
    let finite = placement.origin.x.is_finite() && placement.origin.y.is_finite();
    if !(finite && placement.size.is_finite() && placement.size > 0.0) {
        return Err(CalibrationFileError::BadMarker { id: m.id });
    }
    let (max_x, max_y) = (size.width() as f64 - 1.0, size.height() as f64 - 1.0);
    for (corner, ((&[x, y], floor), &recorded_px)) in m
        .corners_px
        .iter()
        .zip(placement.corners())
        .zip(&m.residuals_px)
        .enumerate()
    {
        if !((0.0..=max_x).contains(&x) && (0.0..=max_y).contains(&y)) {
            return Err(CalibrationFileError::CornerOutsideFrame { id: m.id, corner });
        }
        let actual_px = to_screen(&floor)
            .map(|p| (p - Point::new(x, y)).norm())
            .unwrap_or(f64::INFINITY);
        // Written so that a NaN residual is refused too.
        let agrees = (actual_px - recorded_px).abs() <= RESIDUAL_TOLERANCE_PX;
        if !agrees {
            return Err(CalibrationFileError::ResidualMismatch {
                id: m.id,
                corner,
                recorded_px,
                actual_px,
            });
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests;
