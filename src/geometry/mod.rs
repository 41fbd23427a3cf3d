//! Screen ↔ floor geometry: the homography between the two planes, the ArUco / AprilTag marker
//! detector that finds the points it is fitted from, and the calibration that joins them.

pub mod aruco;
pub mod calibration;
pub mod homography;

pub use calibration::{calibrate, Calibration, CalibrationError, MarkerPlacement};
pub use homography::{FloorMapping, Homography, HomographyError, Point};
