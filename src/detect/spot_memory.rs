//! The fitted spot of each LED, kept from one frame to the next so that the next fit of the
//! same LED starts warm ([`SpotFit`]).
//!
//! An LED is recognised by place ([`PlaceMemory`]). A spot not fitted for longer than
//! [`MAX_AGE_FRAMES`](super::place_memory::MAX_AGE_FRAMES) (the LED lost, or read by the
//! ramps) is forgotten, and so is one whose fit failed.

use super::fit::{PathFit, SpotFit};
use super::place_memory::{Place, PlaceMemory};

/// The spots fitted in the last frames, by place.
#[derive(Clone)]
pub struct SpotMemory {
    places: PlaceMemory<SpotFit>,
}

impl SpotMemory {
    /// An empty memory for a camera whose exposure time is `exposure_us` (`None` when
    /// unknown).
    pub fn new(exposure_us: Option<u32>) -> Self {
        SpotMemory {
            places: PlaceMemory::new(exposure_us),
        }
    }

    /// Starts a new frame, taken at `t_us`: the spots fitted so far are one frame older.
    pub fn next_frame(&mut self, t_us: u64) {
        self.places.next_frame(t_us);
    }

    /// Whether a spot fitted in a recent frame is remembered for the streak whose rough middle
    /// is `mid_px`, so that [`SpotMemory::fit_at`] would start from it: the LED was fitted
    /// there, and its fit held.
    pub fn remembers(&self, mid_px: (f32, f32)) -> bool {
        let recalled = self.places.recall(mid_px);
        self.places.value(&recalled).is_some()
    }

    /// Runs `fit` for the streak whose rough middle is `mid_px`, given the spot remembered
    /// there (if any), and remembers what it fitted in that spot's place (or the oldest).
    pub fn fit_at<E>(
        &mut self,
        mid_px: (f32, f32),
        fit: impl FnOnce(Option<&SpotFit>) -> Result<PathFit, E>,
    ) -> Result<PathFit, E> {
        let known = self.places.recall(mid_px);
        let found = fit(self.places.value(&known));
        let place = found.as_ref().ok().map(|f| Place {
            mid_px: f.mid_px,
            path_length_px: f.path_length_px,
            value: f.spot,
        });
        self.places.store(known, place);
        found
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::detect::place_memory::MAX_AGE_FRAMES;
    use crate::detect::KEEP_OUT_MARGIN_PX;

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
            length_deviation_px: 0.1,
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
