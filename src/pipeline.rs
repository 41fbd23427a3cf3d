//! The per-frame path, top to bottom: source → detection → tracking → floor → report → sink.
//!
//! [`Pipeline`] holds every stage's state, allocated in [`Pipeline::new`] (the LED) or
//! [`Pipeline::marker`] (a robot carrying an ArUco marker); [`run`] pulls frames from a source
//! and pushes reports into a sink until the source ends. Neither allocates per frame.

use core::fmt;
use std::io;

use crate::detect::bgdiff::BackgroundError;
use crate::detect::blobs::Overflow;
use crate::detect::threshold::Levels;
use crate::detect::{Detection, Detector, DetectorConfig};
use crate::frame::{Frame, FrameSize};
use crate::geometry::recheck::{CalibStatus, MarkerRecheck};
use crate::geometry::{FloorFix, FloorStage};
use crate::sink::Sink;
use crate::source::{FrameMeta, FrameSource};
use crate::track::{Choice, Estimate, MarkerPose, MarkerTracker, Tracker, TrackerConfig};

/// Settings of the whole per-frame path.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PipelineConfig {
    /// The detection stage.
    pub detector: DetectorConfig,
    /// The tracking stage.
    pub tracker: TrackerConfig,
}

/// Everything known about one processed frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrameReport {
    /// Index, sequence and time of the frame.
    pub meta: FrameMeta,
    /// The LED detection stage's findings (empty when tracking a marker).
    pub detection: Detection,
    /// The LED's (or marker's) position and velocity, when found. Positions are image pixels,
    /// (0, 0) the centre of the top-left pixel.
    pub position: Option<Estimate>,
    /// Several candidates and no way yet to tell the LED from glare (or the tracked marker id
    /// seen twice).
    pub ambiguous: bool,
    /// The tracked marker's corners and heading, when tracking a marker and it was found.
    pub marker: Option<MarkerPose>,
    /// When tracking a marker: the marker detector hit its cost cap on this frame, so part of
    /// the frame was not searched.
    pub markers_capped: bool,
    /// Floor position, velocity and heading, when a calibration is loaded and `position` is
    /// known.
    pub floor: Option<FloorFix>,
    /// Which calibration the floor numbers used, when its markers are re-checked.
    pub calib: Option<CalibStatus>,
}

impl FrameReport {
    /// Frame time in seconds since the first frame.
    pub fn t_s(&self) -> f64 {
        self.meta.timestamp_us as f64 * 1e-6
    }
}

/// What finds the robot in a frame.
// One per run, built once and never moved per frame: the size difference costs nothing.
#[allow(clippy::large_enum_variant)]
enum Front {
    /// A saturated LED: segmentation, then the tracker choosing and following a blob.
    Led {
        detector: Detector,
        tracker: Tracker,
    },
    /// An ArUco / AprilTag marker of one id.
    Marker(MarkerTracker),
}

/// The per-frame path and its state.
pub struct Pipeline {
    front: Front,
    /// Screen → floor, when a calibration is loaded.
    floor: Option<FloorStage>,
    /// The calibration's markers re-checked while tracking.
    recheck: Option<MarkerRecheck>,
}

impl Pipeline {
    /// Allocates every stage of LED tracking for frames of `size`.
    pub fn new(size: FrameSize, config: PipelineConfig) -> Result<Self, BackgroundError> {
        Ok(Pipeline {
            front: Front::Led {
                detector: Detector::new(size, config.detector)?,
                tracker: Tracker::new(config.tracker),
            },
            floor: None,
            recheck: None,
        })
    }

    /// A pipeline that follows a marker instead of an LED.
    pub fn marker(tracker: MarkerTracker) -> Self {
        Pipeline {
            front: Front::Marker(tracker),
            floor: None,
            recheck: None,
        }
    }

    /// Adds the floor stage: every found frame also gets floor coordinates.
    pub fn with_floor(mut self, floor: FloorStage) -> Self {
        self.floor = Some(floor);
        self
    }

    /// Adds the re-check of the calibration's markers (with a floor stage that has a camera
    /// model): a knocked camera's pose is refitted, and reports say which calibration they use.
    pub fn with_recheck(mut self, recheck: MarkerRecheck) -> Self {
        self.recheck = Some(recheck);
        self
    }

    /// Feeds a frame of a separate background recording to the LED detector (nothing to do
    /// when tracking a marker).
    pub fn learn_background(&mut self, frame: &Frame<'_>) -> Result<(), BackgroundError> {
        match &mut self.front {
            Front::Led { detector, .. } => detector.learn_background(frame),
            Front::Marker(_) => Ok(()),
        }
    }

    /// Processes one frame: find the robot (LED: segment, let the tracker choose the LED among
    /// the candidates, analyse that one blob's streak, update the track; marker: detect and
    /// pick the id), then map the result to the floor.
    pub fn process(&mut self, frame: &Frame<'_>, meta: FrameMeta) -> FrameReport {
        let (detection, position, ambiguous, marker, markers_capped) = match &mut self.front {
            Front::Led { detector, tracker } => {
                let mut detection = detector.segment_at(frame, meta.timestamp_us);
                let choice = tracker.choose(detector.candidates(), meta.index, meta.timestamp_us);
                detection.best = match choice {
                    Choice::Blob(index) => {
                        let best = detector.analyze(frame, index, detection.levels);
                        // Report the level the LED itself was cut at.
                        if best.is_some() {
                            detection.levels = detector.levels_of(frame, index, detection.levels);
                        }
                        best
                    }
                    Choice::Nothing | Choice::Ambiguous => None,
                };
                let position =
                    tracker.update(meta.timestamp_us, detection.best.as_ref().map(|(_, s)| s));
                (
                    detection,
                    position,
                    choice == Choice::Ambiguous,
                    None,
                    false,
                )
            }
            Front::Marker(tracker) => {
                let found = tracker.process(frame, meta.timestamp_us);
                let capped = found.markers_capped;
                (
                    no_detection(),
                    found.estimate,
                    found.ambiguous,
                    found.pose,
                    capped,
                )
            }
        };
        let calib = match (&mut self.recheck, &mut self.floor) {
            (Some(recheck), Some(stage)) => {
                Some(recheck.check(frame, meta.index, meta.timestamp_us, stage))
            }
            _ => None,
        };
        let floor = match (&self.floor, &position) {
            (Some(stage), Some(p)) => Some(stage.map(p, marker.as_ref().map(|m| &m.corners_px))),
            _ => None,
        };
        FrameReport {
            meta,
            detection,
            position,
            ambiguous,
            marker,
            markers_capped,
            floor,
            calib,
        }
    }

    /// The LED detection stage, for overlays and diagnostics (`None` when tracking a marker).
    pub fn detector(&self) -> Option<&Detector> {
        match &self.front {
            Front::Led { detector, .. } => Some(detector),
            Front::Marker(_) => None,
        }
    }

    /// The floor stage, when a calibration is loaded.
    pub fn floor(&self) -> Option<&FloorStage> {
        self.floor.as_ref()
    }
}

/// The LED detection's report for a frame it did not look at.
fn no_detection() -> Detection {
    Detection {
        levels: Levels {
            top_luma: 0,
            threshold_luma: None,
        },
        mask_px: 0,
        blob_count: 0,
        overflow: Overflow::default(),
        blinded: false,
        learning: false,
        best: None,
    }
}

/// Counts over a whole run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct RunSummary {
    /// Frames processed.
    pub frames: u64,
    /// Frames in which the LED was found.
    pub found: u64,
    /// Frames whose blob tables overflowed.
    pub overflowed: u64,
    /// Frames that were mostly saturated.
    pub blinded: u64,
}

/// Why a run stopped early.
#[derive(Debug)]
pub enum RunError<E> {
    /// The source failed; the frames before it were processed.
    Source(E),
    /// The sink could not be written (a closed pipe, a full disk).
    Sink(io::Error),
}

impl<E: fmt::Display> fmt::Display for RunError<E> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RunError::Source(e) => write!(f, "{e}"),
            RunError::Sink(e) => write!(f, "writing output: {e}"),
        }
    }
}

impl<E: fmt::Debug + fmt::Display> std::error::Error for RunError<E> {}

/// Processes every frame of `source` into `sink`. On a source error, the summary of the
/// frames processed so far comes back with it.
pub fn run<S: FrameSource, K: Sink>(
    source: &mut S,
    pipeline: &mut Pipeline,
    sink: &mut K,
) -> (RunSummary, Result<(), RunError<S::Error>>) {
    let mut summary = RunSummary::default();
    let mut overflow_reported = false;
    loop {
        let (frame, meta) = match source.next_frame() {
            Ok(Some(next)) => next,
            Ok(None) => break,
            Err(e) => return (summary, Err(RunError::Source(e))),
        };
        let report = pipeline.process(&frame, meta);
        summary.frames += 1;
        summary.found += u64::from(report.position.is_some());
        summary.blinded += u64::from(report.detection.blinded);
        let overflow = report.detection.overflow;
        if overflow.any() {
            summary.overflowed += 1;
            if !overflow_reported {
                log::warn!(
                    "frame {}: {overflow}; such frames report found: false",
                    meta.index
                );
            }
        } else if overflow_reported {
            log::info!(
                "frame {}: the scene cleared; blob tables fit again",
                meta.index
            );
        }
        overflow_reported = overflow.any();
        if let Err(e) = sink.write_frame(&frame, &report) {
            return (summary, Err(RunError::Sink(e)));
        }
    }
    (summary, sink.finish().map_err(RunError::Sink))
}
