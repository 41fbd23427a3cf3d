//! Screen ↔ floor geometry: the homography between the two planes, the calibration that joins
//! them from markers found by [`crate::detect::aruco`] (and its file), and the floor stage that
//! maps each frame's estimate onto the floor.

pub mod calibration;
pub mod calibration_file;
pub mod calibration_record;
pub mod camera;
pub mod camera_fit;
pub mod floor;
pub mod floor_grid;
pub mod heading;
pub mod homography;
pub mod lens_file;
pub mod recheck;

pub use calibration::{calibrate, Calibration, CalibrationError, MarkerPlacement};
pub use calibration_file::{CalibrationFile, CalibrationFileError};
pub use calibration_record::{CalibrationRecord, RecordedMarker, CALIBRATION_VERSION};
pub use camera::{CameraError, CameraModel, Lens, Pose};
pub use camera_fit::{
    fit_camera, fit_camera_views, CameraFit, CameraFitError, LensChoice, ViewCorners,
};
pub use floor::{FloorEstimate, FloorFix, FloorStage, FloorUnit, NeedsCameraPose};
pub use heading::marker_heading_deg;
pub use homography::{FloorMapping, Homography, HomographyError, Point};
