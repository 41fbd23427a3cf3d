//! The per-frame path, top to bottom: source → detection → (tracking) → report → sink.
//!
//! [`Pipeline`] holds every stage's state, allocated in [`Pipeline::new`]; [`run`] pulls frames
//! from a source and pushes reports into a sink until the source ends. Neither allocates per
//! frame.

use core::fmt;
use std::io;

use crate::detect::bgdiff::BackgroundError;
use crate::detect::{Detection, Detector, DetectorConfig};
use crate::frame::{Frame, FrameSize};
use crate::sink::Sink;
use crate::source::{FrameMeta, FrameSource};
use crate::track::{Choice, Estimate, Tracker, TrackerConfig};

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
    /// The detection stage's findings.
    pub detection: Detection,
    /// The LED's position and velocity, when found. Positions are image pixels, (0, 0) the
    /// centre of the top-left pixel.
    pub position: Option<Estimate>,
    /// Several candidates and no way yet to tell the LED from glare.
    pub ambiguous: bool,
}

impl FrameReport {
    /// Frame time in seconds since the first frame.
    pub fn t_s(&self) -> f64 {
        self.meta.timestamp_us as f64 * 1e-6
    }
}

/// The per-frame path and its state.
pub struct Pipeline {
    detector: Detector,
    tracker: Tracker,
}

impl Pipeline {
    /// Allocates every stage for frames of `size`.
    pub fn new(size: FrameSize, config: PipelineConfig) -> Result<Self, BackgroundError> {
        Ok(Pipeline {
            detector: Detector::new(size, config.detector)?,
            tracker: Tracker::new(config.tracker),
        })
    }

    /// Feeds a frame of a separate background recording to the detector.
    pub fn learn_background(&mut self, frame: &Frame<'_>) -> Result<(), BackgroundError> {
        self.detector.learn_background(frame)
    }

    /// Processes one frame: segment, let the tracker choose the LED among the candidates,
    /// analyse that one blob's streak, and update the track.
    pub fn process(&mut self, frame: &Frame<'_>, meta: FrameMeta) -> FrameReport {
        let mut detection = self.detector.segment(frame);
        let choice = self
            .tracker
            .choose(self.detector.candidates(), meta.index, meta.timestamp_us);
        detection.best = match choice {
            Choice::Blob(index) => self.detector.analyze(frame, index, detection.levels),
            Choice::Nothing | Choice::Ambiguous => None,
        };
        let position = self
            .tracker
            .update(meta.timestamp_us, detection.best.as_ref().map(|(_, s)| s));
        FrameReport {
            meta,
            detection,
            position,
            ambiguous: choice == Choice::Ambiguous,
        }
    }

    /// The detection stage, for overlays and diagnostics.
    pub fn detector(&self) -> &Detector {
        &self.detector
    }

    /// The tracking stage.
    pub fn tracker(&self) -> &Tracker {
        &self.tracker
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
        if let Err(e) = sink.write(&report) {
            return (summary, Err(RunError::Sink(e)));
        }
    }
    (summary, sink.finish().map_err(RunError::Sink))
}
