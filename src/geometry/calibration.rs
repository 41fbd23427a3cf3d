//! Floor calibration from markers at known floor positions (a marker map).
//!
//! Every corner of every named marker is one correspondence between the floor and the screen.
//! Four corners of one small marker fix the mapping exactly but extrapolate their pixel errors
//! across the floor; corners spread over the floor average the errors and pin the mapping down
//! where the robot actually drives, so all corners of all markers go into one least-squares fit.

use core::fmt;

use super::homography::{FloorMapping, HomographyError, Point};
use crate::detect::aruco::{Marker, MAX_MARKERS};

/// Most correspondences: four corners of each of the most markers a frame reports.
const MAX_POINTS: usize = 4 * MAX_MARKERS;

/// Where a marker lies on the floor.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MarkerPlacement {
    /// The marker's id in the detector's dictionary.
    pub id: u16,
    /// Side of the black square, in floor units (cm in the examples).
    pub size: f64,
    /// Floor position of the printed top-left corner; the printed top edge runs along +x and
    /// the left edge along +y.
    pub origin: Point,
}

impl MarkerPlacement {
    /// Floor corners in OpenCV's order: top-left, top-right, bottom-right, bottom-left.
    pub fn corners(&self) -> [Point; 4] {
        let (o, s) = (self.origin, self.size);
        [
            o,
            Point::new(o.x + s, o.y),
            Point::new(o.x + s, o.y + s),
            Point::new(o.x, o.y + s),
        ]
    }
}

/// A fitted floor mapping and how well it fits its corners.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Calibration {
    /// Screen ↔ floor.
    pub mapping: FloorMapping,
    /// Root-mean-square distance between detected corners and mapped floor corners, pixels.
    pub rms_residual_px: f64,
    /// Largest such distance, pixels.
    pub max_residual_px: f64,
    /// Corners used.
    pub corners: usize,
}

/// Why a calibration could not be made.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CalibrationError {
    /// No marker placements were given.
    NoPlacements,
    /// More placements than a frame can report markers.
    TooManyPlacements { max: usize },
    /// A placement's size is not a positive finite number, or its position not finite.
    BadPlacement { id: u16 },
    /// Two placements name the same marker.
    DuplicatePlacement { id: u16 },
    /// A named marker was not detected.
    MarkerNotSeen { id: u16 },
    /// A named marker was detected more than once: which one is the placed one is unknown.
    MarkerSeenTwice { id: u16 },
    /// The corners do not determine a mapping.
    Homography(HomographyError),
}

impl fmt::Display for CalibrationError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            CalibrationError::NoPlacements => write!(f, "no calibration markers were named"),
            CalibrationError::TooManyPlacements { max } => {
                write!(f, "at most {max} calibration markers are supported")
            }
            CalibrationError::BadPlacement { id } => write!(
                f,
                "marker {id}: size must be a positive number and position finite"
            ),
            CalibrationError::DuplicatePlacement { id } => {
                write!(f, "marker {id} is named more than once")
            }
            CalibrationError::MarkerNotSeen { id } => {
                write!(
                    f,
                    "marker {id} is not visible (or not in the chosen dictionary)"
                )
            }
            CalibrationError::MarkerSeenTwice { id } => write!(
                f,
                "marker {id} is visible more than once; each calibration marker must be unique"
            ),
            CalibrationError::Homography(e) => write!(f, "cannot fit the floor mapping: {e}"),
        }
    }
}

impl core::error::Error for CalibrationError {}

impl From<HomographyError> for CalibrationError {
    fn from(e: HomographyError) -> Self {
        CalibrationError::Homography(e)
    }
}

/// Fits the floor mapping from the detected `seen` markers and the `placements` of the ones to
/// use. Every placed marker must be seen exactly once; other seen markers are ignored.
pub fn calibrate(
    seen: &[Marker],
    placements: &[MarkerPlacement],
) -> Result<Calibration, CalibrationError> {
    if placements.is_empty() {
        return Err(CalibrationError::NoPlacements);
    }
    if placements.len() > MAX_MARKERS {
        return Err(CalibrationError::TooManyPlacements { max: MAX_MARKERS });
    }
    let mut floor: heapless::Vec<Point, MAX_POINTS> = heapless::Vec::new();
    let mut screen: heapless::Vec<Point, MAX_POINTS> = heapless::Vec::new();
    for (i, p) in placements.iter().enumerate() {
        let finite = p.origin.x.is_finite() && p.origin.y.is_finite();
        if !(p.size.is_finite() && p.size > 0.0 && finite) {
            return Err(CalibrationError::BadPlacement { id: p.id });
        }
        if placements[..i].iter().any(|q| q.id == p.id) {
            return Err(CalibrationError::DuplicatePlacement { id: p.id });
        }
        let mut matches = seen.iter().filter(|m| m.id == p.id);
        let marker = matches
            .next()
            .ok_or(CalibrationError::MarkerNotSeen { id: p.id })?;
        if matches.next().is_some() {
            return Err(CalibrationError::MarkerSeenTwice { id: p.id });
        }
        if !marker.refined {
            log::warn!(
                "marker {}: corners are not sub-pixel refined; the mapping will be less accurate",
                p.id
            );
        }
        for (f, s) in p.corners().iter().zip(&marker.corners) {
            // Capacity is 4 × MAX_MARKERS and placements are at most MAX_MARKERS.
            floor
                .push(*f)
                .map_err(|_| CalibrationError::TooManyPlacements { max: MAX_MARKERS })?;
            screen
                .push(*s)
                .map_err(|_| CalibrationError::TooManyPlacements { max: MAX_MARKERS })?;
        }
    }
    let mapping = FloorMapping::fit(&floor, &screen)?;
    let mut sum_sq = 0.0;
    let mut max_px: f64 = 0.0;
    for (f, s) in floor.iter().zip(&screen) {
        let d = (mapping.floor_to_screen(f)? - s).norm();
        sum_sq += d * d;
        max_px = max_px.max(d);
    }
    Ok(Calibration {
        mapping,
        rms_residual_px: (sum_sq / floor.len() as f64).sqrt(),
        max_residual_px: max_px,
        corners: floor.len(),
    })
}
