//! Host-only tools for glint.
//!
//! - [`scene`]: the synthetic scene renderer with exact ground truth that glint's accuracy
//!   tests rely on (also the `glint-scene` binary).
//! - [`markers`]: ArUco marker scenes with exact ground truth, for the marker detector and
//!   floor calibration tests.
//! - [`overlay`]: a frame as a PNG with glint's mask, skeleton and answers and the ground truth
//!   drawn on it (the `glint-view` and `glint-demo` binaries).
//! - [`plot`]: a JSON-lines track as a PNG of the trajectory and the speed over time (the
//!   `glint-plot` binary).
//! - [`stats`]: medians and percentiles of per-frame errors and times.
//! - [`rig`]: the robot-in-the-loop rig (`glint-loop`): a simulated robot, filmed by the
//!   renderer, tracked by `glint run`, steered by the example firmware in qemu.

pub mod markers;
pub mod overlay;
pub mod plot;
pub mod rig;
pub mod scene;
pub mod stats;
