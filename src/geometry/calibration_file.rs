//! Reading the calibration file that `glint calibrate` writes, for `glint track --calib`.
//!
//! A wrong mapping is worse than none: every floor position and speed would be silently off. So
//! the file is checked from end to end before tracking starts, and each problem is refused with
//! one line naming it:
//! - it parses as TOML and has every field (`width_px`, `height_px`, `units`,
//!   `[homography] floor_to_screen, screen_to_floor`, and at least one `[[marker]]`);
//! - it was made for the frame size being tracked (a homography holds for one image size);
//! - both matrices are finite, non-singular, and inverses of each other;
//! - each marker's recorded corners are inside the frame and its recorded residuals are what
//!   the matrix really gives for them (an edited or mistyped number shows up here);
//! - the marker corners lie on one side of the floor's horizon, which also tells the mapping
//!   which side of the horizon the floor is.

use core::fmt;

use nalgebra::Matrix3;
use serde::Deserialize;

use super::aruco::Dictionary;
use super::calibration::MarkerPlacement;
use super::floor::{FloorStage, FloorUnit};
use super::homography::{FloorMapping, Homography, HomographyError, Point};
use crate::frame::{FrameSize, SizeError};

/// The two matrices must be each other's inverse to this relative precision (they are written
/// with all the digits of an `f64`, so a correct file agrees to about 1e-15).
const INVERSE_TOLERANCE: f64 = 1e-9;
/// A recorded corner residual may differ from the recomputed one by this much (pixels).
const RESIDUAL_TOLERANCE_PX: f64 = 0.01;

/// The file's layout; every field here must be present.
#[derive(Debug, Deserialize)]
struct FileLayout {
    width_px: u32,
    height_px: u32,
    units: String,
    dictionary: Option<String>,
    homography: MatricesLayout,
    #[serde(default)]
    marker: Vec<MarkerLayout>,
}

#[derive(Debug, Deserialize)]
struct MatricesLayout {
    floor_to_screen: [[f64; 3]; 3],
    screen_to_floor: [[f64; 3]; 3],
}

#[derive(Debug, Deserialize)]
struct MarkerLayout {
    id: u16,
    size_cm: f64,
    origin_cm: [f64; 2],
    corners_px: [[f64; 2]; 4],
    residuals_px: [f64; 4],
}

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
                "marker {id}: corner {corner} is {actual_px:.3} px from where the homography \
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
    /// The frame size it was made for (equal to the frames it was checked against).
    pub size: FrameSize,
    /// The dictionary its markers were found with, when recorded.
    pub dictionary: Option<Dictionary>,
    /// The floor stage to put in the pipeline.
    pub floor: FloorStage,
    /// Largest recorded corner residual, pixels.
    pub max_residual_px: f64,
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

    /// Parses and checks `text` (the file's contents) for frames of `frames`.
    pub fn parse(text: &str, frames: FrameSize) -> Result<Self, CalibrationFileError> {
        let layout: FileLayout = toml::from_str(text).map_err(|e| syntax_error(text, &e))?;
        let size = FrameSize::new(layout.width_px, layout.height_px)
            .map_err(CalibrationFileError::BadFrameSize)?;
        if size != frames {
            return Err(CalibrationFileError::OtherFrameSize { file: size, frames });
        }
        let unit: FloorUnit = layout
            .units
            .parse()
            .map_err(|_| CalibrationFileError::UnknownUnits(layout.units.clone()))?;
        let dictionary = match &layout.dictionary {
            Some(name) => Some(
                name.parse::<Dictionary>()
                    .map_err(|_| CalibrationFileError::UnknownDictionary(name.clone()))?,
            ),
            None => None,
        };
        let to_screen = homography(
            &layout.homography.floor_to_screen,
            MatrixName::FloorToScreen,
        )?;
        let to_floor = homography(
            &layout.homography.screen_to_floor,
            MatrixName::ScreenToFloor,
        )?;
        if !inverses(to_screen.matrix(), to_floor.matrix()) {
            return Err(CalibrationFileError::MatricesDisagree);
        }
        if layout.marker.is_empty() {
            return Err(CalibrationFileError::NoMarkers);
        }
        let mut corners = Vec::with_capacity(4 * layout.marker.len());
        let mut max_residual_px: f64 = 0.0;
        for m in &layout.marker {
            check_marker(m, &to_screen, size)?;
            corners.extend(m.corners_px.iter().map(|&[x, y]| Point::new(x, y)));
            max_residual_px = m
                .residuals_px
                .iter()
                .fold(max_residual_px, |a, &r| a.max(r));
        }
        let mapping = FloorMapping::from_floor_to_screen(to_screen, &corners)
            .map_err(CalibrationFileError::Mapping)?;
        let floor = FloorStage::new(mapping, unit).map_err(CalibrationFileError::Mapping)?;
        Ok(CalibrationFile {
            size,
            dictionary,
            floor,
            max_residual_px,
        })
    }
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

/// Checks one marker entry against the frame and the floor→screen matrix.
fn check_marker(
    m: &MarkerLayout,
    to_screen: &Homography,
    size: FrameSize,
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
        let actual_px = to_screen
            .apply(&floor)
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
mod tests {
    use super::*;

    const SIZE: (u32, u32) = (640, 480);

    /// An oblique view of the floor, cm → px.
    fn floor_to_screen() -> Matrix3<f64> {
        Matrix3::new(2.1, 0.3, 320.0, -0.2, 1.4, 240.0, 0.0004, 0.0021, 1.0)
    }

    fn rows(m: &Matrix3<f64>) -> String {
        (0..3)
            .map(|r| format!("[{:?}, {:?}, {:?}]", m[(r, 0)], m[(r, 1)], m[(r, 2)]))
            .collect::<Vec<_>>()
            .join(", ")
    }

    /// A correct file for a 20 cm marker at the floor origin, as `glint calibrate` lays it out.
    fn good_file() -> String {
        let h = Homography::from_matrix(floor_to_screen()).unwrap();
        let inv = h.inverse().unwrap();
        let placement = MarkerPlacement {
            id: 23,
            size: 20.0,
            origin: Point::new(0.0, 0.0),
        };
        let corners: Vec<String> = placement
            .corners()
            .iter()
            .map(|c| {
                let p = h.apply(c).unwrap();
                format!("[{:?}, {:?}]", p.x, p.y)
            })
            .collect();
        format!(
            "# a comment\nwidth_px = {}\nheight_px = {}\nunits = \"cm\"\n\
             dictionary = \"DICT_6X6_250\"\nframes = 1\n\n[homography]\n\
             floor_to_screen = [{}]\nscreen_to_floor = [{}]\n\n[[marker]]\nid = 23\n\
             size_cm = 20.0\norigin_cm = [0.0, 0.0]\ncorners_px = [{}]\n\
             residuals_px = [0.0, 0.0, 0.0, 0.0]\n",
            SIZE.0,
            SIZE.1,
            rows(h.matrix()),
            rows(inv.matrix()),
            corners.join(", ")
        )
    }

    #[test]
    fn the_markers_corners_come_back_for_drawing() {
        let text = good_file();
        assert!(parse(&text).is_ok());
        let markers = CalibrationFile::marker_corners_px(&text).unwrap();
        assert_eq!(markers.len(), 1);
        // The first corner is the marker's floor origin seen through the matrix.
        let h = Homography::from_matrix(floor_to_screen()).unwrap();
        let p = h.apply(&Point::new(0.0, 0.0)).unwrap();
        let (x, y) = markers[0][0];
        assert!((f64::from(x) - p.x).abs() < 1e-3 && (f64::from(y) - p.y).abs() < 1e-3);
        assert!(CalibrationFile::marker_corners_px("not toml [").is_err());
    }

    fn frames() -> FrameSize {
        FrameSize::new(SIZE.0, SIZE.1).unwrap()
    }

    fn parse(text: &str) -> Result<CalibrationFile, CalibrationFileError> {
        CalibrationFile::parse(text, frames())
    }

    #[test]
    fn a_correct_file_maps_like_its_matrix() {
        let c = parse(&good_file()).unwrap();
        assert_eq!(c.size, frames());
        assert_eq!(c.dictionary, Some(Dictionary::Aruco6x6_250));
        assert_eq!(c.floor.unit(), FloorUnit::Cm);
        let truth = Homography::from_matrix(floor_to_screen()).unwrap();
        let floor = Point::new(35.0, -12.0);
        let screen = truth.apply(&floor).unwrap();
        let back = c.floor.mapping().screen_to_floor(&screen).unwrap();
        assert!((back - floor).norm() < 1e-9, "{back:?}");
    }

    #[test]
    fn missing_fields_are_named() {
        let good = good_file();
        for (line_start, field) in [
            ("width_px", "width_px"),
            ("units", "units"),
            ("screen_to_floor", "screen_to_floor"),
            ("residuals_px", "residuals_px"),
        ] {
            let text: String = good
                .lines()
                .filter(|l| !l.starts_with(line_start))
                .map(|l| format!("{l}\n"))
                .collect();
            let err = parse(&text).unwrap_err();
            assert!(
                err.to_string()
                    .contains(&format!("missing field `{field}`")),
                "{field}: {err}"
            );
        }
        let no_markers: String = good.split("[[marker]]").next().unwrap().to_owned();
        assert_eq!(
            parse(&no_markers).unwrap_err(),
            CalibrationFileError::NoMarkers
        );
    }

    #[test]
    fn syntax_errors_carry_their_line() {
        let text = good_file().replacen("units = \"cm\"", "units = cm", 1);
        let err = parse(&text).unwrap_err();
        assert!(
            matches!(err, CalibrationFileError::Syntax { line: Some(4), .. }),
            "{err:?}"
        );
        let err =
            parse(&good_file().replacen("[0.0, 0.0, 0.0, 0.0]", "[0.0, 0.0]", 1)).unwrap_err();
        assert!(err.to_string().contains("residuals_px"), "{err}");
    }

    #[test]
    fn another_frame_size_is_refused() {
        let err = CalibrationFile::parse(&good_file(), FrameSize::new(320, 240).unwrap());
        assert_eq!(
            err.unwrap_err().to_string(),
            "made for 640x480 frames, but the frames are 320x240; calibrate again at 320x240"
        );
        let odd = good_file().replacen("width_px = 640", "width_px = 641", 1);
        assert!(matches!(
            parse(&odd),
            Err(CalibrationFileError::BadFrameSize(SizeError::OddWidth(641)))
        ));
    }

    #[test]
    fn bad_numbers_and_degenerate_matrices_are_refused() {
        let good = good_file();
        let h = Homography::from_matrix(floor_to_screen()).unwrap();
        let f2s = format!("floor_to_screen = [{}]", rows(h.matrix()));
        let s2f = format!(
            "screen_to_floor = [{}]",
            rows(h.inverse().unwrap().matrix())
        );
        // NaN is valid TOML.
        let nan = good.replacen(
            &f2s,
            "floor_to_screen = [[nan, 0.3, 320.0], [-0.2, 1.4, 240.0], [0.0004, 0.0021, 1.0]]",
            1,
        );
        assert_eq!(
            parse(&nan).unwrap_err(),
            CalibrationFileError::NonFinite(MatrixName::FloorToScreen)
        );
        let singular = good.replacen(
            &s2f,
            "screen_to_floor = [[1.0, 2.0, 3.0], [2.0, 4.0, 6.0], [0.0, 0.0, 1.0]]",
            1,
        );
        assert_eq!(
            parse(&singular).unwrap_err(),
            CalibrationFileError::Degenerate(MatrixName::ScreenToFloor, HomographyError::Singular)
        );
        // A plausible matrix that is not the other's inverse (one digit changed).
        let edited = good.replacen("[2.1, 0.3, 320.0]", "[2.1, 0.3, 321.0]", 1);
        assert_eq!(
            parse(&edited).unwrap_err(),
            CalibrationFileError::MatricesDisagree
        );
        let units = good.replacen("units = \"cm\"", "units = \"furlongs\"", 1);
        assert!(parse(&units).unwrap_err().to_string().contains("furlongs"));
        let size = good.replacen("size_cm = 20.0", "size_cm = -20.0", 1);
        assert_eq!(
            parse(&size).unwrap_err(),
            CalibrationFileError::BadMarker { id: 23 }
        );
    }

    #[test]
    fn corners_that_disagree_with_the_matrix_are_refused() {
        // The marker said to be 25 cm: its corners are no longer where the matrix puts them.
        let text = good_file().replacen("size_cm = 20.0", "size_cm = 25.0", 1);
        let err = parse(&text).unwrap_err();
        assert!(
            matches!(
                err,
                CalibrationFileError::ResidualMismatch {
                    id: 23,
                    corner: 1,
                    ..
                }
            ),
            "{err:?}"
        );
        let text = good_file().replacen("corners_px = [[", "corners_px = [[-5", 1);
        assert!(matches!(
            parse(&text),
            Err(CalibrationFileError::CornerOutsideFrame { id: 23, corner: 0 })
        ));
    }
}
