//! The clock offset between two cameras, measured where both see the same robot moving.
//!
//! If camera b's clock reads `δ` more than camera a's, b's report stamped `t` was taken at a's
//! time `t − δ`, so at one stamped time b sees the robot where it was `δ` earlier: the
//! difference of their positions is `Δ = p_b − p_a ≈ −v δ`. Over the overlap, least squares
//! gives `δ = −Σ Δ·v / Σ |v|²`. A steady difference between the two calibrations along the
//! direction of travel reads as an offset too (0.1 cm at 1 m/s is 1 ms), so the figure is an
//! upper bound of the clocks' disagreement rather than a measurement finer than that.

use crate::geometry::Point;

/// Offsets above this are worth a warning: at 1 m/s, 2 ms is 2 mm on the floor.
pub const WARN_OFFSET_US: f64 = 2_000.0;

/// Least-squares sums for one pair of cameras.
#[derive(Debug, Clone, Copy, Default)]
struct Sums {
    /// `−Σ Δ·v`, floor units² / s.
    numerator: f64,
    /// `Σ |v|²`, floor units² / s².
    denominator: f64,
    samples: u64,
}

/// A measured offset between two cameras.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ClockOffset {
    /// The pair's cameras (indices), `a < b`.
    pub a: usize,
    pub b: usize,
    /// How much b's clock reads more than a's, µs.
    pub offset_us: f64,
    /// Sightings of both at one time that went into it.
    pub samples: u64,
}

/// Accumulates the offsets of every pair of cameras.
#[derive(Debug, Clone)]
pub struct OffsetEstimator {
    cameras: usize,
    /// Pair `(a, b)`, `a < b`, at `a * cameras + b`.
    sums: Vec<Sums>,
}

impl OffsetEstimator {
    /// No samples yet, for `cameras` cameras.
    pub fn new(cameras: usize) -> Self {
        OffsetEstimator {
            cameras,
            sums: vec![Sums::default(); cameras.saturating_mul(cameras)],
        }
    }

    /// Camera `seen_by` saw the robot at `p` at a stamped time when camera `reference`, by
    /// interpolation, saw it at `p_reference` moving at `velocity` (floor units/s).
    pub fn add(
        &mut self,
        seen_by: usize,
        p: Point,
        reference: usize,
        p_reference: Point,
        velocity: Point,
    ) {
        if seen_by == reference || seen_by >= self.cameras || reference >= self.cameras {
            return;
        }
        let (delta, a, b) = if reference < seen_by {
            (p - p_reference, reference, seen_by)
        } else {
            (p_reference - p, seen_by, reference)
        };
        let v = velocity.coords;
        let (numerator, denominator) = (-delta.dot(&v), v.norm_squared());
        if !(numerator.is_finite() && denominator.is_finite() && denominator > 0.0) {
            return;
        }
        if let Some(s) = self.sums.get_mut(a * self.cameras + b) {
            s.numerator += numerator;
            s.denominator += denominator;
            s.samples += 1;
        }
    }

    /// The offsets of every pair measured so far.
    pub fn offsets(&self) -> Vec<ClockOffset> {
        let mut out = Vec::new();
        for a in 0..self.cameras {
            for b in a + 1..self.cameras {
                let Some(s) = self.sums.get(a * self.cameras + b) else {
                    continue;
                };
                if s.samples > 0 && s.denominator > 0.0 {
                    out.push(ClockOffset {
                        a,
                        b,
                        offset_us: s.numerator / s.denominator * 1e6,
                        samples: s.samples,
                    });
                }
            }
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_clock_ahead_is_measured_from_where_it_sees_the_robot() {
        // Camera 1's clock reads 5 ms ahead: at one stamped time it sees the robot 5 ms back.
        let mut e = OffsetEstimator::new(2);
        let v = Point::new(80.0, -30.0);
        for k in 0..10 {
            let p0 = Point::new(k as f64, 2.0 * k as f64);
            let p1 = p0 - v.coords * 0.005;
            e.add(1, p1, 0, p0, v);
            // The same pair seen from the other side adds the same evidence.
            e.add(0, p0, 1, p1, v);
        }
        let [o] = e.offsets()[..] else { panic!() };
        assert_eq!((o.a, o.b, o.samples), (0, 1, 20));
        assert!((o.offset_us - 5_000.0).abs() < 1e-6, "{}", o.offset_us);
    }

    #[test]
    fn a_still_robot_tells_nothing() {
        let mut e = OffsetEstimator::new(2);
        e.add(
            1,
            Point::new(1.0, 0.0),
            0,
            Point::new(0.0, 0.0),
            Point::new(0.0, 0.0),
        );
        assert!(e.offsets().is_empty());
    }
}
