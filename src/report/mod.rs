//! The per-frame report: the one thing the stages fill and the sinks read.
//!
//! The pipeline fills a [`FrameReport`] from each stage's answer (detection, tracks, floor,
//! calibration check) and hands it to the sink; sinks read only this module's types (the
//! stages' own types are re-exported here), never the pipeline. Each robot followed has a
//! [`TrackReport`] carrying its id, where the id came from, and the track's state, so that a
//! sink never recomputes what the tracker knows.
//!
//! # Memory
//!
//! A report is a fixed-size value: at most [`MAX_ROBOTS`] track reports, in a bounded list.

use heapless::Vec as BoundedVec;

pub use crate::detect::blobs::Blob;
pub use crate::detect::streak::Streak;
pub use crate::detect::Detection;
pub use crate::geometry::floor::{FloorEstimate, FloorFix, FloorUnit};
pub use crate::geometry::recheck::CalibStatus;
pub use crate::identify::BlinkRequest;
pub use crate::source::FrameMeta;
pub use crate::track::{
    Estimate, MarkerPose, PositionMethod, TrackState, VelocityMethod, MAX_ROBOTS,
};

/// Where a track's id came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum IdSource {
    /// Followed from frame to frame: only as good as the last time two tracks came close.
    Continuity,
    /// The robot switched its LED off when asked, and this track went dark in exactly those
    /// frames (see `identify`); held since by continuity, but never across a loss or a meeting.
    Blink,
}

impl IdSource {
    /// The name used in the output.
    pub fn name(self) -> &'static str {
        match self {
            IdSource::Continuity => "continuity",
            IdSource::Blink => "blink",
        }
    }
}

/// One robot's track in one frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TrackReport {
    /// The robot's id, 1 ..= the number of robots.
    pub id: u8,
    /// The id is the track's slot, not a robot's confirmed identity: nothing may be sent under
    /// it to a robot.
    pub provisional: bool,
    /// Where the id came from.
    pub id_source: IdSource,
    /// Searching, tracking or coasting.
    pub state: TrackState,
    /// Its light touches another track's in this frame: one blob where two tracks predict, so
    /// `estimate` is that blob's and says nothing of which robot is where.
    pub merged: bool,
    /// Position and velocity in image pixels, when found.
    pub estimate: Option<Estimate>,
    /// The blob the light was found in and its streak, when found.
    pub blob: Option<(Blob, Streak)>,
    /// Floor position, velocity and heading, when a calibration is loaded and it was found.
    pub floor: Option<FloorFix>,
}

/// The tracks of one frame, one per robot followed, in track-slot order (the id order, unless
/// identification has bound the slots to robots in another order).
pub type Tracks = BoundedVec<TrackReport, MAX_ROBOTS>;

/// Everything known about one processed frame.
#[derive(Debug, Clone, PartialEq)]
pub struct FrameReport {
    /// Index, sequence and time of the frame.
    pub meta: FrameMeta,
    /// The LED detection stage's findings (empty when tracking a marker).
    pub detection: Detection,
    /// With one robot: its LED's (or marker's) position and velocity, when found. Positions
    /// are image pixels, (0, 0) the centre of the top-left pixel. With several robots: `None`
    /// (each is in `tracks`).
    pub position: Option<Estimate>,
    /// Several candidates and no way yet to tell the LED from glare (or the tracked marker id
    /// seen twice).
    pub ambiguous: bool,
    /// The tracked marker's corners and heading, when tracking a marker and it was found.
    pub marker: Option<MarkerPose>,
    /// When tracking a marker: the marker detector hit its cost cap on this frame, so part of
    /// the frame was not searched.
    pub markers_capped: bool,
    /// With one robot: floor position, velocity and heading, when a calibration is loaded and
    /// `position` is known.
    pub floor: Option<FloorFix>,
    /// Which calibration the floor numbers used, when its markers are re-checked.
    pub calib: Option<CalibStatus>,
    /// One report per robot followed (one with a single robot, mirroring `position` and
    /// `floor`).
    pub tracks: Tracks,
    /// The LED request identification asks for on this frame: the serial link sends it.
    pub blink: Option<BlinkRequest>,
}

impl FrameReport {
    /// Frame time in seconds since the first frame.
    pub fn t_s(&self) -> f64 {
        self.meta.timestamp_us as f64 * 1e-6
    }

    /// Whether the run follows several robots: then the sinks write one entry per track.
    pub fn several(&self) -> bool {
        self.tracks.len() > 1
    }

    /// The state of the only track (searching without one): what a sink serving a single
    /// robot reports.
    pub fn single_state(&self) -> TrackState {
        self.tracks
            .first()
            .map_or(TrackState::Searching, |t| t.state)
    }
}
