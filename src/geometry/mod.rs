//! Screen ↔ floor geometry: the homography between the two planes, and the ArUco / AprilTag
//! marker detector that finds the points it is fitted from.

pub mod aruco;
pub mod homography;

pub use homography::{FloorMapping, Homography, HomographyError, Point};
