//! Tracking a robot that carries an ArUco / AprilTag marker instead of an LED (the seed's
//! part II): slower than the LED (the marker must be sharp to decode), but it gives the
//! robot's heading as well as its position.
//!
//! Each frame the marker detector runs on the whole frame; the one marker with the wanted id is
//! the robot. Its centre (where the diagonals cross, exact under perspective) is the position,
//! the direction from its bottom edge to its top edge the heading, and consecutive centres give
//! the velocity.

use core::fmt;

use crate::detect::aruco::{self, DetectorConfig, Dictionary, Marker};
use crate::frame::{Frame, FrameSize};
use crate::geometry::{marker_heading_deg, Point};

use super::{Estimate, PositionMethod, VelocityMethod};

/// Why a marker tracker cannot be built.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MarkerTrackError {
    /// The id is not in the dictionary.
    IdOutOfRange {
        /// The wanted id.
        id: u16,
        /// The dictionary.
        dictionary: Dictionary,
    },
}

impl fmt::Display for MarkerTrackError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            MarkerTrackError::IdOutOfRange { id, dictionary } => write!(
                f,
                "marker id {id} is not in {dictionary}, whose ids are 0..={}",
                dictionary.len().saturating_sub(1)
            ),
        }
    }
}

impl core::error::Error for MarkerTrackError {}

/// The tracked marker in one frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MarkerPose {
    /// Its id.
    pub id: u16,
    /// Top-left, top-right, bottom-right, bottom-left as printed, frame pixels.
    pub corners_px: [Point; 4],
    /// Screen heading ([`marker_heading_deg`]).
    pub heading_deg: f64,
}

/// What the marker tracker found in one frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MarkerFinding {
    /// Position (the centre, also as the middle) and velocity, when the marker was found.
    pub estimate: Option<Estimate>,
    /// The marker's corners and heading, when found.
    pub pose: Option<MarkerPose>,
    /// The id was seen more than once: which one is the robot is unknown, so neither is used.
    pub ambiguous: bool,
    /// Markers of any id decoded in the frame.
    pub markers_seen: usize,
    /// The detector hit its cost cap on this frame (a cluttered frame): part of it was not
    /// searched, so a marker missing here may only have been missed.
    pub markers_capped: bool,
}

/// Finds one marker id frame after frame.
#[derive(Debug)]
pub struct MarkerTracker {
    detector: aruco::Detector,
    id: u16,
    /// Time and centre of the previous frame, when the marker was found in it.
    previous: Option<(u64, Point)>,
}

impl MarkerTracker {
    /// A tracker for marker `id` of `dictionary` in frames of `size`; allocates the detector.
    pub fn new(size: FrameSize, dictionary: Dictionary, id: u16) -> Result<Self, MarkerTrackError> {
        if usize::from(id) >= dictionary.len() {
            return Err(MarkerTrackError::IdOutOfRange { id, dictionary });
        }
        Ok(MarkerTracker {
            detector: aruco::Detector::new(size, DetectorConfig::new(dictionary)),
            id,
            previous: None,
        })
    }

    /// The marker detector, for diagnostics.
    pub fn detector(&self) -> &aruco::Detector {
        &self.detector
    }

    /// Looks for the marker in `frame`, taken at `t_us`.
    pub fn process(&mut self, frame: &Frame<'_>, t_us: u64) -> MarkerFinding {
        let markers = match self.detector.detect(frame, None) {
            Ok(m) => m,
            Err(e) => {
                // Only a frame of the wrong size gets here, which the sources never deliver.
                log::warn!("marker detection skipped: {e}");
                &[]
            }
        };
        let mut matching = markers.iter().filter(|m| m.id == self.id);
        let (found, ambiguous) = match (matching.next(), matching.next()) {
            (Some(m), None) => (Some(*m), false),
            (Some(_), Some(_)) => (None, true),
            _ => (None, false),
        };
        let markers_seen = markers.len();
        let markers_capped = self.detector.stats().capped;
        let Some(marker) = found else {
            self.previous = None;
            return MarkerFinding {
                estimate: None,
                pose: None,
                ambiguous,
                markers_seen,
                markers_capped,
            };
        };
        let centre = marker.centre();
        let velocity = self.previous.and_then(|(t0, c0)| {
            let dt_s = f64::from(super::frame_interval_s(t0, t_us)?);
            let v = (centre - c0) / dt_s;
            Some(((v.x as f32, v.y as f32), VelocityMethod::Frames))
        });
        self.previous = Some((t_us, centre));
        let position = (centre.x as f32, centre.y as f32);
        MarkerFinding {
            estimate: Some(Estimate {
                position_px: position,
                position_method: PositionMethod::Marker,
                mid_px: position,
                velocity_px_s: velocity,
            }),
            pose: Some(pose(&marker)),
            ambiguous: false,
            markers_seen,
            markers_capped,
        }
    }
}

fn pose(m: &Marker) -> MarkerPose {
    MarkerPose {
        id: m.id,
        corners_px: m.corners,
        heading_deg: marker_heading_deg(&m.corners),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_id_outside_the_dictionary_is_refused() {
        let size = FrameSize::new(64, 48).unwrap();
        let err = MarkerTracker::new(size, Dictionary::Aruco4x4_50, 50).unwrap_err();
        assert_eq!(
            err.to_string(),
            "marker id 50 is not in DICT_4X4_50, whose ids are 0..=49"
        );
        assert!(MarkerTracker::new(size, Dictionary::Aruco4x4_50, 49).is_ok());
    }
}
