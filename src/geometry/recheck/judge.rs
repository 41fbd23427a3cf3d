//! One check of the calibration's markers, on one frame's copy (on the re-check's worker
//! thread): find each marker around where the pose puts it, and judge, marker by marker,
//! whether it is where the pose puts it.
//!
//! A marker's corners as the detector traces them are about 0.8 px rms from where the pose puts
//! them, and the centre where their diagonals cross up to 1.2 px (on the knocked renders): too
//! far to tell a pose that holds from one a pixel off. But that offset is the marker's own (the
//! traced outline of a marker the lens bends), the same from check to check while nothing
//! moves. So when a marker's refined corners confirm the pose, its unrefined centre's offset is
//! kept, and later checks compare its unrefined centre, less that offset, with where the pose
//! puts it: a steady marker is not refined (refining every marker was most of a check's cost).
//! Any other marker has its corners refined to sub-pixel and is judged on them: it agrees with a
//! pose when its corners are within the calibration's residual plus [`MOVED_RMS_PX`] (rms) of
//! where that pose puts them.
//!
//! What a check decides:
//! - every marker found agrees with the pose (or only markers already known to be off their
//!   place disagree): the pose is confirmed;
//! - otherwise every marker found is refined, and two explanations compete. The pose holds and
//!   the disagreeing markers moved on the floor; or the camera moved: the pose is refitted (the
//!   lens held) to the markers not known to be moved, and while the refit leaves a marker off,
//!   the worst one is left out and the pose refitted to the rest. Whichever explanation more
//!   markers agree with wins (a tie keeps the pose); a refit must be agreed by two markers or
//!   more, unless only one marker was found at all. The markers that agree with neither are
//!   moved: they are reported, and take no part in later refits until they are back where the
//!   map puts them;
//! - no marker found around where the pose puts them: the whole frame is searched (a knock
//!   large enough to move them out of their regions); none there either, nothing is decided.
//!
//! A marker partly covered by the robot is not decoded at all, so occlusion changes nothing.

use nalgebra::Vector2;

use super::{MovedMarker, MOVED_RMS_PX};
use crate::detect::aruco::{
    diagonals_cross, Detector, DetectorConfig, Dictionary, Marker, Roi, MAX_MARKERS,
};
use crate::frame::{Frame, FrameSize};
use crate::geometry::calibration::MarkerPlacement;
use crate::geometry::camera::{CameraModel, Pose};
use crate::geometry::camera_fit::{fit_camera, LensChoice, MAX_FIT_POINTS};
use crate::geometry::homography::Point;

/// Least margin around a marker's expected outline, pixels: the adaptive threshold's largest
/// window (23 px) must fit beside the marker for its edge to be found as in a whole frame.
const MIN_MARGIN_PX: f64 = 16.0;
/// Markers that must agree with a refitted pose, unless only one marker was found.
const MIN_AGREEING_MARKERS: usize = 2;
/// Steady markers that end a check's search early: a knock moves every marker, so three found
/// where they were say the camera did not move. Any marker found not steady (or too few found)
/// has every marker of the map searched in the same copy, so that a decision is always made on
/// every marker in view; the next check starts with the markers this one did not search.
const STEADY_QUORUM: usize = 3;

/// What a check decided about the pose.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Decision {
    /// No marker found, or none that could decide: nothing changes.
    Nothing,
    /// The markers that agree confirm the pose.
    Confirmed,
    /// The camera moved: the pose refitted to the markers that agree with each other.
    Refit {
        /// The refitted pose (the lens is held).
        pose: Pose,
        /// How far (rms, px) the refit's markers were from where the old pose put them.
        off_px: f64,
        /// Corners the pose was refitted to.
        corners: usize,
    },
}

/// A check's outcome, applied by the tracking thread.
#[derive(Debug, Clone, PartialEq)]
pub struct Verdict {
    /// Markers of the map found in the frame.
    pub found: usize,
    /// What happens to the pose.
    pub decision: Decision,
    /// The rms residual (px) of the refined corners that confirmed or refitted the pose;
    /// `None` when only steady markers confirmed it (the last residual stands).
    pub residual_px: Option<f64>,
    /// Markers found off their place on the map for the first time, left out of the pose.
    pub moved: heapless::Vec<MovedMarker, MAX_MARKERS>,
    /// Markers known to be off their place that are back where the map puts them.
    pub back: heapless::Vec<u16, MAX_MARKERS>,
}

/// The checker's state, allocated once; it lives on the worker thread.
pub struct Checker {
    detector: Detector,
    map: heapless::Vec<MarkerPlacement, MAX_MARKERS>,
    /// The calibration's own rms residual: markers this far off fit as well as they ever did.
    calibration_px: f64,
    /// Per marker of the map, where its unrefined centre sits from where the pose puts it, as
    /// learned when its refined corners confirmed the pose (cleared by a refit).
    centre_bias_px: [Option<Vector2<f64>>; MAX_MARKERS],
    /// Per marker of the map: found off its place, left out of the pose until it is back.
    moved: [bool; MAX_MARKERS],
    /// This check's markers, by map index: as found, and their corners refined (when judged
    /// on them).
    seen: [Option<Marker>; MAX_MARKERS],
    refined: [Option<[Point; 4]>; MAX_MARKERS],
    /// The map index the next check's search starts at.
    turn: usize,
    /// Corners for a fit: floor and screen.
    floor_pts: heapless::Vec<Point, MAX_FIT_POINTS>,
    screen_pts: heapless::Vec<Point, MAX_FIT_POINTS>,
    size: FrameSize,
}

impl Checker {
    /// A checker of `map` (markers of `dictionary`) in frames of `size`; `calibration_px` is
    /// the calibration's own rms residual.
    pub fn new(
        size: FrameSize,
        dictionary: Dictionary,
        map: &[MarkerPlacement],
        calibration_px: f64,
    ) -> Self {
        let mut kept = heapless::Vec::new();
        for m in map.iter().take(MAX_MARKERS) {
            // Capacity is MAX_MARKERS and at most that many are taken.
            let _ = kept.push(*m);
        }
        Checker {
            detector: Detector::new(
                size,
                DetectorConfig {
                    // Refined only when a marker is judged on its corners.
                    refine: false,
                    ..DetectorConfig::new(dictionary)
                },
            ),
            map: kept,
            calibration_px: if calibration_px.is_finite() {
                calibration_px
            } else {
                0.0
            },
            centre_bias_px: [None; MAX_MARKERS],
            moved: [false; MAX_MARKERS],
            seen: [None; MAX_MARKERS],
            refined: [None; MAX_MARKERS],
            turn: 0,
            floor_pts: heapless::Vec::new(),
            screen_pts: heapless::Vec::new(),
            size,
        }
    }

    /// The farthest (rms, px) a marker's corners may be from where a pose puts them and still
    /// agree with it.
    fn agree_px(&self) -> f64 {
        self.calibration_px + MOVED_RMS_PX
    }

    /// Checks the markers in `frame` against `camera`.
    pub fn check(&mut self, frame: &Frame<'_>, camera: &CameraModel) -> Verdict {
        let mut verdict = Verdict {
            found: 0,
            decision: Decision::Nothing,
            residual_px: None,
            moved: heapless::Vec::new(),
            back: heapless::Vec::new(),
        };
        self.find(frame, camera);
        verdict.found = self.seen.iter().flatten().count();
        if verdict.found == 0 {
            return verdict;
        }
        // Steady markers are not refined; the others are judged on refined corners.
        let agree_px = self.agree_px();
        let mut disagree_new = false;
        let mut agree_any = false;
        for i in 0..self.map.len() {
            let Some((_, p)) = self.marker(i) else {
                continue;
            };
            if self.is_steady(camera, i) {
                agree_any = true;
                continue;
            }
            let corners = self.refine(frame, i);
            if marker_rms_px(camera, &p, &corners) <= agree_px {
                agree_any = true;
            } else if !self.is_moved(i) {
                disagree_new = true;
            }
        }
        if agree_any && !disagree_new {
            self.confirm(camera, &mut verdict);
            return verdict;
        }
        // Something disagrees: judge every marker on refined corners.
        for i in 0..self.map.len() {
            if self.seen.get(i).copied().flatten().is_some() {
                self.refine(frame, i);
            }
        }
        let agreeing_pose = self.agreeing(camera);
        let refit = self.robust_refit(camera);
        let refit_agreeing = refit.map_or(0, |(c, _, _)| self.agreeing(&c));
        let unmoved_found = (0..self.map.len())
            .filter(|&i| self.seen.get(i).copied().flatten().is_some() && !self.is_moved(i))
            .count();
        let refit_may_decide =
            refit_agreeing >= MIN_AGREEING_MARKERS || (unmoved_found == 1 && verdict.found == 1);
        match refit {
            Some((fitted, rms_px, corners))
                if refit_agreeing > agreeing_pose && refit_may_decide =>
            {
                let off_px = self.rms_of_agreeing(camera, &fitted);
                self.centre_bias_px = [None; MAX_MARKERS];
                self.mark_moved(&fitted, &mut verdict);
                verdict.decision = Decision::Refit {
                    pose: fitted.pose,
                    off_px,
                    corners,
                };
                verdict.residual_px = Some(rms_px);
            }
            _ if agreeing_pose > 0 => self.confirm(camera, &mut verdict),
            _ => {}
        }
        verdict
    }

    /// Finds the map's markers: each in the region around where `camera` puts it, and when
    /// none is found there, in the whole frame.
    fn find(&mut self, frame: &Frame<'_>, camera: &CameraModel) {
        self.seen = [None; MAX_MARKERS];
        self.refined = [None; MAX_MARKERS];
        let n = self.map.len();
        let (mut searched, mut steady, mut all) = (0, 0, false);
        while searched < n && (all || steady < STEADY_QUORUM) {
            let i = (self.turn + searched) % n;
            searched += 1;
            let Some(p) = self.map.get(i).copied() else {
                continue;
            };
            let Some(roi) = marker_region(camera, &p) else {
                continue;
            };
            if self.detector.detect(frame, Some(roi)).is_ok() {
                self.take(i, p.id);
            }
            if self.seen.get(i).copied().flatten().is_some() {
                if self.is_steady(camera, i) {
                    steady += 1;
                } else {
                    // A marker not steady is judged with every marker in view.
                    all = true;
                }
            }
        }
        // The next check starts with the markers this one did not search.
        self.turn = (self.turn + searched) % n.max(1);
        if self.seen.iter().all(Option::is_none) && self.detector.detect(frame, None).is_ok() {
            for i in 0..self.map.len() {
                if let Some(p) = self.map.get(i).copied() {
                    self.take(i, p.id);
                }
            }
        }
    }

    /// Whether map marker `i`, found in this check, is steady: not known to be moved, and its
    /// unrefined centre where it sat when refined corners last confirmed the pose.
    fn is_steady(&self, camera: &CameraModel, i: usize) -> bool {
        let Some((m, p)) = self.marker(i) else {
            return false;
        };
        let offset = marker_centre_px(camera, &p).map(|c| m.centre() - c);
        let bias = self.centre_bias_px.get(i).copied().flatten();
        !self.is_moved(i)
            && matches!((offset, bias), (Some(o), Some(b)) if (o - b).norm() <= self.agree_px())
    }

    /// Keeps the last detection's one marker of `id` (none if it was seen twice) as map
    /// marker `index`.
    fn take(&mut self, index: usize, id: u16) {
        let mut matching = self.detector.markers().iter().filter(|m| m.id == id);
        if let (Some(&m), None, Some(slot)) =
            (matching.next(), matching.next(), self.seen.get_mut(index))
        {
            *slot = Some(m);
        }
    }

    /// Map marker `i` as found in this check, with its placement.
    fn marker(&self, i: usize) -> Option<(Marker, MarkerPlacement)> {
        Some((self.seen.get(i).copied().flatten()?, *self.map.get(i)?))
    }

    fn is_moved(&self, i: usize) -> bool {
        self.moved.get(i).copied().unwrap_or(false)
    }

    /// Map marker `i`'s corners refined to sub-pixel (once per check; as found if refinement
    /// fails).
    fn refine(&mut self, frame: &Frame<'_>, i: usize) -> [Point; 4] {
        if let Some(corners) = self.refined.get(i).copied().flatten() {
            return corners;
        }
        let Some(m) = self.seen.get(i).copied().flatten() else {
            return [Point::origin(); 4];
        };
        let corners = self.detector.refine(frame, &m).unwrap_or(m.corners);
        if let Some(slot) = self.refined.get_mut(i) {
            *slot = Some(corners);
        }
        corners
    }

    /// Map marker `i`'s refined corners' rms distance from where `camera` puts them
    /// (infinite when not refined in this check).
    fn refined_rms_px(&self, camera: &CameraModel, i: usize) -> f64 {
        match (self.refined.get(i).copied().flatten(), self.map.get(i)) {
            (Some(corners), Some(p)) => marker_rms_px(camera, p, &corners),
            _ => f64::INFINITY,
        }
    }

    /// Markers whose refined corners agree with `camera`.
    fn agreeing(&self, camera: &CameraModel) -> usize {
        let agree_px = self.agree_px();
        (0..self.map.len())
            .filter(|&i| self.refined_rms_px(camera, i) <= agree_px)
            .count()
    }

    /// The pose confirmed by the markers that agree with it: their centres' offsets learned,
    /// the residual of the refined ones reported, and the others marked moved.
    fn confirm(&mut self, camera: &CameraModel, verdict: &mut Verdict) {
        verdict.decision = Decision::Confirmed;
        let agree_px = self.agree_px();
        let (mut sum_sq, mut corners) = (0.0, 0usize);
        for i in 0..self.map.len() {
            let (Some((m, p)), Some(refined)) =
                (self.marker(i), self.refined.get(i).copied().flatten())
            else {
                continue;
            };
            let rms = marker_rms_px(camera, &p, &refined);
            if rms > agree_px {
                continue;
            }
            sum_sq += rms * rms * 4.0;
            corners += 4;
            if let (Some(bias), Some(c)) =
                (self.centre_bias_px.get_mut(i), marker_centre_px(camera, &p))
            {
                *bias = Some(m.centre() - c);
            }
        }
        if corners > 0 {
            verdict.residual_px = Some((sum_sq / corners as f64).sqrt());
        }
        self.mark_moved(camera, verdict);
    }

    /// Notes, against the pose in force (`camera`), which refined markers are off their place
    /// (newly: reported) and which known-moved ones are back.
    fn mark_moved(&mut self, camera: &CameraModel, verdict: &mut Verdict) {
        let agree_px = self.agree_px();
        for i in 0..self.map.len() {
            let Some((_, p)) = self.marker(i) else {
                continue;
            };
            let Some(corners) = self.refined.get(i).copied().flatten() else {
                continue;
            };
            let off_px = marker_rms_px(camera, &p, &corners);
            let was_moved = self.is_moved(i);
            let moved = off_px > agree_px;
            if moved && !was_moved {
                let centre = diagonals_cross(&corners);
                let at = camera.floor_point(&centre, 0.0).ok();
                let off = at.map(|a| (a - placement_centre(&p)).norm());
                // At most one entry per marker of the map.
                let _ = verdict.moved.push(MovedMarker {
                    id: p.id,
                    off_px,
                    off_floor: off,
                });
            } else if !moved && was_moved {
                let _ = verdict.back.push(p.id);
            }
            if let Some(flag) = self.moved.get_mut(i) {
                *flag = moved;
            }
            if moved {
                if let Some(bias) = self.centre_bias_px.get_mut(i) {
                    *bias = None;
                }
            }
        }
    }

    /// The pose refitted (lens held) to the markers not known to be moved, leaving out the
    /// worst one while the refit leaves any off its place; the camera, its rms residual and the
    /// corners it was fitted to, or `None` when no pose fits.
    fn robust_refit(&mut self, camera: &CameraModel) -> Option<(CameraModel, f64, usize)> {
        let agree_px = self.agree_px();
        let mut left_out = [false; MAX_MARKERS];
        for (out, moved) in left_out.iter_mut().zip(&self.moved) {
            *out = *moved;
        }
        loop {
            self.floor_pts.clear();
            self.screen_pts.clear();
            for i in 0..self.map.len() {
                if left_out.get(i).copied().unwrap_or(true) {
                    continue;
                }
                let (Some(corners), Some(p)) =
                    (self.refined.get(i).copied().flatten(), self.map.get(i))
                else {
                    continue;
                };
                for (f, s) in p.corners().iter().zip(&corners) {
                    // MAX_FIT_POINTS holds four corners of every marker of the map.
                    let _ = self.floor_pts.push(*f);
                    let _ = self.screen_pts.push(*s);
                }
            }
            if self.floor_pts.is_empty() {
                return None;
            }
            let fit = fit_camera(
                &self.floor_pts,
                &self.screen_pts,
                self.size,
                LensChoice::Known(camera.lens),
            )
            .ok()?;
            let fitted = CameraModel {
                lens: camera.lens,
                pose: fit.camera.pose,
            };
            // The worst marker of the fit.
            let worst = (0..self.map.len())
                .filter(|&i| !left_out.get(i).copied().unwrap_or(true))
                .map(|i| (i, self.refined_rms_px(&fitted, i)))
                .filter(|(_, rms)| rms.is_finite())
                .max_by(|a, b| a.1.total_cmp(&b.1));
            match worst {
                Some((i, rms)) if rms > agree_px => {
                    if let Some(out) = left_out.get_mut(i) {
                        *out = true;
                    }
                }
                _ => return Some((fitted, fit.rms_residual_px, self.floor_pts.len())),
            }
        }
    }

    /// The rms distance (px) from where `old` puts them of the refined corners that agree
    /// with `new`.
    fn rms_of_agreeing(&self, old: &CameraModel, new: &CameraModel) -> f64 {
        let agree_px = self.agree_px();
        let (mut sum_sq, mut n) = (0.0, 0usize);
        for i in 0..self.map.len() {
            if self.refined_rms_px(new, i) <= agree_px {
                let rms = self.refined_rms_px(old, i);
                sum_sq += rms * rms;
                n += 1;
            }
        }
        (sum_sq / n.max(1) as f64).sqrt()
    }
}

/// The centre of `marker`'s square on the floor.
fn placement_centre(marker: &MarkerPlacement) -> Point {
    let half = 0.5 * marker.size;
    Point::new(marker.origin.x + half, marker.origin.y + half)
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

/// Rms distance between `marker`'s corners seen at `screen` and where `camera` puts them.
fn marker_rms_px(camera: &CameraModel, marker: &MarkerPlacement, screen: &[Point; 4]) -> f64 {
    let mut sum = 0.0;
    for (f, s) in marker.corners().iter().zip(screen) {
        match camera.project(f, 0.0) {
            Ok(q) => sum += (q - s).norm_squared(),
            Err(_) => return f64::INFINITY,
        }
    }
    (sum / 4.0).sqrt()
}
