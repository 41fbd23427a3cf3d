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
    /// A speck beside a much larger blob when last seen (see [`crate::detect::satellite`]): never
    /// the LED, nor where the LED came from.
    satellite: bool,
}

impl Static {
    fn drifted(&self) -> bool {
        dist(self.origin_px, self.position_px) > DRIFT_PX
    }

    /// The blob of the last frame, now at `position_px`, has not drifted from where it first
    /// appeared, as of the last frame nor now: a blob that crosses [`DRIFT_PX`] in this
    /// frame has moved in this frame, not in the next one.
    fn still_at(&self, position_px: (f32, f32)) -> bool {
        !self.drifted()
            && dist(self.origin_px, position_px) <= DRIFT_PX
            && near(self.position_px, position_px)
    }

    /// It has stood still since it appeared: a lamp, not a light moving with a body.
    fn standing(&self) -> bool {
        self.seen_frames >= STATIC_FRAMES && !self.drifted()
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
        let entry = self
            .entries
            .iter()
            .find(|e| e.seen_frames >= STATIC_FRAMES && e.still_at(position_px));
        match entry {
            None => Known::Fresh,
            Some(e) if e.cleared => Known::Cleared,
            Some(_) => Known::Still,
        }
    }

    /// True when a blob stood at `position_px` in the frame before `frame_index` too, and
    /// has not drifted from where it first appeared, then or now.
    pub fn stood_still(&self, position_px: (f32, f32), frame_index: u64) -> bool {
        self.entries
            .iter()
            .any(|e| e.last_seen_frame + 1 == frame_index && e.still_at(position_px))
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

    /// Where a blob now at `position_px` that moved came from: a blob of the frame before
    /// `frame_index` that is not at `position_px` now, was not standing still and was no
    /// satellite (a speck beside a larger blob, which flickers as if it moved). Of those, the
    /// one whose displacement to `position_px` carries most of that frame's blobs onto blobs
    /// of this frame (`now`), within [`DRIFT_PX`]: LEDs on one robot move together, so the
    /// right origin explains the others' motion too, where the nearest may be another LED of
    /// the row when the robot moves more than half their spacing a frame. Among equals, the
    /// nearest. Failing any, the same choice among blobs that stood still and are gone now:
    /// an LED that starts from rest leaves such a place, while a lamp still stands on its own.
    pub fn came_from(
        &self,
        position_px: (f32, f32),
        frame_index: u64,
        now: impl Iterator<Item = (f32, f32)> + Clone,
    ) -> Option<(f32, f32)> {
        let now = &now;
        let before = move |resting: bool| {
            self.entries
                .iter()
                .filter(move |e| {
                    let gone = || !now.clone().any(|p| near(e.position_px, p));
                    e.last_seen_frame + 1 == frame_index
                        && !e.satellite
                        && if resting {
                            e.standing() && gone()
                        } else {
                            !e.standing()
                        }
                })
                .map(|e| e.position_px)
        };
        let explained = |origin: (f32, f32), resting: bool| {
            let d = (position_px.0 - origin.0, position_px.1 - origin.1);
            before(resting)
                .filter(|b| {
                    let carried = (b.0 + d.0, b.1 + d.1);
                    now.clone().any(|p| dist(p, carried) <= DRIFT_PX)
                })
                .count()
        };
        let origin = |resting: bool| {
            before(resting)
                .filter(|&origin| !near(origin, position_px))
                .map(|origin| {
                    let count = explained(origin, resting);
                    (origin, count, dist(origin, position_px))
                })
                .max_by(|a, b| a.1.cmp(&b.1).then(b.2.total_cmp(&a.2)))
                .map(|(origin, _, _)| origin)
        };
        origin(false).or_else(|| origin(true))
    }

    /// Notes a blob that is not the LED, seen in frame `frame_index`; `led_elsewhere` when
    /// the LED was tracked elsewhere in that frame, `satellite` when it lay beside a much
    /// larger blob.
    pub fn observe(
        &mut self,
        position_px: (f32, f32),
        frame_index: u64,
        led_elsewhere: bool,
        satellite: bool,
    ) {
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
            e.satellite = satellite;
            return;
        }
        let entry = Static {
            position_px,
            origin_px: position_px,
            seen_frames: 1,
            last_seen_frame: frame_index,
            cleared: led_elsewhere,
            satellite,
        };
        if let Err(entry) = self.entries.push(entry) {
            if let Some(oldest) = self.entries.iter_mut().min_by_key(|e| e.last_seen_frame) {
                *oldest = entry;
            }
        }
    }

    /// Forgets the blob at `position_px`: it was the LED (the place a track was acquired
    /// from), and the LED is never a distractor, so that it is taken again when it comes
    /// back there.
    pub fn forget(&mut self, position_px: (f32, f32)) {
        self.entries.retain(|e| !near(e.position_px, position_px));
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
        s.observe((10.0, 10.0), 0, false, false);
        assert_eq!(s.known((10.0, 10.0)), Known::Fresh);
        assert!(s.stood_still((10.2, 10.1), 1));
        assert!(
            !s.stood_still((10.2, 10.1), 2),
            "only the frame just before counts"
        );
        assert!(!s.stood_still((15.0, 10.0), 1));
        s.observe((10.2, 10.1), 1, false, false);
        assert_eq!(s.known((10.0, 10.0)), Known::Still);
        assert_eq!(s.known((20.0, 10.0)), Known::Fresh);
        s.observe((10.1, 10.1), 2, true, false);
        assert_eq!(s.known((10.0, 10.0)), Known::Cleared);
        s.expire(2 + FORGET_AFTER_FRAMES + 1);
        assert_eq!(s.known((10.0, 10.0)), Known::Fresh);
    }

    #[test]
    fn a_blob_that_keeps_moving_never_does() {
        let mut s = Statics::default();
        for i in 0..20u64 {
            s.observe((5.0 * i as f32, 0.0), i, false, false);
        }
        assert!((0..20).all(|i| s.known((5.0 * i as f32, 0.0)) == Known::Fresh));
        assert!(s.any_vanished([(100.0, 0.0)].into_iter(), 20));
        assert!(!s.any_vanished([(95.0, 0.0)].into_iter(), 20));
    }

    #[test]
    fn a_blob_creeping_from_where_it_appeared_has_moved() {
        let mut s = Statics::default();
        for i in 0..10u64 {
            s.observe((0.5 * i as f32, 0.0), i, false, false);
            if i == 2 {
                assert_eq!(s.known((1.0, 0.0)), Known::Still, "1 px from its origin");
            }
        }
        // 0.5 px a frame never breaks the match, but 4.5 px from its origin it has moved.
        assert_eq!(s.known((4.5, 0.0)), Known::Fresh);
        assert!(!s.stood_still((5.0, 0.0), 10));
    }

    #[test]
    fn a_creeping_blob_has_moved_in_the_frame_it_crosses_the_drift() {
        let mut s = Statics::default();
        for i in 0..5u64 {
            s.observe((0.5 * i as f32, 0.0), i, false, false);
        }
        // Last seen 2.0 px from its origin, now 2.5 px: it moved in this frame.
        let here = (2.5, 0.0);
        assert!(s.crept(here, 5));
        assert_eq!(s.known(here), Known::Fresh);
        assert!(!s.stood_still(here, 5));
        // Where it was last seen, it still stands.
        assert_eq!(s.known((2.0, 0.0)), Known::Still);
        assert!(s.stood_still((2.0, 0.0), 5));
    }

    #[test]
    fn an_led_that_starts_from_rest_came_from_its_resting_place_not_from_a_lamp() {
        let mut s = Statics::default();
        for i in 0..4u64 {
            s.observe((100.0, 100.0), i, false, false);
            s.observe((300.0, 200.0), i, false, false);
        }
        // The LED leaves its place; the lamp stays on its own.
        let now = [(103.0, 100.0), (300.0, 200.0)];
        assert_eq!(
            s.came_from((103.0, 100.0), 4, now.into_iter()),
            Some((100.0, 100.0))
        );
        // Something that moved in the frame before is the origin before any resting place.
        s.observe((90.0, 130.0), 3, false, false);
        assert_eq!(
            s.came_from((103.0, 100.0), 4, now.into_iter()),
            Some((90.0, 130.0))
        );
        // The LED's resting place, forgotten, is no distractor when it comes back there.
        assert_eq!(s.known((100.0, 100.0)), Known::Still);
        s.forget((100.0, 100.0));
        assert_eq!(s.known((100.0, 100.0)), Known::Fresh);
        assert_eq!(s.known((300.0, 200.0)), Known::Still, "the lamp is kept");
    }

    #[test]
    fn a_flickering_satellite_is_never_where_the_led_came_from() {
        let mut s = Statics::default();
        for i in 0..4u64 {
            s.observe((100.0, 100.0), i, false, false);
        }
        // A speck beside the LED's glow, which flickered in the frame before: not standing.
        s.observe((103.0, 117.0), 3, false, true);
        // The LED starts off: it came from its resting place, not from the speck.
        let now = [(101.5, 100.0)];
        assert_eq!(
            s.came_from((101.5, 100.0), 4, now.into_iter()),
            Some((100.0, 100.0))
        );
        // The same blob seen as no satellite is an origin.
        s.observe((103.0, 117.0), 3, false, false);
        assert_eq!(
            s.came_from((101.5, 100.0), 4, now.into_iter()),
            Some((103.0, 117.0))
        );
    }

    #[test]
    fn a_full_table_replaces_the_oldest_entry() {
        let mut s = Statics::default();
        for i in 0..(MAX_STATICS as u64 + 1) {
            s.observe((10.0 * i as f32, 0.0), i, false, false);
            s.observe((10.0 * i as f32, 0.0), i + 1, false, false);
        }
        assert_eq!(s.known((0.0, 0.0)), Known::Fresh, "the oldest made room");
        assert_eq!(s.known((10.0 * MAX_STATICS as f32, 0.0)), Known::Still);
    }
}
