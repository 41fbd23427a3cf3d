//! A memory of bright blobs that are not the LED (a lamp, a window glint, a reflection, and
//! before acquisition everything in view), by place.
//!
//! Every blob that is not the tracked LED is matched against this table by position. A blob
//! seen at the same place for [`STATIC_FRAMES`] frames is a distractor: it has stood still since
//! it appeared there. An entry follows its blob by less than [`STATIC_TOLERANCE_PX`] a frame,
//! but keeps the place where the blob first appeared, so that a blob creeping away from it
//! (a robot starting slowly) counts as moved once it is [`DRIFT_PX`] from that place. A
//! distractor seen while the LED was tracked elsewhere is *cleared*: certainly not the LED.
//! The tracked LED is never entered, so a robot that stops stays tracked: "not moving" alone
//! does not make a distractor.

use heapless::Vec as BoundedVec;

/// How many static blobs are remembered; the oldest unseen one makes room for a new one.
pub const MAX_STATICS: usize = 16;

/// A blob whose mass centre moved less than this since the last frame stands still.
pub const STATIC_TOLERANCE_PX: f32 = 1.0;

/// A blob this far from where it first appeared has moved, however slowly it went.
pub const DRIFT_PX: f32 = 2.0;

/// Frames at the same place before a blob counts as a distractor.
pub const STATIC_FRAMES: u32 = 2;

/// Frames unseen after which a static blob is forgotten (the lamp was switched off).
pub const FORGET_AFTER_FRAMES: u64 = 300;

#[derive(Debug, Clone, Copy)]
struct Static {
    position_px: (f32, f32),
    origin_px: (f32, f32),
    seen_frames: u32,
    last_seen_frame: u64,
    cleared: bool,
}

impl Static {
    fn drifted(&self) -> bool {
        dist(self.origin_px, self.position_px) > DRIFT_PX
    }
}

/// What the table knows of a blob at some place.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Known {
    /// Nothing stood there long: it may be the LED.
    Fresh,
    /// It has stood still since it appeared, but only while no LED was tracked: it is not the
    /// LED now, yet it may turn out to be one (a robot at rest) once it moves.
    Still,
    /// It stood still while the LED was tracked elsewhere: never the LED.
    Cleared,
}

/// The table of static blobs.
#[derive(Debug, Default)]
pub struct Statics {
    entries: BoundedVec<Static, MAX_STATICS>,
}

impl Statics {
    /// What is known of a blob at `position_px`.
    pub fn known(&self, position_px: (f32, f32)) -> Known {
        let entry = self.entries.iter().find(|e| {
            e.seen_frames >= STATIC_FRAMES && !e.drifted() && near(e.position_px, position_px)
        });
        match entry {
            None => Known::Fresh,
            Some(e) if e.cleared => Known::Cleared,
            Some(_) => Known::Still,
        }
    }

    /// True when a blob stood at `position_px` in the frame before `frame_index` too, and
    /// has not drifted from where it first appeared.
    pub fn stood_still(&self, position_px: (f32, f32), frame_index: u64) -> bool {
        self.entries.iter().any(|e| {
            e.last_seen_frame + 1 == frame_index && !e.drifted() && near(e.position_px, position_px)
        })
    }

    /// True when a blob at `position_px` continues one of the frame before `frame_index` that
    /// has crept more than [`DRIFT_PX`] from where it first appeared.
    pub fn crept(&self, position_px: (f32, f32), frame_index: u64) -> bool {
        self.entries.iter().any(|e| {
            e.last_seen_frame + 1 == frame_index
                && near(e.position_px, position_px)
                && dist(e.origin_px, position_px) > DRIFT_PX
        })
    }

    /// True when a blob of the frame before `frame_index` is at none of `positions` now: it
    /// went somewhere (or out).
    pub fn any_vanished(
        &self,
        positions: impl Iterator<Item = (f32, f32)> + Clone,
        frame_index: u64,
    ) -> bool {
        self.entries.iter().any(|e| {
            e.last_seen_frame + 1 == frame_index
                && !positions.clone().any(|p| near(e.position_px, p))
        })
    }

    /// Where the blob of the frame before `frame_index` nearest `position_px` was, when one
    /// was there and is not at `position_px` now: the place a blob that moved came from.
    pub fn came_from(&self, position_px: (f32, f32), frame_index: u64) -> Option<(f32, f32)> {
        self.entries
            .iter()
            .filter(|e| e.last_seen_frame + 1 == frame_index && !near(e.position_px, position_px))
            .map(|e| e.position_px)
            .min_by(|a, b| dist(*a, position_px).total_cmp(&dist(*b, position_px)))
    }

    /// Notes a blob that is not the LED, seen in frame `frame_index`; `led_elsewhere` when
    /// the LED was tracked elsewhere in that frame.
    pub fn observe(&mut self, position_px: (f32, f32), frame_index: u64, led_elsewhere: bool) {
        if let Some(e) = self
            .entries
            .iter_mut()
            .find(|e| near(e.position_px, position_px))
        {
            // Seen again next frame at the same place: one more static frame.
            if e.last_seen_frame + 1 == frame_index {
                e.seen_frames += 1;
            } else if e.last_seen_frame != frame_index {
                e.seen_frames = 1;
                e.origin_px = position_px;
            }
            e.position_px = position_px;
            e.last_seen_frame = frame_index;
            e.cleared |= led_elsewhere;
            return;
        }
        let entry = Static {
            position_px,
            origin_px: position_px,
            seen_frames: 1,
            last_seen_frame: frame_index,
            cleared: led_elsewhere,
        };
        if let Err(entry) = self.entries.push(entry) {
            if let Some(oldest) = self.entries.iter_mut().min_by_key(|e| e.last_seen_frame) {
                *oldest = entry;
            }
        }
    }

    /// Forgets blobs unseen for a long time.
    pub fn expire(&mut self, frame_index: u64) {
        self.entries
            .retain(|e| frame_index.saturating_sub(e.last_seen_frame) <= FORGET_AFTER_FRAMES);
    }
}

fn dist(a: (f32, f32), b: (f32, f32)) -> f32 {
    (a.0 - b.0).hypot(a.1 - b.1)
}

fn near(a: (f32, f32), b: (f32, f32)) -> bool {
    dist(a, b) <= STATIC_TOLERANCE_PX
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_blob_at_the_same_place_becomes_a_distractor_and_is_forgotten_later() {
        let mut s = Statics::default();
        s.observe((10.0, 10.0), 0, false);
        assert_eq!(s.known((10.0, 10.0)), Known::Fresh);
        assert!(s.stood_still((10.2, 10.1), 1));
        assert!(
            !s.stood_still((10.2, 10.1), 2),
            "only the frame just before counts"
        );
        assert!(!s.stood_still((15.0, 10.0), 1));
        s.observe((10.2, 10.1), 1, false);
        assert_eq!(s.known((10.0, 10.0)), Known::Still);
        assert_eq!(s.known((20.0, 10.0)), Known::Fresh);
        s.observe((10.1, 10.1), 2, true);
        assert_eq!(s.known((10.0, 10.0)), Known::Cleared);
        s.expire(2 + FORGET_AFTER_FRAMES + 1);
        assert_eq!(s.known((10.0, 10.0)), Known::Fresh);
    }

    #[test]
    fn a_blob_that_keeps_moving_never_does() {
        let mut s = Statics::default();
        for i in 0..20u64 {
            s.observe((5.0 * i as f32, 0.0), i, false);
        }
        assert!((0..20).all(|i| s.known((5.0 * i as f32, 0.0)) == Known::Fresh));
        assert!(s.any_vanished([(100.0, 0.0)].into_iter(), 20));
        assert!(!s.any_vanished([(95.0, 0.0)].into_iter(), 20));
    }

    #[test]
    fn a_blob_creeping_from_where_it_appeared_has_moved() {
        let mut s = Statics::default();
        for i in 0..10u64 {
            s.observe((0.5 * i as f32, 0.0), i, false);
            if i == 2 {
                assert_eq!(s.known((1.0, 0.0)), Known::Still, "1 px from its origin");
            }
        }
        // 0.5 px a frame never breaks the match, but 4.5 px from its origin it has moved.
        assert_eq!(s.known((4.5, 0.0)), Known::Fresh);
        assert!(!s.stood_still((5.0, 0.0), 10));
    }

    #[test]
    fn a_full_table_replaces_the_oldest_entry() {
        let mut s = Statics::default();
        for i in 0..(MAX_STATICS as u64 + 1) {
            s.observe((10.0 * i as f32, 0.0), i, false);
            s.observe((10.0 * i as f32, 0.0), i + 1, false);
        }
        assert_eq!(s.known((0.0, 0.0)), Known::Fresh, "the oldest made room");
        assert_eq!(s.known((10.0 * MAX_STATICS as f32, 0.0)), Known::Still);
    }
}
