//! Writing the calibration file (version 2): the lens, the camera's pose over the floor and the
//! marker map it was fitted to, with each corner's residual, so that the reader can check the
//! numbers against each other (see [`super::calibration_file`]).

use core::fmt::{self, Write as _};

use super::calibration::MarkerPlacement;
use super::camera::{CameraError, CameraModel};
use super::homography::Point;
use crate::detect::aruco::Dictionary;
use crate::frame::FrameSize;

/// The version this glint writes.
pub const CALIBRATION_VERSION: u32 = 2;

/// One marker of the map that was seen.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RecordedMarker {
    pub placement: MarkerPlacement,
    /// Frames its corners were averaged over.
    pub frames_seen: u32,
    /// Detected corners (averaged), OpenCV's order, pixels.
    pub corners_px: [Point; 4],
}

/// Everything a version-2 calibration file says.
#[derive(Debug, Clone, PartialEq)]
pub struct CalibrationRecord {
    pub size: FrameSize,
    pub dictionary: Dictionary,
    /// Frames read.
    pub frames: u64,
    /// Where the lens came from (`fitted`, `ideal`, or a file), for people.
    pub lens_source: String,
    pub camera: CameraModel,
    pub markers: Vec<RecordedMarker>,
    /// Map markers that were not seen.
    pub unseen: Vec<u16>,
}

/// Why a record cannot be written.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum RecordError {
    /// A marker's corner cannot be projected (behind the camera).
    Projection { id: u16, error: CameraError },
    /// Formatting failed.
    Format,
}

impl fmt::Display for RecordError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RecordError::Projection { id, error } => write!(f, "marker {id}: {error}"),
            RecordError::Format => write!(f, "cannot format the calibration"),
        }
    }
}

impl core::error::Error for RecordError {}

impl From<fmt::Error> for RecordError {
    fn from(_: fmt::Error) -> Self {
        RecordError::Format
    }
}

/// Corner residuals of a marker through a camera, pixels.
pub fn corner_residuals_px(
    camera: &CameraModel,
    placement: &MarkerPlacement,
    corners_px: &[Point; 4],
) -> Result<[f64; 4], CameraError> {
    let mut out = [0.0; 4];
    for (r, (f, s)) in out
        .iter_mut()
        .zip(placement.corners().iter().zip(corners_px))
    {
        *r = (camera.project(f, 0.0)? - s).norm();
    }
    Ok(out)
}

impl CalibrationRecord {
    /// Root-mean-square and largest corner residual, and the corner count.
    pub fn residuals(&self) -> Result<(f64, f64, usize), RecordError> {
        let (mut sum_sq, mut max_px, mut n) = (0.0, 0.0f64, 0usize);
        for m in &self.markers {
            let r = corner_residuals_px(&self.camera, &m.placement, &m.corners_px).map_err(
                |error| RecordError::Projection {
                    id: m.placement.id,
                    error,
                },
            )?;
            for d in r {
                sum_sq += d * d;
                max_px = max_px.max(d);
                n += 1;
            }
        }
        Ok(((sum_sq / n.max(1) as f64).sqrt(), max_px, n))
    }

    /// The documented TOML file.
    pub fn to_toml(&self) -> Result<String, RecordError> {
        let mut t = String::new();
        let (rms_px, max_px, corners) = self.residuals()?;
        let lens = &self.camera.lens;
        let pose = &self.camera.pose;
        let rotation = pose.rotation.matrix();
        let row = |r: usize| {
            format!(
                "[{:?}, {:?}, {:?}]",
                rotation[(r, 0)],
                rotation[(r, 1)],
                rotation[(r, 2)]
            )
        };
        let t_cm = pose.translation;
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
            "# pixel centres at whole numbers (as OpenCV). Floor coordinates are cm on a"
        )?;
        writeln!(
            t,
            "# map of the floor seen from above (x right, y down the map, z into the floor)."
        )?;
        writeln!(
            t,
            "# Every number is checked against the others when the file is read."
        )?;
        writeln!(t, "version = {CALIBRATION_VERSION}")?;
        writeln!(t)?;
        writeln!(
            t,
            "# The camera image this calibration belongs to; another size is refused."
        )?;
        writeln!(t, "width_px = {}", self.size.width())?;
        writeln!(t, "height_px = {}", self.size.height())?;
        writeln!(
            t,
            "# The unit of every floor number (the keys say it too: _cm)."
        )?;
        writeln!(t, "units = \"cm\"")?;
        writeln!(t, "dictionary = \"{}\"", self.dictionary)?;
        writeln!(
            t,
            "# Frames read; each marker's corners are averaged over the frames it is seen in."
        )?;
        writeln!(t, "frames = {}", self.frames)?;
        let unseen: Vec<String> = self.unseen.iter().map(u16::to_string).collect();
        writeln!(t, "# Markers of the map that were not seen (not used).")?;
        writeln!(t, "unseen = [{}]", unseen.join(", "))?;
        writeln!(t)?;
        writeln!(t, "[lens]")?;
        writeln!(
            t,
            "# OpenCV's camera matrix [fx 0 cx; 0 fy cy; 0 0 1] (pixels) and distortion"
        )?;
        writeln!(
            t,
            "# coefficients (k1, k2, p1, p2, k3), as calibrateCamera writes them."
        )?;
        writeln!(t, "source = {:?}", self.lens_source)?;
        for (key, value) in [
            ("fx", lens.fx),
            ("fy", lens.fy),
            ("cx", lens.cx),
            ("cy", lens.cy),
            ("k1", lens.k1),
            ("k2", lens.k2),
            ("p1", lens.p1),
            ("p2", lens.p2),
            ("k3", lens.k3),
        ] {
            writeln!(t, "{key} = {value:?}")?;
        }
        writeln!(t)?;
        writeln!(t, "[pose]")?;
        writeln!(
            t,
            "# Floor to camera: X_cam = rotation * X_floor + translation_cm (camera axes:"
        )?;
        writeln!(t, "# x right, y down the picture, z forward).")?;
        writeln!(t, "rotation = [{}, {}, {}]", row(0), row(1), row(2))?;
        writeln!(
            t,
            "translation_cm = [{:?}, {:?}, {:?}]",
            t_cm.x, t_cm.y, t_cm.z
        )?;
        writeln!(
            t,
            "# The camera's height above the floor, from the two above."
        )?;
        writeln!(t, "height_cm = {:?}", pose.height())?;
        writeln!(t)?;
        writeln!(t, "[residuals]")?;
        writeln!(
            t,
            "# Distances between the detected (averaged) corners and the floor corners seen"
        )?;
        writeln!(t, "# through the lens and pose, in pixels.")?;
        writeln!(t, "corners = {corners}")?;
        writeln!(t, "rms_px = {rms_px:?}")?;
        writeln!(t, "max_px = {max_px:?}")?;
        for m in &self.markers {
            let p = &m.placement;
            let corners = m
                .corners_px
                .iter()
                .map(|q| format!("[{:?}, {:?}]", q.x, q.y))
                .collect::<Vec<_>>()
                .join(", ");
            let residuals = corner_residuals_px(&self.camera, p, &m.corners_px)
                .map_err(|error| RecordError::Projection { id: p.id, error })?
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
            writeln!(t, "frames_seen = {}", m.frames_seen)?;
            writeln!(
                t,
                "# Top-left, top-right, bottom-right, bottom-left as printed."
            )?;
            writeln!(t, "corners_px = [{corners}]")?;
            writeln!(t, "residuals_px = [{residuals}]")?;
        }
        Ok(t)
    }
}
