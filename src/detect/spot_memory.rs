//! The fitted spot of each LED, kept from one frame to the next so that the next fit of the
//! same LED starts warm ([`SpotFit`]).
//!
//! An LED is recognised by place, not by the tracker's identity: a spot fitted in one of the
//! last [`MAX_AGE_FRAMES`] frames whose middle lies within reach of this streak's (as far as
//! the LED can have moved since: its path's length for each exposure time since, when the
//! exposure is known, else its path's length; and a margin). Each remembered spot
//! starts at most one fit a frame, so a second blob beside the LED starts cold; a spot not
//! fitted for longer (the LED lost, or read by the ramps) is forgotten, and so is one whose fit
//! failed. Fixed memory: one slot per LED the detector keeps apart ([`MAX_KEEP_OUT`]), the
//! oldest reused first.

use super::fit::{PathFit, SpotFit};
use super::{KEEP_OUT_MARGIN_PX, MAX_KEEP_OUT};

/// A spot is remembered for this many frames after its fit: the previous frame's, or the
/// one before when a frame in between was read otherwise.
pub const MAX_AGE_FRAMES: u64 = 2;

/// How much faster than during its fitted exposure an LED is allowed to be moving by the
/// next frames, for the reach: the independent scenes' accelerating lines lengthen their
/// streaks by up to half from one frame to the next.
const MAX_SPEEDUP: f32 = 1.5;

/// The spots fitted in the last frames, by place.
pub struct SpotMemory {
    slots: [Option<Slot>; MAX_KEEP_OUT],
    /// The frame being analysed.
    frame: u64,
    /// Its time (µs).
    t_us: u64,
    /// The camera's exposure time, when known (µs): how long the LED took to sweep a
    /// streak, and so how far it goes in the time between two frames.
    exposure_us: Option<u32>,
}

#[derive(Clone, Copy)]
struct Slot {
    mid_px: (f32, f32),
    /// The fitted path's length: how far the LED moved in one exposure.
    path_length_px: f32,
    /// The frame of the fit, and its time (µs).
    frame: u64,
    t_us: u64,
    spot: SpotFit,
}

impl SpotMemory {
    /// An empty memory for a camera whose exposure time is `exposure_us` (`None` when
    /// unknown).
    pub fn new(exposure_us: Option<u32>) -> Self {
        SpotMemory {
            slots: [None; MAX_KEEP_OUT],
            frame: 0,
            t_us: 0,
            exposure_us,
        }
    }

    /// Starts a new frame, taken at `t_us`: the spots fitted so far are one frame older.
    pub fn next_frame(&mut self, t_us: u64) {
        self.frame += 1;
        self.t_us = t_us;
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
        let (frame, t_us) = (self.frame, self.t_us);
        if let Some(slot) = self.slots.get_mut(index) {
            *slot = found.as_ref().ok().map(|f| Slot {
                mid_px: f.mid_px,
                path_length_px: f.path_length_px,
                frame,
                t_us,
                spot: f.spot,
            });
        }
        found
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
    fn reach_px(&self, slot: &Slot) -> f32 {
        let exposures = match self.exposure_us {
            Some(exposure_us) if exposure_us > 0 => {
                let since_us = self.t_us.saturating_sub(slot.t_us);
                (MAX_SPEEDUP * since_us as f32 / exposure_us as f32).max(1.0)
            }
            _ => 1.0,
        };
        slot.path_length_px * exposures + KEEP_OUT_MARGIN_PX as f32
    }

    /// The nearest slot fitted in an earlier recent frame that reaches `mid_px`.
    fn recall(&self, mid_px: (f32, f32)) -> Option<usize> {
        let distance = |s: &Slot| (s.mid_px.0 - mid_px.0).hypot(s.mid_px.1 - mid_px.1);
        self.slots
            .iter()
            .enumerate()
            .filter_map(|(i, s)| s.as_ref().map(|s| (i, s)))
            .filter(|(_, s)| s.frame < self.frame && s.frame + MAX_AGE_FRAMES >= self.frame)
            .filter(|(_, s)| distance(s) <= self.reach_px(s))
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
        let mut memory = SpotMemory::new(None);
        memory.next_frame(0);
        assert_eq!(start_at(&mut memory, (100.0, 100.0), 1.0), None);
        // Not in the frame that fitted it, and not far away.
        assert_eq!(start_at(&mut memory, (102.0, 100.0), 2.0), None);
        memory.next_frame(0);
        assert_eq!(start_at(&mut memory, (400.0, 100.0), 3.0), None);
        // The nearer of the two, within its path's length and the margin.
        let near = start_at(&mut memory, (120.0, 110.0), 4.0);
        assert!(near == Some(SpotFit::with_cost(2.0)) || near == Some(SpotFit::with_cost(1.0)));
        // Each spot starts one fit a frame: the other one is left for a second blob.
        let second = start_at(&mut memory, (118.0, 108.0), 5.0);
        assert!(second.is_some() && second != near, "{second:?}");
        assert_eq!(start_at(&mut memory, (119.0, 109.0), 6.0), None);
    }

    /// A fitted path of 20 px (see [`fitted`]) swept in a 4 ms exposure, frames 33.3 ms apart:
    /// at a steady speed the LED's next middle lies 166.7 px on.
    #[test]
    fn a_short_exposure_s_spot_is_recalled_as_far_as_its_led_can_have_gone() {
        const FRAME_US: u64 = 33_333;
        let steady_px = 20.0 * FRAME_US as f32 / 4_000.0;
        let mut memory = SpotMemory::new(Some(4_000));
        memory.next_frame(0);
        start_at(&mut memory, (100.0, 100.0), 1.0);
        memory.next_frame(FRAME_US);
        let next = (100.0 + steady_px, 100.0);
        assert_eq!(
            start_at(&mut memory, next, 2.0),
            Some(SpotFit::with_cost(1.0))
        );
        // Twice as fast as during its exposure: another LED, or none.
        memory.next_frame(2 * FRAME_US);
        let far = (next.0 + 2.0 * steady_px, 100.0);
        assert_eq!(start_at(&mut memory, far, 3.0), None);
        // Two frames on (the frame between read otherwise), twice as far is in reach.
        memory.next_frame(3 * FRAME_US);
        let later = (next.0 - 2.0 * steady_px, 100.0);
        assert_eq!(
            start_at(&mut memory, later, 4.0),
            Some(SpotFit::with_cost(2.0))
        );

        // With the exposure unknown, the LED is taken to move its path's length and the
        // margin a frame: the steady LED's next middle is out of reach.
        let mut unknown = SpotMemory::new(None);
        unknown.next_frame(0);
        start_at(&mut unknown, (100.0, 100.0), 1.0);
        unknown.next_frame(FRAME_US);
        assert_eq!(start_at(&mut unknown, next, 2.0), None);
        unknown.next_frame(2 * FRAME_US);
        let beside = (next.0 + 20.0 + KEEP_OUT_MARGIN_PX as f32 - 1.0, 100.0);
        assert_eq!(
            start_at(&mut unknown, beside, 3.0),
            Some(SpotFit::with_cost(2.0))
        );
    }

    #[test]
    fn a_spot_not_fitted_for_long_or_failed_is_forgotten() {
        let mut memory = SpotMemory::new(None);
        memory.next_frame(0);
        start_at(&mut memory, (100.0, 100.0), 1.0);
        for _ in 0..=MAX_AGE_FRAMES {
            memory.next_frame(0);
        }
        assert_eq!(start_at(&mut memory, (100.0, 100.0), 2.0), None);
        memory.next_frame(0);
        assert!(memory
            .fit_at((100.0, 100.0), |warm| {
                assert_eq!(warm, Some(&SpotFit::with_cost(2.0)));
                Err(())
            })
            .is_err());
        memory.next_frame(0);
        assert_eq!(start_at(&mut memory, (100.0, 100.0), 3.0), None);
    }
}
