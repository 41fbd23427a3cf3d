//! The floor beside a streak, read from the streak's own surroundings: out along a ray from
//! the streak, where the LED's light has died away.
//!
//! The ramps' and the line profile's brightness levels are fractions of the way from this
//! floor to the clip. A fixed reach reads it wrong under a wide glow (bloom): a glow several
//! times the core's width carries the LED's light 20–50 px out, so that a floor read 14 px out
//! is glow, every level is lifted towards the clip, and a 60 px streak's ends were read
//! 5–10 px short (17 % of its speed). The LED's light falls monotonically away from its path
//! (its spot has one peak), so the floor is where the profile stops falling: the ray is walked
//! out until a window's median has set no new low (lower by more than [`FLOOR_PRECISION`] of
//! the light's span) for a window's length, and the floor is that low. The median, not the
//! darkest sample, so that the floor's grout lines and read noise do not drag the floor down
//! (a dark line crossed by a ray is narrower than half a window).

use super::bilinear::Walk;
use crate::frame::Frame;

/// Samples per window: 7 px, more than twice a grout line crossed at 45° (2.8 px).
const WINDOW: usize = 7;

/// Sampling step along the ray, in pixels.
const STEP_PX: f32 = 1.0;

/// The fraction of the light's span (from the ray's start to its floor) to which the floor is
/// read: the levels cut from it move by as much, which the ramps and the pairing take as
/// they take the floor's texture.
const FLOOR_PRECISION: f32 = 0.02;

/// How far out the floor is sought, in pixels: past the widest glow the sweep renders (σ
/// 18 px, clipped 40 px out) the light is still falling 60 px out, but a blob that wide is
/// glare, not an LED (`MAX_BLOB_FRACTION`).
pub const MAX_REACH_PX: f32 = 64.0;

/// The floor along one ray.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RayFloor {
    /// The floor's luma.
    pub luma: f32,
    /// How far out the light had died away (where the profile stopped falling).
    pub reach_px: f32,
}

/// The floor along the ray from `start` along unit vector `d`: the low of the window medians,
/// once they have set no new low for a window's length below the start's brightness.
/// `None` when the ray leaves the frame or reaches [`MAX_REACH_PX`] still falling.
pub fn along(frame: &Frame<'_>, start: (f32, f32), d: (f32, f32)) -> Option<RayFloor> {
    const SAMPLES: usize = (MAX_REACH_PX / STEP_PX) as usize + 1;
    let mut ring = [0.0f32; WINDOW];
    let mut first = None;
    let mut low = f32::INFINITY;
    let mut low_at = 0usize;
    let mut walk = Walk::new(frame);
    for i in 0..SAMPLES {
        let u = i as f32 * STEP_PX;
        let v = walk.luma_at(start.0 + u * d.0, start.1 + u * d.1)?;
        // The light at the start, which the profile falls from.
        let first = *first.get_or_insert(v);
        if let Some(slot) = ring.get_mut(i % WINDOW) {
            *slot = v;
        }
        if i + 1 < WINDOW {
            continue;
        }
        let median = median_of_7(ring);
        // A fall too small to move a level by more than the floor's precision is the
        // floor's own slope (its texture, a light's gradient), not the LED's light.
        if median < low - FLOOR_PRECISION * (first - low) {
            low = median;
            low_at = i;
        } else if low < first && i - low_at >= WINDOW {
            // The window centred half a window behind the low's last sample.
            let centre = low_at as f32 - 0.5 * (WINDOW - 1) as f32;
            return Some(RayFloor {
                luma: low,
                reach_px: centre * STEP_PX,
            });
        }
    }
    None
}

/// The median of seven values by a fixed network of 13 compare-exchanges (Paeth's), without
/// branches: a sort of the window at every step of every ray was a tenth of a sharp streak's
/// replay, most of it mispredicted branches. For the finite, non-negative luma read here it is
/// the value a sort puts in the middle.
#[inline]
fn median_of_7(mut p: [f32; WINDOW]) -> f32 {
    let [p0, p1, p2, p3, p4, p5, p6] = &mut p;
    exchange(p0, p5);
    exchange(p0, p3);
    exchange(p1, p6);
    exchange(p2, p4);
    exchange(p0, p1);
    exchange(p3, p5);
    exchange(p2, p6);
    exchange(p2, p3);
    exchange(p3, p6);
    exchange(p4, p5);
    exchange(p1, p4);
    exchange(p1, p3);
    exchange(p3, p4);
    *p3
}

/// Orders `a` and `b`: one `minss` and one `maxss` on values held in registers.
#[inline(always)]
fn exchange(a: &mut f32, b: &mut f32) {
    let (low, high) = if *b < *a { (*b, *a) } else { (*a, *b) };
    *a = low;
    *b = high;
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::FrameSize;

    /// A YUYV frame `w` wide and `h` high whose luma is `f(x, y)`.
    fn frame_of(w: u32, h: u32, f: impl Fn(f32, f32) -> f32) -> Vec<u8> {
        let mut bytes = vec![128u8; (2 * w * h) as usize];
        for y in 0..h {
            for x in 0..w {
                let i = 2 * (y * w + x) as usize;
                bytes[i] = f(x as f32, y as f32).round().clamp(0.0, 255.0) as u8;
            }
        }
        bytes
    }

    /// By the 0–1 principle a compare-exchange network that puts the median of every input of
    /// zeros and ones in the middle does so for every input; the random windows check the same
    /// against a sort.
    #[test]
    fn the_network_s_median_is_the_sorted_middle() {
        for bits in 0u32..1 << WINDOW {
            let window: [f32; WINDOW] = core::array::from_fn(|i| ((bits >> i) & 1) as f32);
            let ones = bits.count_ones() as usize;
            let expected = if ones > WINDOW / 2 { 1.0 } else { 0.0 };
            assert_eq!(median_of_7(window), expected, "{window:?}");
        }
        let mut state = 0x9e37_79b9u32;
        for _ in 0..10_000 {
            let window: [f32; WINDOW] = core::array::from_fn(|_| {
                state ^= state << 13;
                state ^= state >> 17;
                state ^= state << 5;
                (state % 2560) as f32 / 10.0
            });
            let mut sorted = window;
            sorted.sort_unstable_by(f32::total_cmp);
            assert_eq!(median_of_7(window), sorted[WINDOW / 2], "{window:?}");
        }
    }

    #[test]
    fn the_floor_under_a_wide_glow_is_where_the_glow_dies() {
        // A streak along y = 20 whose glow (σ 8 px, 150 levels) clips within 6 px, on a floor
        // of 90 crossed by a dark 2 px line 10 px out.
        let (w, h) = (64u32, 120u32);
        let bytes = frame_of(w, h, |_, y| {
            let t = y - 20.0;
            let line = if (30.0..32.0).contains(&y) {
                -40.0
            } else {
                0.0
            };
            (90.0 + line + 150.0 * (-t * t / 128.0).exp()).min(235.0)
        });
        let size = FrameSize::new(w, h).unwrap();
        let frame = Frame::new_checked(&bytes, size, size.row_bytes()).unwrap();
        let floor = along(&frame, (32.0, 20.0), (0.0, 1.0)).expect("a floor");
        // Read to its precision of the span from the clip.
        let tolerance = FLOOR_PRECISION * (235.0 - 90.0);
        assert!((floor.luma - 90.0).abs() <= tolerance, "{floor:?}");
        // The glow is within a few levels of the floor 2.5–3σ out (20–24 px).
        assert!(
            floor.reach_px >= 20.0 && floor.reach_px <= 40.0,
            "{floor:?}"
        );
        // A fixed reach of 14 px read the glow: 90 + 150 exp(−14²/128) = 122.
        let at_14 = crate::detect::bilinear::luma_at(&frame, 32.0, 34.0).unwrap();
        assert!(at_14 > 110.0, "{at_14}");
    }

    #[test]
    fn a_ray_still_falling_at_the_frame_s_edge_has_no_floor() {
        let (w, h) = (64u32, 40u32);
        let bytes = frame_of(w, h, |_, y| 255.0 - 5.0 * y);
        let size = FrameSize::new(w, h).unwrap();
        let frame = Frame::new_checked(&bytes, size, size.row_bytes()).unwrap();
        assert_eq!(along(&frame, (32.0, 2.0), (0.0, 1.0)), None);
    }
}
