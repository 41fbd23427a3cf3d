//! What a track is doing in a frame: the state the report carries, so that no reader has to
//! work it out again from the tracker's constants.

use super::{Tracker, MAX_MISSED_FRAMES};

/// A track's state in one frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum TrackState {
    /// No track: nothing followed, or lost for longer than the tracker predicts.
    #[default]
    Searching,
    /// Found in this frame.
    Tracking,
    /// Not found in this frame, but still predicted: a found candidate inside its gate is
    /// taken as the same light.
    Coasting,
}

impl TrackState {
    /// The name used in the output.
    pub fn name(self) -> &'static str {
        match self {
            TrackState::Searching => "searching",
            TrackState::Tracking => "tracking",
            TrackState::Coasting => "coasting",
        }
    }
}

impl Tracker {
    /// The track's state after the frame just updated: tracking when that frame found the
    /// light, coasting while it is lost for at most [`MAX_MISSED_FRAMES`] frames, searching
    /// before anything was found and after the track expired.
    pub fn state(&self) -> TrackState {
        if self.history.recent().is_none() {
            return TrackState::Searching;
        }
        match self.missed_frames {
            0 => TrackState::Tracking,
            m if m <= MAX_MISSED_FRAMES => TrackState::Coasting,
            _ => TrackState::Searching,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::detect::streak::Streak;
    use crate::track::TrackerConfig;

    #[test]
    fn searching_then_tracking_then_coasting_until_the_track_expires() {
        let mut t = Tracker::new(TrackerConfig::default());
        assert_eq!(t.state(), TrackState::Searching);
        t.update(0, None);
        assert_eq!(t.state(), TrackState::Searching, "nothing found yet");
        let streak = Streak {
            centroid_px: (10.0, 10.0),
            seed_point_px: (10, 10),
            mid_px: (10.0, 10.0),
            ends_px: [(10.0, 10.0); 2],
            skeleton_length_px: 0,
            skeleton_px: 1,
            thickness_px: 6.0,
            path: None,
            path_failed: false,
            cut_ends: [false; 2],
        };
        t.update(1, Some(&streak));
        assert_eq!(t.state(), TrackState::Tracking);
        for i in 0..MAX_MISSED_FRAMES {
            t.update(2 + u64::from(i), None);
            assert_eq!(t.state(), TrackState::Coasting, "missed {}", i + 1);
        }
        t.update(100, None);
        assert_eq!(t.state(), TrackState::Searching, "expired");
        assert_eq!(
            t.prediction(101),
            None,
            "the state agrees with the prediction"
        );
    }
}
