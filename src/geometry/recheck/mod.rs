//! Staying calibrated: the calibration's markers re-detected while tracking, and the camera's
//! pose refitted (the pose only: the lens stays) when a knock has moved them.
//!
//! Every [`RECHECK_PERIOD_FRAMES`] frames the markers are checked once, the detection spread
//! over the period's first frames so that no frame pays for a whole-frame search (about 4 ms at
//! 640×480, more than the rest of the per-frame path by far): while the markers are where the
//! pose puts them, frame `k` of the period searches only the region around marker `k`'s
//! expected outline (half the marker's size on every side: room for a knock that moves it by
//! that much); after a
//! check that found no marker, the period searches the whole frame in [`SEARCH_BANDS`]
//! overlapping bands of rows instead, one per frame. The detector allocates nothing after
//! start-up. Refining every marker's corners to sub-pixel was most of a check's cost, and a
//! check that confirms the pose does not need it. A marker's corners as the detector traces them
//! are about 0.8 px rms from where the pose puts them, and the centre where their diagonals cross
//! up to 1.2 px (on the knocked renders), too far to tell a pose that holds from one a pixel off;
//! but that offset is the marker's own (the traced outline of a marker the lens bends), the same
//! from check to check while nothing moves. So when a marker's refined corners confirm the pose,
//! its unrefined centre's offset is kept, and later checks compare its unrefined centre, less
//! that offset, with where the pose puts it: a steady marker is not refined. A marker without a
//! kept offset (the first check, after a refit), or one off by more than the calibration's
//! residual plus [`MOVED_RMS_PX`], has its corners refined on the frame it was found in. After
//! the period's last search:
//! - every marker steady: the pose is confirmed (its age restarts), no corner refined;
//! - the refined markers' corners within that bound of where the pose puts them (rms): the pose
//!   is confirmed, and their offsets kept;
//! - farther, and every marker refined (a knock moves them all): the pose is refitted to them with
//!   the lens held, and taken if the refit fits them (one log line says so);
//! - farther, but some markers steady (a knock within the period, or one marker kicked): nothing
//!   changes yet, and the next period refines every marker and decides as above;
//! - none seen: nothing changes (the robot may be standing on them); after
//!   [`STALE_AFTER_CHECKS`] such checks in a row, once markers had been seen in this run, the
//!   floor numbers are marked stale: the camera may have moved where no marker shows.
//!
//! A marker partly covered by the robot is not decoded at all, so occlusion changes nothing.

use nalgebra::Vector2;

use super::calibration::MarkerPlacement;
use super::camera::CameraModel;
use super::camera_fit::{fit_camera, LensChoice, MAX_FIT_POINTS};
use super::floor::FloorStage;
use super::homography::Point;
use crate::detect::aruco::{
    diagonals_cross, Detector, DetectorConfig, Dictionary, Roi, MAX_MARKERS,
};
use crate::frame::{Frame, FrameSize};

/// Frames between two re-checks (0.5 s at 30 fps: a knock is caught well within a second).
pub const RECHECK_PERIOD_FRAMES: u64 = 15;
/// A pose whose markers are this far off (rms, pixels) has moved: at 640×480 from 1.5 m, one
/// pixel is a few millimetres on the floor, several times a good calibration's residual.
pub const MOVED_RMS_PX: f64 = 1.0;
/// Checks in a row without any marker before the floor numbers are called stale.
pub const STALE_AFTER_CHECKS: u32 = 4;
/// Bands of rows a whole-frame search is spread over, one per frame.
pub const SEARCH_BANDS: u64 = 5;
/// Least margin around a marker's expected outline, pixels: the adaptive threshold's largest
/// window (23 px) must fit beside the marker for its edge to be found as in a whole frame.
const MIN_MARGIN_PX: f64 = 16.0;
/// Least overlap of two search bands, pixels, when the map's markers are smaller than this.
const MIN_BAND_OVERLAP_PX: usize = 32;

/// Which calibration a frame's floor numbers come from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CalibStatus {
    /// Seconds since the pose was last confirmed by markers (or since the start of the run).
    pub age_s: f64,
    /// The markers' corners' rms residual when they last confirmed or refitted the pose refined
    /// (at the start: the file's); a confirmation by steady markers alone keeps it.
    pub residual_px: f64,
    /// No marker has been seen for a while after markers were seen: the camera may have moved.
    pub stale: bool,
    /// The camera the floor numbers were mapped through (after a refit, the refitted pose).
    pub camera: Option<CameraModel>,
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
    /// Corners found so far in this period: floor and screen, and the ids they belong to.
    floor_pts: heapless::Vec<Point, MAX_FIT_POINTS>,
    screen_pts: heapless::Vec<Point, MAX_FIT_POINTS>,
    found_ids: heapless::Vec<u16, MAX_MARKERS>,
    /// The last check found no marker: this period searches the whole frame, band by band.
    search_bands: bool,
    /// This period refines every marker's corners (the last check saw some markers move, or
    /// found none).
    refine_all: bool,
    /// Per marker of the map, where its unrefined centre sits from where the pose puts it, as
    /// learned when its refined corners confirmed the pose (cleared by a refit).
    centre_bias_px: [Option<Vector2<f64>>; MAX_MARKERS],
    /// This period's refined markers: their map index and unrefined centre's offset, learned as
    /// their bias if they confirm the pose.
    pending: heapless::Vec<(usize, Vector2<f64>), MAX_MARKERS>,
    /// Checks made, to turn which markers a period searches when there are more than frames.
    checks: u64,
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
            detector: Detector::new(
                size,
                DetectorConfig {
                    // Refined only when a marker looks moved (see `search`).
                    refine: false,
                    ..DetectorConfig::new(dictionary)
                },
            ),
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
            floor_pts: heapless::Vec::new(),
            screen_pts: heapless::Vec::new(),
            found_ids: heapless::Vec::new(),
            search_bands: false,
            refine_all: false,
            centre_bias_px: [None; MAX_MARKERS],
            pending: heapless::Vec::new(),
            checks: 0,
        }
    }

    /// Searches this period makes, one per frame from its first.
    fn searches(&self) -> u64 {
        let n = if self.search_bands {
            SEARCH_BANDS
        } else {
            self.map.len() as u64
        };
        n.clamp(1, RECHECK_PERIOD_FRAMES)
    }

    /// Runs the re-check's share of frame `index` (one search in each of the first frames of
    /// every [`RECHECK_PERIOD_FRAMES`]), refitting the floor stage's pose when the period's
    /// markers moved; returns the calibration's status.
    pub fn check(
        &mut self,
        frame: &Frame<'_>,
        index: u64,
        timestamp_us: u64,
        floor: &mut FloorStage,
    ) -> CalibStatus {
        let start_us = *self.start_us.get_or_insert(timestamp_us);
        let step = index % RECHECK_PERIOD_FRAMES;
        let searches = self.searches();
        if step < searches {
            if step == 0 {
                self.floor_pts.clear();
                self.screen_pts.clear();
                self.found_ids.clear();
                self.pending.clear();
            }
            self.search(frame, step, floor);
            if step + 1 == searches {
                self.checks = self.checks.wrapping_add(1);
                match self.evaluate(floor) {
                    Outcome::Nothing => {}
                    Outcome::Confirmed | Outcome::Refit => self.confirmed_us = Some(timestamp_us),
                }
            }
        }
        let since = self.confirmed_us.unwrap_or(start_us);
        CalibStatus {
            age_s: timestamp_us.saturating_sub(since) as f64 * 1e-6,
            residual_px: self.residual_px,
            stale: self.seen_any && self.misses >= STALE_AFTER_CHECKS,
            camera: floor.camera().copied(),
        }
    }

    /// Search `step` of the period: one marker's region, or one band of rows.
    fn search(&mut self, frame: &Frame<'_>, step: u64, floor: &FloorStage) {
        let Some(camera) = floor.camera().copied() else {
            return;
        };
        let (roi, only) = if self.search_bands {
            (self.band(step, &camera), None)
        } else {
            let n = self.map.len() as u64;
            let turn = self.checks.wrapping_mul(self.searches());
            let Some(&marker) = usize::try_from(turn.wrapping_add(step) % n.max(1))
                .ok()
                .and_then(|i| self.map.get(i))
            else {
                return;
            };
            (marker_region(&camera, &marker), Some(marker.id))
        };
        let Some(roi) = roi else {
            return;
        };
        if self.detector.detect(frame, Some(roi)).is_err() {
            return;
        }
        let moved_px = self.calibration_px + MOVED_RMS_PX;
        for (index, p) in self.map.iter().enumerate() {
            if only.is_some_and(|id| id != p.id) || self.found_ids.contains(&p.id) {
                continue;
            }
            let mut matching = self.detector.markers().iter().filter(|m| m.id == p.id);
            let (Some(&m), None) = (matching.next(), matching.next()) else {
                continue;
            };
            let room = self.floor_pts.capacity() - self.floor_pts.len();
            if room < 4 || self.found_ids.push(p.id).is_err() {
                break;
            }
            // Steady: its unrefined centre where it sat when refined corners last confirmed the
            // pose. Anything else gets sub-pixel corners, for the pose to be judged on them.
            let offset = marker_centre_px(&camera, p).map(|c| m.centre() - c);
            let bias = self.centre_bias_px.get(index).copied().flatten();
            let steady = match (offset, bias) {
                (Some(o), Some(b)) => (o - b).norm() <= moved_px,
                _ => false,
            };
            if steady && !self.refine_all && !self.search_bands {
                continue;
            }
            if let Some(o) = offset {
                // Capacity MAX_MARKERS, one entry per marker of the map.
                let _ = self.pending.push((index, o));
            }
            let corners = self.detector.refine(frame, &m).unwrap_or(m.corners);
            let floor_corners = p.corners();
            for (f, s) in floor_corners.iter().zip(&corners) {
                // Room for four was checked above.
                let _ = self.floor_pts.push(*f);
                let _ = self.screen_pts.push(*s);
            }
        }
    }

    /// Band `step` of [`SEARCH_BANDS`]: full rows, overlapping the next band by the height of
    /// the map's tallest marker as the pose puts it, so that a marker lies wholly in one band.
    fn band(&self, step: u64, camera: &CameraModel) -> Option<Roi> {
        let (w, h) = (self.size.width(), self.size.height());
        let tallest_px = self
            .map
            .iter()
            .filter_map(|m| outline_px(camera, m))
            .map(|(lo, hi)| (hi.y - lo.y).ceil())
            .fold(0.0f64, f64::max);
        // A marker's height plus the threshold's margin on both sides; a float cast saturates.
        let overlap = ((tallest_px + 2.0 * MIN_MARGIN_PX) as usize).max(MIN_BAND_OVERLAP_PX);
        let bands = usize::try_from(SEARCH_BANDS).ok()?;
        let stride = h.div_ceil(bands);
        let top = usize::try_from(step).ok()?.checked_mul(stride)?;
        (top < h).then(|| Roi {
            x_px: 0,
            y_px: top,
            width_px: w,
            height_px: (stride + overlap).min(h - top),
        })
    }

    /// The period's markers against the pose: confirm it, refit it, or count a miss.
    fn evaluate(&mut self, floor: &mut FloorStage) -> Outcome {
        let Some(camera) = floor.camera().copied() else {
            return Outcome::Nothing;
        };
        let found = self.found_ids.len();
        self.search_bands = found == 0;
        if found == 0 {
            self.misses = self.misses.saturating_add(1);
            return Outcome::Nothing;
        }
        self.misses = 0;
        self.seen_any = true;
        self.refine_all = false;
        let (floor_pts, screen_pts) = (&self.floor_pts, &self.screen_pts);
        if floor_pts.is_empty() {
            // Every marker steady by its centre.
            return Outcome::Confirmed;
        }
        let moved_px = self.calibration_px + MOVED_RMS_PX;
        let current = rms_px(&camera, floor_pts, screen_pts);
        if current <= moved_px {
            self.residual_px = current;
            for &(index, offset) in &self.pending {
                if let Some(bias) = self.centre_bias_px.get_mut(index) {
                    *bias = Some(offset);
                }
            }
            return Outcome::Confirmed;
        }
        if floor_pts.len() < 4 * found {
            // The refined markers moved and the steady ones did not: settle it next period, on
            // every marker's refined corners.
            self.refine_all = true;
            return Outcome::Nothing;
        }
        let Ok(fit) = fit_camera(
            floor_pts,
            screen_pts,
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
            // Where each marker's unrefined centre sits is learned again under the new pose.
            self.centre_bias_px = [None; MAX_MARKERS];
            return Outcome::Refit;
        }
        Outcome::Nothing
    }
}

/// The bounding box (least and greatest corner) of `marker`'s outline as `camera` sees it.
fn outline_px(camera: &CameraModel, marker: &MarkerPlacement) -> Option<(Point, Point)> {
    let mut lo = Point::new(f64::INFINITY, f64::INFINITY);
    let mut hi = Point::new(f64::NEG_INFINITY, f64::NEG_INFINITY);
    for c in marker.corners() {
        let p = camera.project(&c, 0.0).ok()?;
        lo = Point::new(lo.x.min(p.x), lo.y.min(p.y));
        hi = Point::new(hi.x.max(p.x), hi.y.max(p.y));
    }
    (lo.x.is_finite() && lo.y.is_finite() && hi.x.is_finite() && hi.y.is_finite())
        .then_some((lo, hi))
}

/// The region searched for `marker`: its expected outline with half its size on every side (at
/// least [`MIN_MARGIN_PX`]), room for a knock that moves it by that much. `None` when
/// it is not in front of the camera; the detector clips the region to the frame and refuses one
/// wholly outside it.
fn marker_region(camera: &CameraModel, marker: &MarkerPlacement) -> Option<Roi> {
    let (lo, hi) = outline_px(camera, marker)?;
    let margin = (0.5 * (hi.x - lo.x).max(hi.y - lo.y)).max(MIN_MARGIN_PX);
    // Float-to-integer casts saturate: a region far off the frame is clipped to nothing.
    let (x0, y0) = ((lo.x - margin).max(0.0), (lo.y - margin).max(0.0));
    let (x1, y1) = (hi.x + margin + 1.0, hi.y + margin + 1.0);
    if x1 <= x0 || y1 <= y0 {
        return None;
    }
    Some(Roi {
        x_px: x0 as usize,
        y_px: y0 as usize,
        width_px: (x1 - x0).ceil() as usize,
        height_px: (y1 - y0).ceil() as usize,
    })
}

/// Where the diagonals of `marker`'s outline cross as `camera` sees it (as the detector finds a
/// marker's centre, so that the lens bends both alike).
fn marker_centre_px(camera: &CameraModel, marker: &MarkerPlacement) -> Option<Point> {
    let mut corners = [Point::origin(); 4];
    for (seen, c) in corners.iter_mut().zip(marker.corners()) {
        *seen = camera.project(&c, 0.0).ok()?;
    }
    Some(diagonals_cross(&corners))
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
