//! What was read of each LED in the last frames, recalled by place: the detector does not
//! know the tracker's identities, so an LED is the streak whose middle lies where the same
//! LED's middle can have moved since.
//!
//! A value read in one of the last [`MAX_AGE_FRAMES`] frames is recalled for a streak whose
//! middle lies within reach of the one it was read on (as far as the LED can have moved
//! since: its path's length for each exposure time since, when the exposure is known, else
//! its path's length; and a margin). Each remembered value is recalled at most once a frame,
//! as storing this frame's value takes its slot, so that a second blob beside the LED starts
//! afresh; a value not stored again for longer (the LED lost, or read otherwise) is forgotten.
//! Fixed memory: one slot per LED the detector keeps apart ([`MAX_KEEP_OUT`]), the oldest
//! reused first.

use super::{KEEP_OUT_MARGIN_PX, MAX_KEEP_OUT};

/// A value is remembered for this many frames after it was read: the previous frame's, or
/// the one before when a frame in between was read otherwise.
pub const MAX_AGE_FRAMES: u64 = 2;

/// How much faster than during its last exposure an LED is allowed to be moving by the next
/// frames, for the reach: the independent scenes' accelerating lines lengthen their streaks
/// by up to half from one frame to the next.
const MAX_SPEEDUP: f32 = 1.5;

/// The values read in the last frames, by place.
#[derive(Clone)]
pub struct PlaceMemory<T> {
    slots: [Option<Slot<T>>; MAX_KEEP_OUT],
    /// The frame being analysed.
    frame: u64,
    /// Its time (µs).
    t_us: u64,
    /// The camera's exposure time, when known (µs): how long the LED took to sweep a
    /// streak, and so how far it goes in the time between two frames.
    exposure_us: Option<u32>,
}

/// Where a value was read and what it is.
#[derive(Clone, Copy)]
pub struct Place<T> {
    /// The streak's middle.
    pub mid_px: (f32, f32),
    /// The streak's path length: how far the LED moved in one exposure.
    pub path_length_px: f32,
    /// What was read there.
    pub value: T,
}

#[derive(Clone, Copy)]
struct Slot<T> {
    place: Place<T>,
    /// The frame it was read in, and its time (µs).
    frame: u64,
    t_us: u64,
}

/// A slot recalled for a streak ([`PlaceMemory::recall`]): where that streak's value is
/// stored.
pub struct Recalled(Option<usize>);

impl<T: Copy> PlaceMemory<T> {
    /// An empty memory for a camera whose exposure time is `exposure_us` (`None` when
    /// unknown).
    pub fn new(exposure_us: Option<u32>) -> Self {
        PlaceMemory {
            slots: [None; MAX_KEEP_OUT],
            frame: 0,
            t_us: 0,
            exposure_us,
        }
    }

    /// Starts a new frame, taken at `t_us`: the values read so far are one frame older.
    pub fn next_frame(&mut self, t_us: u64) {
        self.frame += 1;
        self.t_us = t_us;
    }

    /// The slot read in an earlier recent frame nearest the streak whose middle is `mid_px`
    /// now, among those within reach of it.
    pub fn recall(&self, mid_px: (f32, f32)) -> Recalled {
        let distance = |s: &Slot<T>| {
            let m = s.place.mid_px;
            (m.0 - mid_px.0).hypot(m.1 - mid_px.1)
        };
        Recalled(
            self.slots
                .iter()
                .enumerate()
                .filter_map(|(i, s)| s.as_ref().map(|s| (i, s)))
                .filter(|(_, s)| s.frame < self.frame && s.frame + MAX_AGE_FRAMES >= self.frame)
                .filter(|(_, s)| distance(s) <= self.reach_px(s))
                .min_by(|(_, s), (_, t)| distance(s).total_cmp(&distance(t)))
                .map(|(i, _)| i),
        )
    }

    /// The value of a recalled slot.
    pub fn value(&self, recalled: &Recalled) -> Option<&T> {
        let slot = self.slots.get(recalled.0?)?.as_ref()?;
        Some(&slot.place.value)
    }

    /// Stores what this frame read of the streak `recalled` was recalled for, in that slot
    /// (else the oldest); `None` forgets it.
    pub fn store(&mut self, recalled: Recalled, place: Option<Place<T>>) {
        let index = recalled.0.unwrap_or_else(|| self.oldest());
        let (frame, t_us) = (self.frame, self.t_us);
        if let Some(slot) = self.slots.get_mut(index) {
            *slot = place.map(|place| Slot { place, frame, t_us });
        }
    }

    /// How far from the middle of `slot`'s streak the same LED's middle may lie now: its path's
    /// length for each exposure time since (the LED swept that path in one exposure, and a
    /// short exposure at a steady frame rate leaves gaps of several streaks between frames),
    /// at [`MAX_SPEEDUP`], and never less than the path's length, plus
    /// [`KEEP_OUT_MARGIN_PX`] for the streak's own ends. With the exposure unknown, the path's
    /// length and the margin: the LED is taken to move about its streak's length a frame.
    ///
    /// The path's length alone lost the warm start of every frame of a fast LED whose
    /// exposure is shorter than the frame interval (independent 1280×720 scenes: a line
    /// speeding up at 25 of 33 ms, 48–112 px streaks 80–110 px apart), and with it the
    /// light's gradient that the last frame's length gives: its middles stayed 0.4–0.5 px
    /// behind the path's halfway point.
    fn reach_px(&self, slot: &Slot<T>) -> f32 {
        let exposures = match self.exposure_us {
            Some(exposure_us) if exposure_us > 0 => {
                let since_us = self.t_us.saturating_sub(slot.t_us);
                (MAX_SPEEDUP * since_us as f32 / exposure_us as f32).max(1.0)
            }
            _ => 1.0,
        };
        slot.place.path_length_px * exposures + KEEP_OUT_MARGIN_PX as f32
    }

    /// An empty slot, else the one read longest ago.
    fn oldest(&self) -> usize {
        self.slots
            .iter()
            .enumerate()
            .min_by_key(|(_, s)| s.map_or(0, |s| s.frame + 1))
            .map_or(0, |(i, _)| i)
    }
}
