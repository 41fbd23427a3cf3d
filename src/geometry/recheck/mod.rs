//! Staying calibrated: the calibration's markers re-detected while tracking, and the camera's
//! pose refitted (the pose only: the lens stays) when a knock has moved them.
//!
//! Every [`RECHECK_PERIOD_FRAMES`] frames the tracking thread copies the frame's luma into a
//! buffer allocated at start and hands it, with the pose in force, to a worker thread made at
//! start (`worker`), which finds the markers in the copy and judges them ([`judge`]: a marker
//! is searched in the region around where the pose puts it, refined to sub-pixel only when its
//! unrefined centre does not already say it is steady, and the pose confirmed, refitted, or
//! kept with a moved marker left out). Checking the six markers of a map costs a millisecond or
//! more, several times the rest of the per-frame path; on the worker it costs the tracking
//! thread only the copy. The verdict is applied [`VERDICT_LAG_FRAMES`] frames after the copy,
//! the tracking thread waiting there for it if the worker is not done: the frames a verdict
//! applies to never depend on how fast the worker was, so a replay gives the same numbers on
//! every run, however loaded the machine.
//!
//! What the tracking thread does with a verdict:
//! - markers confirm the pose: its age restarts from the checked frame;
//! - the camera moved: the refitted pose replaces the floor stage's, and one line says so;
//! - a marker is off its place on the map (kicked, or moved by hand): one line names it, and it
//!   is left out of the pose until it is back (another line);
//! - no marker seen (the robot may be standing on them, or the camera looks elsewhere): nothing
//!   changes; after [`STALE_AFTER_CHECKS`] such checks in a row, once markers had been seen in
//!   this run, the floor numbers are marked stale: the camera may have moved where no marker
//!   shows.

pub mod judge;
mod worker;

use core::fmt;

use self::judge::{Checker, Decision, Verdict};
use self::worker::{Job, Worker};
use super::calibration::MarkerPlacement;
use super::camera::CameraModel;
use super::floor::FloorStage;
use crate::detect::aruco::Dictionary;
use crate::frame::{Frame, FrameSize, PixelFormat};

/// Frames between two re-checks (0.5 s at 30 fps: a knock is caught well within a second).
pub const RECHECK_PERIOD_FRAMES: u64 = 15;
/// Frames from a check's copy to the frame its verdict is applied on: time for the worker to
/// check six markers while the tracking thread goes on (at 30 fps a third of a second; replayed
/// from a file, about 2 ms), and short enough that a knock is refitted within a second.
pub const VERDICT_LAG_FRAMES: u64 = 10;
/// A marker whose corners are this far off a pose (rms, pixels, beyond the calibration's own
/// residual) does not agree with it: at 640×480 from 1.5 m, one pixel is a few millimetres on
/// the floor, several times a good calibration's residual.
pub const MOVED_RMS_PX: f64 = 1.0;
/// Checks in a row without any marker before the floor numbers are called stale.
pub const STALE_AFTER_CHECKS: u32 = 4;

/// Which calibration a frame's floor numbers come from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CalibStatus {
    /// Seconds since the frame in which markers last confirmed the pose (or since the start
    /// of the run).
    pub age_s: f64,
    /// The markers' corners' rms residual when they last confirmed or refitted the pose refined
    /// (at the start: the file's); a confirmation by steady markers alone keeps it.
    pub residual_px: f64,
    /// No marker has been seen for a while after markers were seen: the camera may have moved.
    pub stale: bool,
    /// The camera the floor numbers were mapped through (after a refit, the refitted pose).
    pub camera: Option<CameraModel>,
}

/// A marker of the map found off its place.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MovedMarker {
    /// Its id.
    pub id: u16,
    /// Its corners' rms distance from where the pose puts them, pixels.
    pub off_px: f64,
    /// How far its centre lies from its place on the map, in floor units (`None` when the
    /// pose cannot map it to the floor).
    pub off_floor: Option<f64>,
}

/// Why the re-check could not start.
#[derive(Debug)]
pub struct RecheckError(std::io::Error);

impl fmt::Display for RecheckError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "cannot start the marker re-check's thread: {}", self.0)
    }
}

impl std::error::Error for RecheckError {}

/// The re-check's state on the tracking thread, allocated once.
pub struct MarkerRecheck {
    worker: Worker,
    /// The copy's buffer while no check is under way.
    spare: Option<Box<[u8]>>,
    /// The frame index and timestamp of the check under way.
    in_flight: Option<(u64, u64)>,
    /// The frame index of the last check's copy.
    last_check: Option<u64>,
    confirmed_us: Option<u64>,
    residual_px: f64,
    misses: u32,
    seen_any: bool,
    start_us: Option<u64>,
}

impl MarkerRecheck {
    /// A re-check of `map` (the calibration's markers, found with `dictionary`) for frames of
    /// `size`; `residual_px` is the calibration's own rms residual. Starts the worker thread.
    pub fn new(
        size: FrameSize,
        dictionary: Dictionary,
        map: &[MarkerPlacement],
        residual_px: f64,
    ) -> Result<Self, RecheckError> {
        let checker = Checker::new(size, dictionary, map, residual_px);
        let worker = Worker::start(checker, size).map_err(RecheckError)?;
        Ok(MarkerRecheck {
            worker,
            spare: Some(vec![0u8; luma_bytes(size)].into_boxed_slice()),
            in_flight: None,
            last_check: None,
            confirmed_us: None,
            residual_px,
            misses: 0,
            seen_any: false,
            start_us: None,
        })
    }

    /// Bytes the re-check allocates besides its marker detector: the frame copy.
    pub fn copy_bytes(size: FrameSize) -> usize {
        luma_bytes(size)
    }

    /// The re-check's share of frame `index`: every [`RECHECK_PERIOD_FRAMES`] frames the
    /// frame is copied for a check, whose verdict is applied [`VERDICT_LAG_FRAMES`] frames
    /// later (refitting the floor stage's pose when the camera moved); returns the
    /// calibration's status.
    pub fn check(
        &mut self,
        frame: &Frame<'_>,
        index: u64,
        timestamp_us: u64,
        floor: &mut FloorStage,
    ) -> CalibStatus {
        let start_us = *self.start_us.get_or_insert(timestamp_us);
        if let Some((checked, checked_us)) = self.in_flight {
            if index >= checked.saturating_add(VERDICT_LAG_FRAMES) || index < checked {
                self.in_flight = None;
                match self.worker.wait() {
                    Some((job, verdict)) => {
                        self.spare = Some(job.luma);
                        self.apply(&verdict, checked_us, floor);
                    }
                    None => {
                        log::warn!("the marker re-check's thread ended; markers no longer checked")
                    }
                }
            }
        }
        let due = self
            .last_check
            .is_none_or(|last| index >= last.saturating_add(RECHECK_PERIOD_FRAMES) || index < last);
        if due && self.in_flight.is_none() {
            if let (Some(mut luma), Some(camera)) = (self.spare.take(), floor.camera().copied()) {
                if copy_luma(frame, &mut luma) {
                    self.worker.submit(Job { luma, camera });
                    self.in_flight = Some((index, timestamp_us));
                    self.last_check = Some(index);
                } else {
                    self.spare = Some(luma);
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

    /// Applies the verdict on the frame taken at `checked_us`.
    fn apply(&mut self, verdict: &Verdict, checked_us: u64, floor: &mut FloorStage) {
        let unit = floor.unit().name();
        for m in &verdict.moved {
            log::warn!(
                "calibration marker {} is {}off its place on the map ({:.1} px): left out of \
                 the pose until it is back",
                m.id,
                OffFloor(m.off_floor, unit),
                m.off_px
            );
        }
        for id in &verdict.back {
            log::info!("calibration marker {id} is back in its place on the map");
        }
        if verdict.found == 0 {
            self.misses = self.misses.saturating_add(1);
            return;
        }
        self.misses = 0;
        self.seen_any = true;
        match verdict.decision {
            Decision::Nothing => {}
            Decision::Confirmed => {
                self.confirmed_us = Some(checked_us);
                if let Some(r) = verdict.residual_px {
                    self.residual_px = r;
                }
            }
            Decision::Refit {
                pose,
                off_px,
                corners,
            } => {
                let Some(camera) = floor.camera().copied() else {
                    return;
                };
                let refit = FloorStage::from_camera(
                    CameraModel {
                        lens: camera.lens,
                        pose,
                    },
                    floor.unit(),
                )
                .with_led_height(floor.led_height());
                if let Ok(stage) = refit {
                    let moved = (pose.centre() - camera.pose.centre()).norm();
                    let residual_px = verdict.residual_px.unwrap_or(f64::NAN);
                    log::warn!(
                        "camera moved: the markers were {off_px:.2} px off; pose refit from \
                         {corners} corners ({residual_px:.3} px rms, camera centre moved \
                         {moved:.1} {unit})"
                    );
                    *floor = stage;
                    self.residual_px = residual_px;
                    self.confirmed_us = Some(checked_us);
                }
            }
        }
    }
}

/// How far a moved marker is from its place, in floor units, when known (written without
/// allocating).
struct OffFloor(Option<f64>, &'static str);

impl fmt::Display for OffFloor {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.0 {
            Some(d) => write!(f, "{d:.1} {} ", self.1),
            None => Ok(()),
        }
    }
}

/// Bytes of a frame's luma copy.
pub fn luma_bytes(size: FrameSize) -> usize {
    size.frame_bytes_as(PixelFormat::Grey)
}

/// Copies `frame`'s luma into `out` (one byte a pixel, rows `width` apart), as a check's copy
/// is made; false when the sizes differ.
pub fn copy_luma(frame: &Frame<'_>, out: &mut [u8]) -> bool {
    let size = frame.size();
    if out.len() != luma_bytes(size) {
        return false;
    }
    for (dst, row) in out.chunks_exact_mut(size.width()).zip(frame.rows()) {
        match frame.format() {
            PixelFormat::Grey => dst.copy_from_slice(row),
            PixelFormat::Yuyv => {
                for (d, p) in dst.iter_mut().zip(row.chunks_exact(2)) {
                    *d = p[0];
                }
            }
            PixelFormat::Uyvy => {
                for (d, p) in dst.iter_mut().zip(row.chunks_exact(2)) {
                    *d = p[1];
                }
            }
        }
    }
    true
}
