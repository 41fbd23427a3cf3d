//! The per-frame path, top to bottom: source → detection → tracking → floor → report → sink.
//!
//! [`Pipeline`] holds every stage's state, allocated in [`Pipeline::new`] (the LED) or
//! [`Pipeline::marker`] (a robot carrying an ArUco marker); [`run`] pulls frames from a source
//! and pushes reports into a sink until the source ends. Neither allocates per frame.

use core::fmt;
use std::io;

use crate::detect::bgdiff::BackgroundError;
use crate::detect::blobs::{Blob, Overflow};
use crate::detect::spot_shape::SpotOptics;
use crate::detect::streak::Streak;
use crate::detect::threshold::Levels;
use crate::detect::{Detection, Detector, DetectorConfig};
use crate::frame::{Frame, FrameSize};
use crate::geometry::recheck::MarkerRecheck;
use crate::geometry::FloorStage;
use crate::identify::{Identifier, IdentifyConfig, IdentifyError, TrackSeen};
use crate::report::{Estimate, FrameReport, IdSource, TrackReport, Tracks, MAX_ROBOTS};
use crate::sink::Sink;
use crate::source::{FrameMeta, FrameSource};
use crate::track::shutter::RollingShutter;
use crate::track::{Choice, MarkerTracker, MultiTracker, TrackState, Tracker, TrackerConfig};

/// Settings of the whole per-frame path.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PipelineConfig {
    /// The detection stage.
    pub detector: DetectorConfig,
    /// The tracking stage.
    pub tracker: TrackerConfig,
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
    /// Several LEDs, one per robot: segmentation, then the candidates assigned to the tracks.
    Leds {
        detector: Detector,
        tracks: MultiTracker,
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
    /// With several robots and a link to them: which track is which robot.
    identify: Option<Identifier<MAX_ROBOTS>>,
    /// A camera that reads its rows one after another: the velocities its picture shows are
    /// skewed by the LED's own motion.
    shutter: Option<RollingShutter>,
}

impl Pipeline {
    /// Allocates every stage of LED tracking for frames of `size`.
    pub fn new(size: FrameSize, config: PipelineConfig) -> Result<Self, BackgroundError> {
        Ok(Pipeline {
            front: Front::Led {
                detector: detector(size, &config)?,
                tracker: Tracker::new(config.tracker),
            },
            floor: None,
            recheck: None,
            identify: None,
            shutter: None,
        })
    }

    /// Allocates every stage of LED tracking for frames of `size`, following the robots of
    /// `tracks` (`--robots N`) instead of one.
    pub fn several(
        size: FrameSize,
        config: PipelineConfig,
        tracks: MultiTracker,
    ) -> Result<Self, BackgroundError> {
        Ok(Pipeline {
            front: Front::Leds {
                detector: detector(size, &config)?,
                tracks,
            },
            floor: None,
            recheck: None,
            identify: None,
            shutter: None,
        })
    }

    /// A pipeline that follows a marker instead of an LED.
    pub fn marker(tracker: MarkerTracker) -> Self {
        Pipeline {
            front: Front::Marker(tracker),
            floor: None,
            recheck: None,
            identify: None,
            shutter: None,
        }
    }

    /// Identifies the robots by their own LEDs (several robots, each with a link): every frame's
    /// report then carries the LED request to send ([`FrameReport::blink`]), and a track's id is
    /// its robot's once bound (`id_source` blink), or provisional, above every robot's id, until
    /// then. Only for several LEDs; a single robot's id is certain.
    pub fn with_identify(mut self, config: IdentifyConfig) -> Result<Self, IdentifyError> {
        if matches!(self.front, Front::Leds { .. }) {
            self.identify = Some(Identifier::new(config)?);
        }
        Ok(self)
    }

    /// Adds the floor stage: every found frame also gets floor coordinates. A lens that
    /// distorts is also given to the LED detector, which places a streak's tips for the shape
    /// the lens gives a round spot there.
    pub fn with_floor(mut self, floor: FloorStage) -> Self {
        let lens = floor.camera().map(|c| c.lens).filter(|l| !l.is_ideal());
        if let Some(lens) = lens {
            self.set_optics(Box::new(lens));
        }
        self.floor = Some(floor);
        self
    }

    /// Tells the LED detector the lens's local shape of a round spot (as [`Pipeline::with_floor`]
    /// does with a calibrated camera's lens); nothing to do when tracking a marker.
    pub fn set_optics(&mut self, optics: Box<dyn SpotOptics>) {
        if let Front::Led { detector, .. } | Front::Leds { detector, .. } = &mut self.front {
            detector.set_optics(optics);
        }
    }

    /// Reads the velocities of a camera with a rolling shutter (see [`RollingShutter`]): every
    /// track's, the marker's and the floor's. The trackers work on the picture as it is, whose
    /// streaks and steps agree with one another; only the velocity they report is undone.
    pub fn with_rolling_shutter(mut self, shutter: RollingShutter) -> Self {
        self.shutter = Some(shutter);
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
            Front::Led { detector, .. } | Front::Leds { detector, .. } => {
                detector.learn_background(frame)
            }
            Front::Marker(_) => Ok(()),
        }
    }

    /// Processes one frame: find the robot (LED: segment, let the tracker choose the LED among
    /// the candidates, analyse that one blob's streak, update the track; several LEDs: assign
    /// the candidates to the tracks, analyse each track's blob, update each track; marker:
    /// detect and pick the id), then map each track to the floor.
    pub fn process(&mut self, frame: &Frame<'_>, meta: FrameMeta) -> FrameReport {
        let shutter = self.shutter;
        let (detection, ambiguous, marker, markers_capped, mut tracks) = match &mut self.front {
            Front::Led { detector, tracker } => {
                let mut detection = detector.segment_at(frame, meta.timestamp_us);
                if let Some(shutter) = shutter {
                    detector.set_row_skew(row_skew(shutter, tracker, meta.timestamp_us));
                }
                // A first frame's lone round outline may be a smear in a wide glow: its streak
                // says.
                let (frame_index, t_us) = (meta.index, meta.timestamp_us);
                let smeared = tracker
                    .smear_in_question(detector.candidates(), frame_index)
                    .filter(|&index| {
                        let probed = detector.probe(frame, index, detection.levels);
                        probed.is_some_and(|(_, streak)| streak.moving_path().is_some())
                    });
                if let Some(index) = smeared {
                    tracker.smeared_by_its_streak(index);
                }
                let choice = tracker.choose(detector.candidates(), frame_index, t_us);
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
                let blob = detection.best.filter(|_| position.is_some());
                let track = single_track(position, tracker.state(), blob);
                (detection, choice == Choice::Ambiguous, None, false, track)
            }
            Front::Leds { detector, tracks } => {
                let detection = detector.segment(frame);
                tracks.choose(detector.candidates(), meta.index, meta.timestamp_us);
                let mut reports = Tracks::new();
                for slot in 0..tracks.robots() {
                    let choice = tracks.choice(slot);
                    if let Some((shutter, tracker)) = shutter.zip(tracks.tracker(slot)) {
                        detector.set_row_skew(row_skew(shutter, tracker, meta.timestamp_us));
                    }
                    let best = choice
                        .blob
                        .and_then(|index| detector.analyze(frame, index, detection.levels));
                    let t_us = meta.timestamp_us;
                    let estimate = tracks.update(slot, t_us, best.as_ref().map(|(_, s)| s));
                    // At most MAX_ROBOTS slots: the bounded list holds them all.
                    let _ = reports.push(TrackReport {
                        id: u8::try_from(slot + 1).unwrap_or(u8::MAX),
                        provisional: true,
                        id_source: IdSource::Continuity,
                        state: tracks.state(slot),
                        merged: choice.merged,
                        estimate,
                        blob: best.filter(|_| estimate.is_some()),
                        floor: None,
                    });
                }
                (detection, false, None, false, reports)
            }
            Front::Marker(tracker) => {
                let found = tracker.process(frame, meta.timestamp_us);
                // The marker tracker predicts nothing: a frame without the marker searches.
                let state = if found.estimate.is_some() {
                    TrackState::Tracking
                } else {
                    TrackState::Searching
                };
                let track = single_track(found.estimate, state, None);
                let capped = found.markers_capped;
                (no_detection(), found.ambiguous, found.pose, capped, track)
            }
        };
        if let Some(shutter) = shutter {
            for estimate in tracks.iter_mut().filter_map(|t| t.estimate.as_mut()) {
                estimate.velocity_px_s = estimate
                    .velocity_px_s
                    .and_then(|(v, method)| Some((shutter.velocity_px_s(v)?, method)));
            }
        }
        let calib = match (&mut self.recheck, &mut self.floor) {
            (Some(recheck), Some(stage)) => {
                Some(recheck.check(frame, meta.index, meta.timestamp_us, stage))
            }
            _ => None,
        };
        if let Some(stage) = &self.floor {
            for track in tracks.iter_mut() {
                track.floor = track.estimate.map(|p| {
                    let corners = marker.as_ref().map(|m| &m.corners_px);
                    stage.map(p.position_px, p.velocity_px_s.map(|(v, _)| v), corners)
                });
            }
        }
        let blink = self
            .identify
            .as_mut()
            .and_then(|identify| identify_tracks(identify, meta.timestamp_us, &mut tracks));
        let (position, floor) = match tracks.as_slice() {
            [one] => (one.estimate, one.floor),
            _ => (None, None),
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
            tracks,
            blink,
        }
    }

    /// The LED detection stage, for overlays and diagnostics (`None` when tracking a marker).
    pub fn detector(&self) -> Option<&Detector> {
        match &self.front {
            Front::Led { detector, .. } | Front::Leds { detector, .. } => Some(detector),
            Front::Marker(_) => None,
        }
    }

    /// The floor stage, when a calibration is loaded.
    pub fn floor(&self) -> Option<&FloorStage> {
        self.floor.as_ref()
    }
}

/// Steps identification on this frame's tracks (visible: found in this frame) and gives each
/// track its identity: a bound track its robot's id, an unbound one a provisional id above every
/// robot's (`MAX_ROBOTS` + 1 + its slot), so that no id is shown twice. Returns the LED request
/// to send.
fn identify_tracks(
    identify: &mut Identifier<MAX_ROBOTS>,
    timestamp_us: u64,
    tracks: &mut Tracks,
) -> Option<crate::identify::BlinkRequest> {
    let mut seen = [TrackSeen::default(); MAX_ROBOTS];
    for (s, t) in seen.iter_mut().zip(tracks.iter()) {
        let position_px = t.estimate.map_or((0.0, 0.0), |e| e.position_px);
        *s = TrackSeen {
            visible: t.state == TrackState::Tracking,
            x_px: position_px.0,
            y_px: position_px.1,
        };
    }
    let step = identify.step(timestamp_us, seen.get(..tracks.len()).unwrap_or(&[]));
    for (slot, t) in tracks.iter_mut().enumerate() {
        match identify.robot_of(slot) {
            Some(robot) => {
                t.id = robot;
                t.provisional = false;
                t.id_source = IdSource::Blink;
            }
            None => {
                t.id = u8::try_from(MAX_ROBOTS + 1 + slot).unwrap_or(u8::MAX);
                t.provisional = true;
                t.id_source = IdSource::Continuity;
            }
        }
    }
    step.request
}

/// The LED detector of `config`, told the tracker's exposure time (how far an LED moves
/// between frames, for the streak fit's warm start).
fn detector(size: FrameSize, config: &PipelineConfig) -> Result<Detector, BackgroundError> {
    let mut detector = Detector::new(size, config.detector)?;
    detector.set_exposure_us(config.tracker.exposure_us);
    Ok(detector)
}

/// How `shutter` skews the spot of the LED `tracker` follows in the frame at `t_us`, for the
/// velocity it is expected to have then (none before one is expected: the spot is then taken to
/// be round).
fn row_skew(shutter: RollingShutter, tracker: &Tracker, t_us: u64) -> Option<[[f32; 2]; 2]> {
    shutter.unskew(tracker.expected_velocity_px_s(t_us)?)
}

/// The report of a run's one robot, whose id is certain.
fn single_track(
    estimate: Option<Estimate>,
    state: TrackState,
    blob: Option<(Blob, Streak)>,
) -> Tracks {
    let mut tracks = Tracks::new();
    // A bounded list of MAX_ROBOTS ≥ 1 holds one entry.
    let _ = tracks.push(TrackReport {
        id: 1,
        provisional: false,
        id_source: IdSource::Continuity,
        state,
        merged: false,
        estimate,
        blob,
        floor: None,
    });
    tracks
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
    /// Frames in which the LED (with several robots, any of them) was found.
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
        summary.found += u64::from(report.tracks.iter().any(|t| t.estimate.is_some()));
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
