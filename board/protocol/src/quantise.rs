//! From the tracker's `f32` estimates to the wire's fixed-point integers.
//!
//! The wire carries 16-bit fixed point: ±32.767 m at 1 mm on the floor, ±4096 px at 1/8 px in
//! the image. A value outside that range (or NaN) is not wrapped: it saturates to the nearest
//! end of the range and the caller is told which fields were clamped, so it can log or mark the
//! update instead of sending the robot a position on the wrong side of the room.

use crate::message::{Position, Status, Units};

/// A position estimate in whole units, before quantisation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Reading {
    /// Frame of reference: pixels or floor millimetres.
    pub units: Units,
    /// X position, in px or mm.
    pub x: f32,
    /// Y position, in px or mm.
    pub y: f32,
    /// X velocity, in px/s or mm/s.
    pub vx_per_s: f32,
    /// Y velocity, in px/s or mm/s.
    pub vy_per_s: f32,
}

/// Which fields of a [`Reading`] were out of range (or NaN) and were saturated.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Clamped {
    /// `x` was saturated.
    pub x: bool,
    /// `y` was saturated.
    pub y: bool,
    /// `vx_per_s` was saturated.
    pub vx_per_s: bool,
    /// `vy_per_s` was saturated.
    pub vy_per_s: bool,
}

impl Clamped {
    /// Whether any field was saturated.
    pub const fn any(&self) -> bool {
        self.x || self.y || self.vx_per_s || self.vy_per_s
    }
}

/// A quantised position and the fields that did not fit.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Quantised {
    /// The position, ready to encode.
    pub position: Position,
    /// Fields that were saturated to fit 16 bits; all `false` when the reading fit.
    pub clamped: Clamped,
}

/// Rounds `value × quanta_per_unit` to the nearest integer (halves away from zero), saturating
/// to the `i16` range. Returns the quantum count and whether it had to saturate; NaN becomes 0,
/// reported as saturated, since it has no nearest representable value.
pub fn quantise(value: f32, quanta_per_unit: f32) -> (i16, bool) {
    // The largest and smallest scaled values that still round into the i16 range.
    const MAX_ROUNDABLE: f32 = i16::MAX as f32 + 0.5;
    const MIN_ROUNDABLE: f32 = i16::MIN as f32 - 0.5;
    let scaled = value * quanta_per_unit;
    if scaled.is_nan() {
        return (0, true);
    }
    if scaled >= MAX_ROUNDABLE {
        return (i16::MAX, true);
    }
    if scaled <= MIN_ROUNDABLE {
        return (i16::MIN, true);
    }
    // In range now. `round` is not in `core`, and adding ±0.5 before truncating misrounds
    // 0.49999997; the fraction left after truncation is exact in f32, so compare that instead.
    let whole = scaled as i32;
    let fraction = scaled - whole as f32;
    let rounded = if fraction >= 0.5 {
        whole + 1
    } else if fraction <= -0.5 {
        whole - 1
    } else {
        whole
    };
    // Saturating, though the range checks above already keep `rounded` inside i16.
    (
        rounded.clamp(i32::from(i16::MIN), i32::from(i16::MAX)) as i16,
        false,
    )
}

impl Position {
    /// Quantises a reading into a position update, saturating out-of-range fields and saying
    /// which ones were clamped.
    pub fn from_reading(
        seq: u8,
        timestamp_us: u32,
        status: Status,
        quality: u8,
        reading: Reading,
    ) -> Quantised {
        let scale = reading.units.quanta_per_unit();
        let (x, x_clamped) = quantise(reading.x, scale);
        let (y, y_clamped) = quantise(reading.y, scale);
        let (vx_per_s, vx_clamped) = quantise(reading.vx_per_s, scale);
        let (vy_per_s, vy_clamped) = quantise(reading.vy_per_s, scale);
        Quantised {
            position: Position {
                seq,
                timestamp_us,
                units: reading.units,
                x,
                y,
                vx_per_s,
                vy_per_s,
                status,
                quality,
            },
            clamped: Clamped {
                x: x_clamped,
                y: y_clamped,
                vx_per_s: vx_clamped,
                vy_per_s: vy_clamped,
            },
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::message::QUANTA_PER_PX;

    #[test]
    fn rounds_to_nearest_eighth_pixel() {
        assert_eq!(quantise(1.0, QUANTA_PER_PX), (8, false));
        assert_eq!(quantise(1.06, QUANTA_PER_PX), (8, false)); // 8.48
        assert_eq!(quantise(1.07, QUANTA_PER_PX), (9, false)); // 8.56
        assert_eq!(quantise(-1.07, QUANTA_PER_PX), (-9, false));
        assert_eq!(quantise(0.0625, QUANTA_PER_PX), (1, false)); // exactly 0.5 rounds away
        assert_eq!(quantise(-0.0625, QUANTA_PER_PX), (-1, false));
        // The largest f32 below 0.5 rounds down (adding 0.5 first would give 1).
        assert_eq!(quantise(0.499_999_97, 1.0), (0, false));
        assert_eq!(quantise(-0.499_999_97, 1.0), (0, false));
    }

    #[test]
    fn range_ends_are_exact_and_beyond_saturates_with_a_report() {
        assert_eq!(quantise(4095.875, QUANTA_PER_PX), (i16::MAX, false));
        assert_eq!(quantise(-4096.0, QUANTA_PER_PX), (i16::MIN, false));
        assert_eq!(quantise(4096.0, QUANTA_PER_PX), (i16::MAX, true));
        assert_eq!(quantise(-4097.0, QUANTA_PER_PX), (i16::MIN, true));
        assert_eq!(quantise(40_000.0, 1.0), (i16::MAX, true));
        assert_eq!(quantise(f32::INFINITY, 1.0), (i16::MAX, true));
        assert_eq!(quantise(f32::NEG_INFINITY, 1.0), (i16::MIN, true));
        assert_eq!(quantise(f32::NAN, 1.0), (0, true));
    }

    #[test]
    fn reading_reports_exactly_the_clamped_fields() {
        let q = Position::from_reading(
            7,
            1_000,
            Status::Found,
            200,
            Reading {
                units: Units::Floor,
                x: 1234.4,
                y: 50_000.0,
                vx_per_s: -12.6,
                vy_per_s: f32::NAN,
            },
        );
        assert_eq!(q.position.x, 1234);
        assert_eq!(q.position.y, i16::MAX);
        assert_eq!(q.position.vx_per_s, -13);
        assert_eq!(q.position.vy_per_s, 0);
        assert_eq!(
            q.clamped,
            Clamped {
                x: false,
                y: true,
                vx_per_s: false,
                vy_per_s: true
            }
        );
        assert!(q.clamped.any());
        assert!((q.position.x_in_units() - 1234.0).abs() < f32::EPSILON);
    }
}
