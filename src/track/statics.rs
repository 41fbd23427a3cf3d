//! A memory of static bright blobs (a lamp, a window glint, a reflection) that are not the LED.
//!
//! Every blob that is not the tracked LED is matched against this table by position. A blob
//! seen at the same place for [`STATIC_FRAMES`] frames becomes a known distractor, which
//! acquisition then skips. The tracked LED is never entered, so a robot that stops stays
//! tracked: "not moving" alone does not make a distractor.

use heapless::Vec as BoundedVec;

/// How many static blobs are remembered; the oldest unseen one makes room for a new one.
pub const MAX_STATICS: usize = 16;

/// A blob whose mass centre moved less than this since the last frame stands still.
pub const STATIC_TOLERANCE_PX: f32 = 1.0;

/// Frames at the same place before a blob counts as a distractor.
pub const STATIC_FRAMES: u32 = 2;

/// Frames unseen after which a static blob is forgotten (the lamp was switched off).
pub const FORGET_AFTER_FRAMES: u64 = 300;

#[derive(Debug, Clone, Copy)]
struct Static {
    position_px: (f32, f32),
    seen_frames: u32,
    last_seen_frame: u64,
}

/// The table of static blobs.
#[derive(Debug, Default)]
pub struct Statics {
    entries: BoundedVec<Static, MAX_STATICS>,
}

impl Statics {
    /// True when a known distractor sits at `position_px`.
    pub fn is_distractor(&self, position_px: (f32, f32)) -> bool {
        self.entries
            .iter()
            .any(|e| e.seen_frames >= STATIC_FRAMES && near(e.position_px, position_px))
    }

    /// True when a blob stood at `position_px` in the frame before `frame_index` too.
    pub fn stood_still(&self, position_px: (f32, f32), frame_index: u64) -> bool {
        self.entries
            .iter()
            .any(|e| e.last_seen_frame + 1 == frame_index && near(e.position_px, position_px))
    }

    /// Notes a blob that is not the LED, seen in frame `frame_index`.
    pub fn observe(&mut self, position_px: (f32, f32), frame_index: u64) {
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
            }
            e.position_px = position_px;
            e.last_seen_frame = frame_index;
            return;
        }
        let entry = Static {
            position_px,
            seen_frames: 1,
            last_seen_frame: frame_index,
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

fn near(a: (f32, f32), b: (f32, f32)) -> bool {
    (a.0 - b.0).hypot(a.1 - b.1) <= STATIC_TOLERANCE_PX
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_blob_at_the_same_place_becomes_a_distractor_and_is_forgotten_later() {
        let mut s = Statics::default();
        s.observe((10.0, 10.0), 0);
        assert!(!s.is_distractor((10.0, 10.0)));
        assert!(s.stood_still((10.2, 10.1), 1));
        assert!(
            !s.stood_still((10.2, 10.1), 2),
            "only the frame just before counts"
        );
        assert!(!s.stood_still((15.0, 10.0), 1));
        s.observe((10.2, 10.1), 1);
        assert!(s.is_distractor((10.0, 10.0)));
        assert!(!s.is_distractor((20.0, 10.0)));
        s.expire(1 + FORGET_AFTER_FRAMES + 1);
        assert!(!s.is_distractor((10.0, 10.0)));
    }

    #[test]
    fn a_blob_that_keeps_moving_never_does() {
        let mut s = Statics::default();
        for i in 0..20u64 {
            s.observe((5.0 * i as f32, 0.0), i);
        }
        assert!((0..20).all(|i| !s.is_distractor((5.0 * i as f32, 0.0))));
    }

    #[test]
    fn a_full_table_replaces_the_oldest_entry() {
        let mut s = Statics::default();
        for i in 0..(MAX_STATICS as u64 + 1) {
            s.observe((10.0 * i as f32, 0.0), i);
            s.observe((10.0 * i as f32, 0.0), i + 1);
        }
        assert!(!s.is_distractor((0.0, 0.0)), "the oldest made room");
        assert!(s.is_distractor((10.0 * MAX_STATICS as f32, 0.0)));
    }
}
