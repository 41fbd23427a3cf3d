//! Each LED's edge falls over its last frames ([`cascade::edge_fall_px`]), so that the
//! cascade judges the LED's edge by their median rather than by one frame's read.
//!
//! A spot's edge is the LED's and the lens's, the same from one frame to the next, but one
//! frame reads it on a few samples through the noise and the floor's texture. On the sweep
//! (`tests/streak_sweep.rs`, seed 11), a Gaussian spot of σ 1.32 px read falls of 0.93–1.30 px
//! over its ten frames, and one of σ 1.50 px 0.93–1.35 px, either side of
//! [`cascade::SHARP_EDGE_PX`], while the sharp disks' frames read 0.5–0.9 px. Judged frame by
//! frame, such an LED passed between the ramps and the fit, which read its length differently
//! (σ 1.32 px on a 12.4 px line: the ramps 11.1–11.6 px, the fit 12.1–12.9 px once settled).
//! An LED is recognised by place ([`PlaceMemory`]).
//!
//! [`cascade::edge_fall_px`]: super::cascade::edge_fall_px
//! [`cascade::SHARP_EDGE_PX`]: super::cascade::SHARP_EDGE_PX

use super::cascade;
use super::place_memory::{Place, PlaceMemory};

/// The falls pooled: this frame's and those of the same LED's last frames. Odd, for a
/// median of one read, and few, for an LED whose spot changes (focus, distance) to be
/// followed within a few frames.
pub const POOLED_FALLS: usize = 5;

/// The last falls read of one LED, oldest first, and whether their median has read
/// resolved in any of its frames remembered.
#[derive(Clone, Copy)]
struct Falls {
    px: [f32; POOLED_FALLS],
    count: usize,
    resolved: bool,
}

/// What an LED's falls say of its edge ([`EdgeMemory::judge`]).
#[derive(Clone, Copy, Debug)]
pub struct EdgeVerdict {
    /// The median of this frame's fall and the LED's last ones (px).
    pub pooled_fall_px: f32,
    /// Whether that median read resolved (beyond [`cascade::SHARP_EDGE_PX`]) in an earlier
    /// frame of the LED's.
    ///
    /// [`cascade::SHARP_EDGE_PX`]: super::cascade::SHARP_EDGE_PX
    pub resolved_before: bool,
}

/// The falls read in the last frames, by place.
#[derive(Clone)]
pub struct EdgeMemory {
    places: PlaceMemory<Falls>,
}

impl EdgeMemory {
    /// An empty memory for a camera whose exposure time is `exposure_us` (`None` when
    /// unknown): how far an LED can move between frames ([`PlaceMemory`]).
    pub fn new(exposure_us: Option<u32>) -> Self {
        EdgeMemory {
            places: PlaceMemory::new(exposure_us),
        }
    }

    /// Starts a new frame, taken at `t_us`: the falls read so far are one frame older.
    pub fn next_frame(&mut self, t_us: u64) {
        self.places.next_frame(t_us);
    }

    /// Judges the edge of the streak whose middle is `mid_px` and whose path is about
    /// `path_length_px` long, from this frame's fall `fall_px` and the falls the same LED read
    /// in its last frames ([`POOLED_FALLS`] in all, at most). A fall not read (`None`) is not
    /// pooled: the edge's light did not fall to a floor within reach, which is the frame's
    /// own finding, not a noisy read of the same edge; the LED's falls are left as they were.
    pub fn judge(
        &mut self,
        mid_px: (f32, f32),
        path_length_px: f32,
        fall_px: Option<f32>,
    ) -> Option<EdgeVerdict> {
        let fall_px = fall_px?;
        let recalled = self.places.recall(mid_px);
        let mut falls = self.places.value(&recalled).copied().unwrap_or(Falls {
            px: [0.0; POOLED_FALLS],
            count: 0,
            resolved: false,
        });
        if falls.count == POOLED_FALLS {
            falls.px.rotate_left(1);
            falls.count -= 1;
        }
        falls.px[falls.count] = fall_px;
        falls.count += 1;
        let verdict = EdgeVerdict {
            pooled_fall_px: median(&falls.px[..falls.count]),
            resolved_before: falls.resolved,
        };
        falls.resolved |= !cascade::is_sharp(verdict.pooled_fall_px);
        let place = Place {
            mid_px,
            path_length_px,
            value: falls,
        };
        self.places.store(recalled, Some(place));
        Some(verdict)
    }
}

/// The median of at most [`POOLED_FALLS`] values (the mean of the middle two of an even
/// count); 0 for none.
fn median(values: &[f32]) -> f32 {
    let mut sorted = [0.0f32; POOLED_FALLS];
    let n = values.len().min(POOLED_FALLS);
    sorted[..n].copy_from_slice(&values[..n]);
    let sorted = &mut sorted[..n];
    sorted.sort_unstable_by(f32::total_cmp);
    match n {
        0 => 0.0,
        _ if n % 2 == 1 => sorted[n / 2],
        _ => 0.5 * (sorted[n / 2 - 1] + sorted[n / 2]),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::detect::place_memory::MAX_AGE_FRAMES;

    /// The median this frame's read of the streak at `mid_px` is judged by.
    fn pooled(memory: &mut EdgeMemory, mid_px: (f32, f32), fall_px: Option<f32>) -> Option<f32> {
        memory
            .judge(mid_px, 10.0, fall_px)
            .map(|v| v.pooled_fall_px)
    }

    /// One LED whose falls read either side of the sharp limit is judged by their median, over
    /// its last five frames; from the frame after its median first read resolved, it is told
    /// so, though the median has gone back under the limit.
    #[test]
    fn an_led_s_falls_are_pooled_over_its_last_frames() {
        let mut memory = EdgeMemory::new(None);
        let reads = [0.9, 1.3, 1.0, 1.4, 0.95, 1.2, 0.8, 0.7];
        // By hand: the medians of the first 1, 2, 3, 4 and 5 reads, then of the last five.
        let medians = [0.9, 1.1, 1.0, 1.15, 1.0, 1.2, 1.0, 0.95];
        let resolved_before = [false, false, true, true, true, true, true, true];
        for (k, read) in reads.into_iter().enumerate() {
            memory.next_frame(k as u64 * 33_333);
            let mid_px = (100.0 + 3.0 * k as f32, 50.0);
            let v = memory.judge(mid_px, 10.0, Some(read)).unwrap();
            assert!(
                (v.pooled_fall_px - medians[k]).abs() < 1e-6,
                "frame {k}: {v:?}, median {}",
                medians[k]
            );
            assert_eq!(v.resolved_before, resolved_before[k], "frame {k}");
        }
    }

    /// Another LED far away, or one read in the same frame, starts its own falls; a frame
    /// whose fall was not read keeps the LED's; falls not read again for long are forgotten.
    #[test]
    fn falls_are_another_led_s_only_where_it_can_be() {
        let mut memory = EdgeMemory::new(None);
        memory.next_frame(0);
        assert_eq!(pooled(&mut memory, (100.0, 100.0), Some(2.0)), Some(2.0));
        // The same frame: another blob beside it is read on its own.
        assert_eq!(pooled(&mut memory, (101.0, 100.0), Some(0.5)), Some(0.5));
        memory.next_frame(33_333);
        // Beyond the path's length and the margin from both: another LED, never resolved.
        let far = memory.judge((300.0, 100.0), 10.0, Some(0.6)).unwrap();
        assert_eq!(far.pooled_fall_px, 0.6);
        assert!(!far.resolved_before);
        // Not read: nothing pooled, nothing forgotten.
        assert_eq!(pooled(&mut memory, (104.0, 100.0), None), None);
        // The nearer of the two read in the frame before: the one at 101 px.
        assert_eq!(pooled(&mut memory, (104.0, 100.0), Some(1.0)), Some(0.75));
        for k in 0..=MAX_AGE_FRAMES {
            memory.next_frame((2 + k) * 33_333);
        }
        assert_eq!(pooled(&mut memory, (104.0, 100.0), Some(0.7)), Some(0.7));
    }
}
