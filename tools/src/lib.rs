//! Host-only tools for glint.
//!
//! - [`scene`]: the synthetic scene renderer with exact ground truth that glint's accuracy
//!   tests rely on (also the `glint-scene` binary).
//! - [`markers`]: ArUco marker scenes with exact ground truth, for the marker detector and
//!   floor calibration tests.

pub mod markers;
pub mod scene;
