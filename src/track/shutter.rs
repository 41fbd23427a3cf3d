//! A rolling shutter's skew of the velocity.
//!
//! Most USB webcams and the Raspberry Pi's camera modules expose their rows one after another:
//! row `y`'s exposure ends `y τ` after row 0's, for a row time `τ` (a 640×480 frame read out
//! over 15–30 ms, 30–60 µs a row). Under steady motion each row then sees the LED where a
//! global shutter would have, moved on by the LED's own motion over the row's delay: the
//! picture is the global shutter's under the map `(x, y) → (x + v_x τ y', y')`, with
//! `y' = y / (1 − v_y τ)`. A streak's path and the middles' steps from frame to frame are both
//! seen through that map, so the tracker's figures agree with one another (the streak's
//! length with the middles' motion, the head with its prediction), and only the velocity they
//! give is off: the picture's `v' = v / (1 − v_y τ)`, 6.7 % fast for an LED moving down at
//! 1000 px/s with 62.5 µs rows, 5.9 % slow moving up. Inverting it, `v = v' / (1 + v'_y τ)`.
//!
//! A position stays where the picture shows it: the LED at the end of its own row's exposure,
//! `y τ` after the frame's time.

/// A camera's rolling shutter: the time from one row's exposure to the next row's.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RollingShutter {
    row_time_s: f32,
}

/// Below this the picture's upward speed `−v'_y τ` says the LED moved up at least a row per
/// row time (`v_y τ ≤ −1`): it outran the readout, and its light is not a streak along its path.
const MIN_SKEW_FACTOR: f32 = 0.5;

impl RollingShutter {
    /// A shutter of `row_time_us` µs a row; `None` unless positive and finite (a global
    /// shutter needs no correction).
    pub fn new(row_time_us: f32) -> Option<Self> {
        (row_time_us.is_finite() && row_time_us > 0.0).then_some(Self {
            row_time_s: row_time_us * 1e-6,
        })
    }

    /// The LED's velocity (px/s) from the velocity `picture_px_s` the picture's skewed rows
    /// show; `None` for an LED that outran the readout upward.
    pub fn velocity_px_s(&self, picture_px_s: (f32, f32)) -> Option<(f32, f32)> {
        let factor = 1.0 + picture_px_s.1 * self.row_time_s;
        (factor >= MIN_SKEW_FACTOR).then(|| (picture_px_s.0 / factor, picture_px_s.1 / factor))
    }

    /// The map from the skewed picture back to a global shutter's, near an LED whose picture
    /// moves at `picture_px_s`: `(x', y') → (x' − v_x τ y', (1 − v_y τ) y')` with the LED's
    /// own velocity `v`. Through it a moving LED's spot is round again: a rolling shutter
    /// stretches the spot of an LED moving down the picture and squeezes one moving up, as
    /// it does the path, and shears one moving across. `None` as for
    /// [`RollingShutter::velocity_px_s`].
    pub fn unskew(&self, picture_px_s: (f32, f32)) -> Option<[[f32; 2]; 2]> {
        let (vx, vy) = self.velocity_px_s(picture_px_s)?;
        Some([
            [1.0, -vx * self.row_time_s],
            [0.0, 1.0 - vy * self.row_time_s],
        ])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The picture's velocity, worked out from the rows' exposure windows: a row `y` sees
    /// the LED at `y` during `[y τ, T + y τ]`, so a streak spans `T + Δy τ` where `Δy` is its
    /// own rise, and the middles' steps `Δt + Δy τ`. The correction undoes both.
    #[test]
    fn the_velocity_the_rows_saw_is_undone() {
        let shutter = RollingShutter::new(62.5).unwrap();
        let tau_s = 62.5e-6;
        for (vx, vy) in [
            (0.0, 1000.0),
            (0.0, -1000.0),
            (700.0, 700.0),
            (-300.0, -2000.0),
        ] {
            let exposure_s = 0.01;
            // The streak's time: T + rise τ, with rise = v_y × that time.
            let seen_s = exposure_s / (1.0 - vy * tau_s);
            let picture = (vx * seen_s / exposure_s, vy * seen_s / exposure_s);
            let (ux, uy) = shutter.velocity_px_s(picture).unwrap();
            assert!(
                (ux - vx).hypot(uy - vy) < 1e-4 * vx.hypot(vy),
                "({vx}, {vy}) read ({ux}, {uy}) from the picture's {picture:?}"
            );
        }
    }

    #[test]
    fn an_led_that_outran_the_readout_has_no_velocity() {
        let shutter = RollingShutter::new(50.0).unwrap();
        // Up at 20000 px/s: a row per row time, the picture's speed unbounded.
        assert_eq!(shutter.velocity_px_s((0.0, -1.0e5)), None);
        assert!(shutter.velocity_px_s((0.0, -5000.0)).is_some());
    }

    #[test]
    fn no_row_time_is_no_rolling_shutter() {
        for row_time_us in [0.0, -1.0, f32::NAN, f32::INFINITY] {
            assert_eq!(RollingShutter::new(row_time_us), None, "{row_time_us}");
        }
    }
}
