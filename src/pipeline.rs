//! The per-frame path, top to bottom: source → detection → (tracking) → report → sink.
//!
//! [`Pipeline`] holds every stage's state, allocated in [`Pipeline::new`]; [`run`] pulls frames
//! from a source and pushes reports into a sink until the source ends. Neither allocates per
//! frame.

use core::fmt;
use std::io;

use crate::detect::{Detection, Detector, DetectorConfig};
use crate::frame::{Frame, FrameSize};
use crate::sink::Sink;
use crate::source::{FrameMeta, FrameSource};

/// Settings of the whole per-frame path.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PipelineConfig {
    /// The detection stage.
    pub detector: DetectorConfig,
}

/// Where the LED is in one frame, in image pixels ((0, 0) is the centre of the top-left pixel).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Position {
    /// Best estimate of the LED's position at the end of the exposure.
    pub x_px: f32,
    pub y_px: f32,
    /// The middle of the streak (the seed's point, refined).
    pub mid_x_px: f32,
    pub mid_y_px: f32,
}

/// Everything known about one processed frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrameReport {
    /// Index, sequence and time of the frame.
    pub meta: FrameMeta,
    /// The detection stage's findings.
    pub detection: Detection,
    /// The LED's position, when found.
    pub position: Option<Position>,
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
}

impl Pipeline {
    /// Allocates every stage for frames of `size`.
    pub fn new(size: FrameSize, config: PipelineConfig) -> Self {
        Pipeline {
            detector: Detector::new(size, config.detector),
        }
    }

    /// Processes one frame.
    pub fn process(&mut self, frame: &Frame<'_>, meta: FrameMeta) -> FrameReport {
        let detection = self.detector.detect(frame);
        let position = detection.best.map(|(_, streak)| Position {
            x_px: streak.mid_px.0,
            y_px: streak.mid_px.1,
            mid_x_px: streak.mid_px.0,
            mid_y_px: streak.mid_px.1,
        });
        FrameReport {
            meta,
            detection,
            position,
        }
    }

    /// The detection stage, for overlays and diagnostics.
    pub fn detector(&self) -> &Detector {
        &self.detector
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
