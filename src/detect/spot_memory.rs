//! The fitted spot of each LED, kept from one frame to the next so that the next fit of the
//! same LED starts warm ([`SpotFit`]).
//!
//! An LED is recognised by place, not by the tracker's identity: a spot fitted in one of the
//! last [`MAX_AGE_FRAMES`] frames whose middle lies within its path's length and
//! [`KEEP_OUT_MARGIN_PX`] of this streak's (the LED moves by about its streak's length between
//! frames). Each remembered spot starts at most one fit a frame, so a second blob beside the
//! LED starts cold; a spot not fitted for longer (the LED lost, or read by the ramps) is
//! forgotten, and so is one whose fit failed. Fixed memory: one slot per LED the detector
//! keeps apart ([`MAX_KEEP_OUT`]), the oldest reused first.

use super::fit::{PathFit, SpotFit};
use super::{KEEP_OUT_MARGIN_PX, MAX_KEEP_OUT};

/// A spot is remembered for this many frames after its fit: the previous frame's, or the
/// one before when a frame in between was read otherwise.
pub const MAX_AGE_FRAMES: u64 = 2;

/// The spots fitted in the last frames, by place.
pub struct SpotMemory {
    slots: [Option<Slot>; MAX_KEEP_OUT],
    /// The frame being analysed.
    frame: u64,
}

#[derive(Clone, Copy)]
struct Slot {
    mid_px: (f32, f32),
    /// How far from `mid_px` the same LED may be in the next frames.
    reach_px: f32,
    /// The frame of the fit.
    frame: u64,
    spot: SpotFit,
}

impl Default for SpotMemory {
    fn default() -> Self {
        SpotMemory {
            slots: [None; MAX_KEEP_OUT],
            frame: 0,
        }
    }
}

impl SpotMemory {
    /// Starts a new frame: the spots fitted so far are one frame older.
    pub fn next_frame(&mut self) {
        self.frame += 1;
    }

    /// Runs `fit` for the streak whose rough middle is `mid_px`, given the spot remembered
    /// there (if any), and remembers what it fitted in that spot's place (or the oldest).
    pub fn fit_at<E>(
        &mut self,
        mid_px: (f32, f32),
        fit: impl FnOnce(Option<&SpotFit>) -> Result<PathFit, E>,
    ) -> Result<PathFit, E> {
        let known = self.recall(mid_px);
        let found = fit(known.and_then(|i| self.slots.get(i)?.as_ref().map(|s| &s.spot)));
        let index = known.unwrap_or_else(|| self.oldest());
        if let Some(slot) = self.slots.get_mut(index) {
            *slot = found.as_ref().ok().map(|f| Slot {
                mid_px: f.mid_px,
                reach_px: f.path_length_px + KEEP_OUT_MARGIN_PX as f32,
                frame: self.frame,
                spot: f.spot,
            });
        }
        found
    }

    /// The nearest slot fitted in an earlier recent frame that reaches `mid_px`.
    fn recall(&self, mid_px: (f32, f32)) -> Option<usize> {
        let distance = |s: &Slot| (s.mid_px.0 - mid_px.0).hypot(s.mid_px.1 - mid_px.1);
        self.slots
            .iter()
            .enumerate()
            .filter_map(|(i, s)| s.as_ref().map(|s| (i, s)))
            .filter(|(_, s)| s.frame < self.frame && s.frame + MAX_AGE_FRAMES >= self.frame)
            .filter(|(_, s)| distance(s) <= s.reach_px)
            .min_by(|(_, s), (_, t)| distance(s).total_cmp(&distance(t)))
            .map(|(i, _)| i)
    }

    /// An empty slot, else the one fitted longest ago.
    fn oldest(&self) -> usize {
        self.slots
            .iter()
            .enumerate()
            .min_by_key(|(_, s)| s.map_or(0, |s| s.frame + 1))
            .map_or(0, |(i, _)| i)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A fit at `mid_px` of a path `length_px` long whose spot is told by its cost.
    fn fitted(mid_px: (f32, f32), length_px: f32, cost: f32) -> PathFit {
        PathFit {
            ends_px: [mid_px; 2],
            mid_px,
            path_length_px: length_px,
            ideal_path_length_px: length_px,
            spot_sigma_px: 1.0,
            noise_px: 0.1,
            length_noise_px: 0.1,
            uncertainty_px: 0.1,
            floor_measured: 1.0,
            spot: SpotFit::with_cost(cost),
        }
    }

    /// What a fit at `mid_px` is given to start from, as the cost of that spot.
    fn start_at(memory: &mut SpotMemory, mid_px: (f32, f32), cost: f32) -> Option<SpotFit> {
        let mut given = None;
        let _ = memory.fit_at(mid_px, |warm| {
            given = warm.copied();
            Ok::<_, ()>(fitted(mid_px, 20.0, cost))
        });
        given
    }

    #[test]
    fn a_spot_starts_the_next_fit_nearby_once() {
        let mut memory = SpotMemory::default();
        memory.next_frame();
        assert_eq!(start_at(&mut memory, (100.0, 100.0), 1.0), None);
        // Not in the frame that fitted it, and not far away.
        assert_eq!(start_at(&mut memory, (102.0, 100.0), 2.0), None);
        memory.next_frame();
        assert_eq!(start_at(&mut memory, (400.0, 100.0), 3.0), None);
        // The nearer of the two, within its path's length and the margin.
        let near = start_at(&mut memory, (120.0, 110.0), 4.0);
        assert!(near == Some(SpotFit::with_cost(2.0)) || near == Some(SpotFit::with_cost(1.0)));
        // Each spot starts one fit a frame: the other one is left for a second blob.
        let second = start_at(&mut memory, (118.0, 108.0), 5.0);
        assert!(second.is_some() && second != near, "{second:?}");
        assert_eq!(start_at(&mut memory, (119.0, 109.0), 6.0), None);
    }

    #[test]
    fn a_spot_not_fitted_for_long_or_failed_is_forgotten() {
        let mut memory = SpotMemory::default();
        memory.next_frame();
        start_at(&mut memory, (100.0, 100.0), 1.0);
        for _ in 0..=MAX_AGE_FRAMES {
            memory.next_frame();
        }
        assert_eq!(start_at(&mut memory, (100.0, 100.0), 2.0), None);
        memory.next_frame();
        assert!(memory
            .fit_at((100.0, 100.0), |warm| {
                assert_eq!(warm, Some(&SpotFit::with_cost(2.0)));
                Err(())
            })
            .is_err());
        memory.next_frame();
        assert_eq!(start_at(&mut memory, (100.0, 100.0), 3.0), None);
    }
}
