//! Following several LEDs at once (`--robots N`): one [`Tracker`] per robot for its history,
//! head and velocity, one shared table of static blobs, and a global assignment of each
//! frame's candidates to the tracks.
//!
//! Each frame:
//!
//! - Every live track (tracking, or coasting after a loss) predicts where its streak's middle
//!   is and gates around it ([`Tracker::prediction`]). Candidates are assigned to tracks all
//!   at once, minimising the summed distance to the predictions ([`super::assign`]), a track
//!   taking nothing when nothing is in its gate: two robots crossing, or meeting and standing
//!   side by side, each keep their own blob where a nearest-first choice would hand the first
//!   track the other's.
//! - When a track takes nothing while a blob another track took lies inside its gate, the two
//!   lights are one blob: both are reported `merged`, at that blob, and neither track learns
//!   from it (its middle is neither robot's), so each coasts on its own prediction until they
//!   part. The picture cannot tell them apart, so the report says so instead of guessing.
//! - Blobs no track took are matched against the static table ([`super::statics`]): a blob
//!   that has stood still since it appeared is never a track. A free track slot takes a blob
//!   that moved, the largest first, as the single tracker acquires.
//!
//! Ids are track slots, 1 ..= N. A track lost for longer than it is predicted frees its slot;
//! a robot acquired later takes the free slot whose last position was nearest, so a robot that
//! leaves the view and comes back, while the others are followed, gets its id back.

use core::fmt;

use heapless::Vec as BoundedVec;

use crate::detect::blobs::{Blob, MAX_BLOBS};
use crate::detect::satellite::is_satellite;
use crate::detect::streak::Streak;

use super::assign::Assignment;
use super::statics::{Known, Statics};
use super::{dist, Estimate, PositionMethod, Sample, TrackState, Tracker, TrackerConfig};

/// The most robots one run can follow: every per-robot table is sized for this many.
pub const MAX_ROBOTS: usize = 16;

// Every tracked LED's surroundings are kept out of the static map, so that a parked robot is
// never learned as a window.
const _: () = assert!(MAX_ROBOTS <= crate::detect::MAX_KEEP_OUT);

/// A number of robots outside 1 ..= [`MAX_ROBOTS`].
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RobotsOutOfRange(pub usize);

impl fmt::Display for RobotsOutOfRange {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "--robots {} is out of range: glint follows 1 to {MAX_ROBOTS} robots",
            self.0
        )
    }
}

impl core::error::Error for RobotsOutOfRange {}

/// What one track took in a frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct TrackChoice {
    /// The blob (candidate index) that is this robot's light.
    pub blob: Option<usize>,
    /// That blob holds this robot's light and another's.
    pub merged: bool,
}

#[derive(Debug, Default)]
struct Slot {
    tracker: Tracker,
    /// The slot has followed a robot since the start of the run.
    used: bool,
    choice: TrackChoice,
}

/// The tracks of several robots.
#[derive(Debug)]
pub struct MultiTracker {
    config: TrackerConfig,
    slots: BoundedVec<Slot, MAX_ROBOTS>,
    statics: Statics,
    assignment: Assignment,
    /// This frame's candidates, copied once so that the solver can index them.
    candidates: BoundedVec<(usize, Blob), MAX_BLOBS>,
    /// Predicted middle and gate radius of each slot this frame, when live.
    predictions: [Option<((f32, f32), f32)>; MAX_ROBOTS],
    /// The time of the last frame chosen in.
    last_t_us: u64,
}

impl MultiTracker {
    /// Tracks for `robots` robots, 1 ..= [`MAX_ROBOTS`].
    pub fn new(robots: usize, config: TrackerConfig) -> Result<Self, RobotsOutOfRange> {
        if robots == 0 || robots > MAX_ROBOTS {
            return Err(RobotsOutOfRange(robots));
        }
        let mut slots = BoundedVec::new();
        for _ in 0..robots {
            // Cannot fail: robots ≤ MAX_ROBOTS.
            let _ = slots.push(Slot {
                tracker: Tracker::new(config),
                ..Slot::default()
            });
        }
        Ok(MultiTracker {
            config,
            slots,
            statics: Statics::default(),
            assignment: Assignment::default(),
            candidates: BoundedVec::new(),
            predictions: [None; MAX_ROBOTS],
            last_t_us: 0,
        })
    }

    /// The number of robots followed.
    pub fn robots(&self) -> usize {
        self.slots.len()
    }

    /// What track `slot` took in the last frame chosen.
    pub fn choice(&self, slot: usize) -> TrackChoice {
        self.slots
            .get(slot)
            .map_or(TrackChoice::default(), |s| s.choice)
    }

    /// The tracker of `slot`, for its history and state.
    pub fn tracker(&self, slot: usize) -> Option<&Tracker> {
        self.slots.get(slot).map(|s| &s.tracker)
    }

    /// Assigns the candidates (index and blob) of frame `frame_index` at `t_us` to the tracks;
    /// read each track's share with [`MultiTracker::choice`].
    pub fn choose(
        &mut self,
        candidates: impl Iterator<Item = (usize, Blob)>,
        frame_index: u64,
        t_us: u64,
    ) {
        self.candidates.clear();
        for candidate in candidates {
            if self.candidates.push(candidate).is_err() {
                break;
            }
        }
        let previous_t_us = core::mem::replace(&mut self.last_t_us, t_us);
        let frame_us = t_us.saturating_sub(previous_t_us);
        let everything = self.candidates.iter().map(|(_, b)| b.mass_centre_px);
        for (slot, prediction) in self.slots.iter_mut().zip(self.predictions.iter_mut()) {
            slot.choice = TrackChoice::default();
            slot.tracker
                .follow_body(frame_index, t_us, frame_us, everything.clone());
            *prediction = slot.tracker.prediction(t_us);
        }
        self.assign(frame_index, t_us.saturating_sub(previous_t_us));
        self.mark_merged();
        self.acquire(frame_index, previous_t_us);
        self.observe_statics(frame_index);
    }

    /// Live tracks take candidates by the global optimum of summed distances to their
    /// predictions; only blobs that may be a light (not known to stand still) are offered.
    /// As with one LED, a blob that another light of a track's body, carried on with it,
    /// explains better than that track's prediction is not offered to it; nor, while a track
    /// coasts (its gate grown with its lost frames), a blob nearer another track's prediction:
    /// a hidden LED's track does not take its body's other LED from that LED's own track.
    fn assign(&mut self, frame_index: u64, frame_us: u64) {
        let statics = &self.statics;
        let candidates = &self.candidates;
        let predictions = &self.predictions;
        let slots = &self.slots;
        let rows = self.slots.len();
        self.assignment.solve(
            rows,
            candidates.len(),
            |row, column| {
                let ((centre, gate_px), (_, blob)) =
                    (predictions.get(row).copied()??, candidates.get(column)?);
                let here = blob.mass_centre_px;
                if statics.known(here) != Known::Fresh {
                    return None;
                }
                let d = dist(here, centre);
                let tracker = &slots.get(row)?.tracker;
                let everything = candidates.iter().map(|(_, b)| b.mass_centre_px);
                let another =
                    tracker.is_another_light(here, centre, frame_index, frame_us, everything);
                let nearer_another_track = tracker.missed_frames > 0
                    && predictions.iter().take(rows).enumerate().any(|(other, p)| {
                        other != row && p.is_some_and(|(c, _)| dist(here, c) < d)
                    });
                (d <= gate_px && !another && !nearer_another_track).then_some(d)
            },
            |row| predictions.get(row).copied().flatten().map_or(0.0, |p| p.1),
        );
        for (row, slot) in self.slots.iter_mut().enumerate() {
            let column = self.assignment.candidate_of(row);
            slot.choice.blob = column.and_then(|c| candidates.get(c)).map(|(i, _)| *i);
        }
    }

    /// A live track that took nothing while another track's blob lies in its gate and covers
    /// its prediction: one blob where two tracks predict. A blob beside the prediction is
    /// another light (a hidden LED's track, its gate grown while it coasts, does not claim
    /// its robot's other LED).
    fn mark_merged(&mut self) {
        for row in 0..self.slots.len() {
            let Some((centre, gate_px)) = self.predictions.get(row).copied().flatten() else {
                continue;
            };
            if self.slots.get(row).is_none_or(|s| s.choice.blob.is_some()) {
                continue;
            }
            let shared = (0..self.slots.len()).find_map(|other| {
                let index = self.slots.get(other)?.choice.blob?;
                let (_, blob) = self.candidates.iter().find(|(i, _)| *i == index)?;
                (covers(blob, centre) && dist(blob.mass_centre_px, centre) <= gate_px)
                    .then_some((other, index))
            });
            if let Some((other, index)) = shared {
                if let Some(s) = self.slots.get_mut(row) {
                    s.choice = TrackChoice {
                        blob: Some(index),
                        merged: true,
                    };
                }
                if let Some(s) = self.slots.get_mut(other) {
                    s.choice.merged = true;
                }
            }
        }
    }

    /// Free slots (no live track, nothing taken) take blobs that moved, the largest first. A
    /// track starts from where its blob came from (in the frame before, at `previous_t_us`),
    /// as the single tracker's does: its first frame has a velocity, so that its second does
    /// not predict it standing still and take another LED of its robot.
    fn acquire(&mut self, frame_index: u64, previous_t_us: u64) {
        let statics = &self.statics;
        let possible = self
            .candidates
            .iter()
            .filter(|(_, b)| statics.known(b.mass_centre_px) != Known::Cleared);
        let something_went =
            statics.any_vanished(possible.clone().map(|(_, b)| b.mass_centre_px), frame_index);
        loop {
            let slots = &self.slots;
            let taken = |index: usize| slots.iter().any(|s| s.choice.blob == Some(index));
            let mover = possible
                .clone()
                .filter(|(i, _)| !taken(*i))
                .filter(|(_, b)| {
                    let here = b.mass_centre_px;
                    statics.known(here) == Known::Fresh
                        && !statics.stood_still(here, frame_index)
                        && (something_went || statics.crept(here, frame_index))
                        && !is_satellite(b, self.candidates.iter().map(|&(_, o)| o))
                })
                .max_by_key(|(_, b)| b.area_px)
                .copied();
            let Some((index, blob)) = mover else {
                return;
            };
            // The free slot whose robot was last seen nearest; one never used after those.
            let last_seen_px = |s: &Slot| {
                s.tracker
                    .history()
                    .last()
                    .filter(|_| s.used)
                    .map_or(f32::INFINITY, |h| {
                        dist(h.estimate.mid_px, blob.mass_centre_px)
                    })
            };
            let slot = self
                .slots
                .iter_mut()
                .zip(self.predictions.iter())
                .filter(|(s, prediction)| prediction.is_none() && s.choice.blob.is_none())
                .map(|(s, _)| s)
                .min_by(|a, b| last_seen_px(a).total_cmp(&last_seen_px(b)));
            let Some(slot) = slot else {
                return;
            };
            slot.tracker = Tracker::new(self.config);
            slot.tracker.held_since_frame = frame_index;
            let now = self.candidates.iter().map(|(_, b)| b.mass_centre_px);
            slot.tracker.came_from = statics
                .came_from(blob.mass_centre_px, frame_index, now)
                .map(|p| Sample {
                    t_us: previous_t_us,
                    estimate: Estimate {
                        position_px: p,
                        position_method: PositionMethod::Mid,
                        mid_px: p,
                        velocity_px_s: None,
                    },
                });
            slot.used = true;
            slot.choice = TrackChoice {
                blob: Some(index),
                merged: false,
            };
        }
    }

    /// Blobs no track took are remembered by place; they were seen while a light was followed
    /// elsewhere when any track took something. Each track that took its own blob (not
    /// merged) notes every other blob beside it, its body's other lights among them (another
    /// robot's light, which never moves with it, is never taken for one).
    fn observe_statics(&mut self, frame_index: u64) {
        // Where a track acquired in this frame came from was its LED: never a distractor.
        for slot in &self.slots {
            if let Some(origin) = slot.tracker.came_from {
                if slot.tracker.held_since_frame == frame_index {
                    self.statics.forget(origin.estimate.mid_px);
                }
            }
        }
        let candidates = &self.candidates;
        for slot in self.slots.iter_mut() {
            let own = slot.choice.blob.filter(|_| !slot.choice.merged);
            let Some(led_px) = own.and_then(|index| {
                let (_, b) = candidates.iter().find(|(i, _)| *i == index)?;
                Some(b.mass_centre_px)
            }) else {
                continue;
            };
            let others = candidates
                .iter()
                .filter(|(i, _)| Some(*i) != own)
                .map(|(_, b)| b.mass_centre_px);
            slot.tracker.body.observe(frame_index, led_px, others);
        }
        let led_elsewhere = self.slots.iter().any(|s| s.choice.blob.is_some());
        for (index, blob) in &self.candidates {
            if self.slots.iter().any(|s| s.choice.blob == Some(*index)) {
                continue;
            }
            let satellite = is_satellite(blob, self.candidates.iter().map(|&(_, b)| b));
            self.statics
                .observe(blob.mass_centre_px, frame_index, led_elsewhere, satellite);
        }
        self.statics.expire(frame_index);
    }

    /// Updates track `slot` with the frame at `t_us`: `streak` is its blob's geometry, or
    /// `None` when it was not found. A merged track coasts on its own prediction and reports
    /// the shared blob's middle. Returns the estimate for a found frame.
    pub fn update(&mut self, slot: usize, t_us: u64, streak: Option<&Streak>) -> Option<Estimate> {
        let s = self.slots.get_mut(slot)?;
        if s.choice.merged {
            s.tracker.update(t_us, None);
            return streak.map(|streak| Estimate {
                position_px: streak.mid_px,
                position_method: PositionMethod::Mid,
                mid_px: streak.mid_px,
                velocity_px_s: None,
            });
        }
        s.tracker.update(t_us, streak)
    }

    /// The state of track `slot` after its update: a merged track's light is in view.
    pub fn state(&self, slot: usize) -> TrackState {
        match self.slots.get(slot) {
            Some(s) if s.choice.merged && s.choice.blob.is_some() => TrackState::Tracking,
            Some(s) => s.tracker.state(),
            None => TrackState::Searching,
        }
    }
}

/// True when `point_px` lies on `blob`: inside its bounding box, grown by the distance
/// within which a blob counts as at the same place ([`super::statics::DRIFT_PX`]).
fn covers(blob: &Blob, point_px: (f32, f32)) -> bool {
    let b = &blob.bbox;
    let margin_px = super::statics::DRIFT_PX;
    let inside =
        |v: f32, lo: usize, hi: usize| v >= lo as f32 - margin_px && v <= hi as f32 + margin_px;
    inside(point_px.0, b.x_min_px, b.x_max_px) && inside(point_px.1, b.y_min_px, b.y_max_px)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::detect::blobs::BoundingBox;

    const FRAME_US: u64 = 33_333;

    /// A round blob of 30 px (about 3 px in radius) at `(x, y)`.
    fn blob_at((x, y): (f32, f32)) -> Blob {
        let (x0, y0) = ((x - 3.0).max(0.0) as usize, (y - 3.0).max(0.0) as usize);
        Blob {
            area_px: 30,
            bbox: BoundingBox {
                x_min_px: x0,
                y_min_px: y0,
                x_max_px: x0 + 6,
                y_max_px: y0 + 6,
            },
            mass_centre_px: (x, y),
            elongation: 1.0,
        }
    }

    fn streak_at(mid: (f32, f32)) -> Streak {
        Streak {
            centroid_px: mid,
            seed_point_px: (0, 0),
            mid_px: mid,
            ends_px: [mid, mid],
            skeleton_length_px: 0,
            skeleton_px: 1,
            thickness_px: 6.0,
            path: None,
            path_failed: false,
            cut_ends: [false; 2],
        }
    }

    /// Runs one frame of blobs at `at`; returns, per slot, the position it took (if any) and
    /// whether it was merged.
    fn frame(t: &mut MultiTracker, i: u64, at: &[(f32, f32)]) -> Vec<Option<((f32, f32), bool)>> {
        t.choose(at.iter().map(|&p| blob_at(p)).enumerate(), i, i * FRAME_US);
        (0..t.robots())
            .map(|slot| {
                let c = t.choice(slot);
                let p = c.blob.map(|b| at[b]);
                t.update(slot, i * FRAME_US, p.map(streak_at).as_ref());
                p.map(|p| (p, c.merged))
            })
            .collect()
    }

    #[test]
    fn out_of_range_robot_counts_are_refused() {
        let config = TrackerConfig::default();
        assert_eq!(
            MultiTracker::new(0, config).unwrap_err().to_string(),
            "--robots 0 is out of range: glint follows 1 to 16 robots"
        );
        assert!(MultiTracker::new(MAX_ROBOTS + 1, config).is_err());
        assert_eq!(MultiTracker::new(MAX_ROBOTS, config).unwrap().robots(), 16);
    }

    #[test]
    fn crossing_robots_keep_their_ids_and_glare_is_never_a_track() {
        let mut t = MultiTracker::new(3, TrackerConfig::default()).unwrap();
        let glare = (300.0, 300.0);
        // A moves right along y = 100, B left along y = 112: they pass 12 px apart, inside
        // each other's gate, where a nearest-first choice may hand one the other's blob.
        let a = |i: u64| (100.0 + 8.0 * i as f32, 100.0);
        let b = |i: u64| (300.0 - 8.0 * i as f32, 112.0);
        let mut ids = None;
        for i in 0..30 {
            let got = frame(&mut t, i, &[glare, b(i), a(i)]);
            assert!(got.iter().flatten().all(|(p, _)| *p != glare), "frame {i}");
            if i == 0 {
                assert!(got.iter().all(Option::is_none), "nothing moved yet");
                continue;
            }
            let slot_of = |p| got.iter().position(|g| g.map(|(q, _)| q) == Some(p));
            let now = (slot_of(a(i)).unwrap(), slot_of(b(i)).unwrap());
            assert_eq!(*ids.get_or_insert(now), now, "frame {i}: ids swapped");
        }
        assert_eq!(
            t.state(2),
            TrackState::Searching,
            "the third slot stays free"
        );
    }

    #[test]
    fn one_blob_where_two_tracks_predict_is_merged_on_both() {
        let mut t = MultiTracker::new(2, TrackerConfig::default()).unwrap();
        // Head-on along one line: they overlap exactly at frame 10, then part.
        let a = |i: u64| (100.0 + 10.0 * i as f32, 200.0);
        let b = |i: u64| (300.0 - 10.0 * i as f32, 200.0);
        let mut ids = None;
        for i in 0..21 {
            let at: Vec<(f32, f32)> = if i == 10 {
                vec![a(i)]
            } else {
                vec![a(i), b(i)]
            };
            let got = frame(&mut t, i, &at);
            if i == 0 {
                continue;
            }
            if i == 10 {
                assert_eq!(got, [Some((a(i), true)), Some((a(i), true))]);
                continue;
            }
            assert!(got.iter().flatten().all(|(_, merged)| !merged), "frame {i}");
            let slot_of = |p| got.iter().position(|g| g.map(|(q, _)| q) == Some(p));
            let now = (slot_of(a(i)).unwrap(), slot_of(b(i)).unwrap());
            assert_eq!(*ids.get_or_insert(now), now, "frame {i}: ids swapped");
        }
    }

    #[test]
    fn a_robot_that_leaves_and_comes_back_gets_its_id_back() {
        let mut t = MultiTracker::new(2, TrackerConfig::default()).unwrap();
        let a = |i: u64| (100.0 + 5.0 * i as f32, 100.0);
        let b = |i: u64| (400.0, 100.0 + 5.0 * i as f32);
        let mut b_slot = None;
        for i in 0..80 {
            // B is out of view for frames 20..60, longer than a track coasts.
            let at: Vec<(f32, f32)> = if (20..60).contains(&i) {
                vec![a(i)]
            } else {
                vec![a(i), b(i)]
            };
            let got = frame(&mut t, i, &at);
            if i < 2 || (20..61).contains(&i) {
                continue;
            }
            let slot = got.iter().position(|g| g.map(|(q, _)| q) == Some(b(i)));
            assert!(slot.is_some(), "frame {i}: B not found");
            assert_eq!(*b_slot.get_or_insert(slot), slot, "frame {i}");
        }
    }
}
