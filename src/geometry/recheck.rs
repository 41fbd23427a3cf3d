//! Staying calibrated: the calibration's markers re-detected while tracking, and the camera's
//! pose refitted (the pose only: the lens stays) when a knock has moved them.
//!
//! Every [`RECHECK_PERIOD_FRAMES`]th frame the marker detector runs on the frame (it allocates
//! nothing after start-up, and costs a couple of milliseconds at 640×480, a small part of one
//! frame period, once in that many frames). The map's markers seen exactly once are compared
//! with where the current pose puts them:
//! - within [`MOVED_RMS_PX`] of the calibration's own residual: the pose is confirmed (its
//!   age restarts);
//! - farther: the pose is refitted to them with the lens held, and taken if the refit fits them
//!   (one log line says so);
//! - none seen: nothing changes (the robot may be standing on them); after
//!   [`STALE_AFTER_CHECKS`] such checks in a row, once markers had been seen in this run, the
//!   floor numbers are marked stale: the camera may have moved where no marker shows.
//!
//! A marker partly covered by the robot is not decoded at all, so occlusion changes nothing.

use super::calibration::MarkerPlacement;
use super::camera::CameraModel;
use super::camera_fit::{fit_camera, LensChoice, MAX_FIT_POINTS};
use super::floor::FloorStage;
use super::homography::Point;
use crate::detect::aruco::{Detector, DetectorConfig, Dictionary, MAX_MARKERS};
use crate::frame::{Frame, FrameSize};

/// Frames between two re-checks (0.5 s at 30 fps: a knock is caught well within a second).
pub const RECHECK_PERIOD_FRAMES: u64 = 15;
/// A pose whose markers are this far off (rms, pixels) has moved: at 640×480 from 1.5 m, one
/// pixel is a few millimetres on the floor, several times a good calibration's residual.
pub const MOVED_RMS_PX: f64 = 1.0;
/// Checks in a row without any marker before the floor numbers are called stale.
pub const STALE_AFTER_CHECKS: u32 = 4;

/// Which calibration a frame's floor numbers come from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CalibStatus {
    /// Seconds since the pose was last confirmed by markers (or since the start of the run).
    pub age_s: f64,
    /// The markers' rms residual at that confirmation (at the start: the file's).
    pub residual_px: f64,
    /// No marker has been seen for a while after markers were seen: the camera may have moved.
    pub stale: bool,
}

/// What a re-check did.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Outcome {
    Nothing,
    Confirmed,
    Refit,
}

/// The re-check's state, allocated once.
pub struct MarkerRecheck {
    detector: Detector,
    map: heapless::Vec<MarkerPlacement, MAX_MARKERS>,
    size: FrameSize,
    confirmed_us: Option<u64>,
    residual_px: f64,
    /// The calibration's own rms residual: markers this far off fit as well as they ever did.
    calibration_px: f64,
    misses: u32,
    seen_any: bool,
    start_us: Option<u64>,
}

impl MarkerRecheck {
    /// A re-check of `map` (the calibration's markers, found with `dictionary`) for frames of
    /// `size`; `residual_px` is the calibration's own rms residual.
    pub fn new(
        size: FrameSize,
        dictionary: Dictionary,
        map: &[MarkerPlacement],
        residual_px: f64,
    ) -> Self {
        let mut kept = heapless::Vec::new();
        for m in map.iter().take(MAX_MARKERS) {
            // Capacity is MAX_MARKERS and at most that many are taken.
            let _ = kept.push(*m);
        }
        MarkerRecheck {
            detector: Detector::new(size, DetectorConfig::new(dictionary)),
            map: kept,
            size,
            confirmed_us: None,
            residual_px,
            calibration_px: if residual_px.is_finite() {
                residual_px
            } else {
                0.0
            },
            misses: 0,
            seen_any: false,
            start_us: None,
        }
    }

    /// Runs the re-check on frame `index` (every [`RECHECK_PERIOD_FRAMES`]th), refitting the
    /// floor stage's pose when the markers moved; returns the calibration's status.
    pub fn check(
        &mut self,
        frame: &Frame<'_>,
        index: u64,
        timestamp_us: u64,
        floor: &mut FloorStage,
    ) -> CalibStatus {
        let start_us = *self.start_us.get_or_insert(timestamp_us);
        if index.is_multiple_of(RECHECK_PERIOD_FRAMES) {
            match self.recheck(frame, floor) {
                Outcome::Nothing => {}
                Outcome::Confirmed | Outcome::Refit => self.confirmed_us = Some(timestamp_us),
            }
        }
        let since = self.confirmed_us.unwrap_or(start_us);
        CalibStatus {
            age_s: timestamp_us.saturating_sub(since) as f64 * 1e-6,
            residual_px: self.residual_px,
            stale: self.seen_any && self.misses >= STALE_AFTER_CHECKS,
        }
    }

    fn recheck(&mut self, frame: &Frame<'_>, floor: &mut FloorStage) -> Outcome {
        let Some(camera) = floor.camera().copied() else {
            return Outcome::Nothing;
        };
        let Ok(seen) = self.detector.detect(frame, None) else {
            return Outcome::Nothing;
        };
        let mut floor_pts: heapless::Vec<Point, MAX_FIT_POINTS> = heapless::Vec::new();
        let mut screen_pts: heapless::Vec<Point, MAX_FIT_POINTS> = heapless::Vec::new();
        for p in &self.map {
            let mut matching = seen.iter().filter(|m| m.id == p.id);
            let (Some(m), None) = (matching.next(), matching.next()) else {
                continue;
            };
            for (f, s) in p.corners().iter().zip(&m.corners) {
                if floor_pts.push(*f).is_err() || screen_pts.push(*s).is_err() {
                    break;
                }
            }
        }
        if floor_pts.is_empty() {
            self.misses = self.misses.saturating_add(1);
            return Outcome::Nothing;
        }
        self.misses = 0;
        self.seen_any = true;
        let current = rms_px(&camera, &floor_pts, &screen_pts);
        let moved_px = self.calibration_px + MOVED_RMS_PX;
        if current <= moved_px {
            self.residual_px = current;
            return Outcome::Confirmed;
        }
        let Ok(fit) = fit_camera(
            &floor_pts,
            &screen_pts,
            self.size,
            LensChoice::Known(camera.lens),
        ) else {
            return Outcome::Nothing;
        };
        if fit.rms_residual_px > moved_px {
            log::warn!(
                "the calibration markers moved ({current:.2} px rms) and no pose fits them \
                 ({:.2} px rms); keeping the pose",
                fit.rms_residual_px
            );
            return Outcome::Nothing;
        }
        let led_height = floor.led_height();
        let refit = FloorStage::from_camera(
            CameraModel {
                lens: camera.lens,
                pose: fit.camera.pose,
            },
            floor.unit(),
        )
        .with_led_height(led_height);
        if let Ok(stage) = refit {
            let moved_cm = (fit.camera.pose.centre() - camera.pose.centre()).norm();
            log::warn!(
                "camera moved: the markers were {current:.2} px off; pose refit from {} corners \
                 ({:.3} px rms, camera centre moved {moved_cm:.1} cm)",
                floor_pts.len(),
                fit.rms_residual_px
            );
            *floor = stage;
            self.residual_px = fit.rms_residual_px;
            return Outcome::Refit;
        }
        Outcome::Nothing
    }
}

/// Rms distance between `screen` and `floor` seen through `camera`.
fn rms_px(camera: &CameraModel, floor: &[Point], screen: &[Point]) -> f64 {
    let mut sum = 0.0;
    for (f, s) in floor.iter().zip(screen) {
        match camera.project(f, 0.0) {
            Ok(q) => sum += (q - s).norm_squared(),
            Err(_) => return f64::INFINITY,
        }
    }
    (sum / floor.len().max(1) as f64).sqrt()
}
