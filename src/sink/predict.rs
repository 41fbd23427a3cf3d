//! Prediction to arrival (`--predict arrival`): where the light is when an update reaches its
//! reader, from where it was at the end of the exposure.
//!
//! The velocity is the tracker's: from the single frame's streak when the exposure is known
//! (its length over the exposure, its direction at the head), else from consecutive frames. Where
//! the path bends, the velocity's turn between consecutive frames gives the centripetal
//! acceleration; only the part across the velocity is kept, since the change of speed along the
//! path is mostly measurement noise at these horizons (tens of ms). Two velocities measured in
//! different ways (the first frames of a track go from frame differences to streaks) differ by
//! more than the bend, so a bend is only taken between two of the same kind. The light then moves on a
//! parabola that follows the bend: `p + v·h + ½·a⊥·h²`.

/// Longest frame interval across which two velocities still measure a bend: beyond it the
/// track was interrupted and the turn between the two is not one bend.
pub const MAX_BEND_INTERVAL_US: u64 = 100_000;

/// Microseconds per second.
const US_PER_S: f32 = 1e6;

use crate::report::VelocityMethod;

/// Which reference a position is in: velocities in different ones cannot be subtracted.
pub type Reference = glint_protocol::Units;

/// How the light moves, for extrapolating a position to its arrival.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Motion {
    /// Velocity in units (px or mm) per second.
    pub velocity_per_s: (f32, f32),
    /// Acceleration across the velocity in units per second², where the path bends; zero on
    /// a straight line and for the first frame of a track.
    pub acceleration_per_s2: (f32, f32),
}

impl Motion {
    /// Where a light at `(x, y)` is `ahead_s` seconds later.
    pub fn extrapolate(&self, (x, y): (f32, f32), ahead_s: f32) -> (f32, f32) {
        let half_t2 = 0.5 * ahead_s * ahead_s;
        (
            x + self.velocity_per_s.0 * ahead_s + self.acceleration_per_s2.0 * half_t2,
            y + self.velocity_per_s.1 * ahead_s + self.acceleration_per_s2.1 * half_t2,
        )
    }
}

/// The last velocity seen, to measure the bend at the next frame.
#[derive(Debug, Clone, Copy, PartialEq)]
struct Seen {
    t_us: u64,
    reference: Reference,
    method: VelocityMethod,
    velocity_per_s: (f32, f32),
}

/// Turns each frame's velocity into a [`Motion`]; fixed-size state, no allocation.
#[derive(Debug, Clone, Default)]
pub struct Predictor {
    last: Option<Seen>,
}

impl Predictor {
    /// No frame seen.
    pub fn new() -> Self {
        Predictor::default()
    }

    /// The motion at frame time `t_us`, from the frame's velocity in `reference` and how it
    /// was measured (`None`: the light was lost or its velocity is not known yet, and nothing is
    /// predicted).
    pub fn observe(
        &mut self,
        t_us: u64,
        reference: Reference,
        velocity_per_s: Option<((f32, f32), VelocityMethod)>,
    ) -> Option<Motion> {
        let Some((v, method)) = velocity_per_s.filter(|(v, _)| v.0.is_finite() && v.1.is_finite())
        else {
            self.last = None;
            return None;
        };
        let acceleration_per_s2 = self
            .last
            .filter(|l| l.reference == reference && l.method == method)
            .and_then(|l| {
                let dt_us = t_us.checked_sub(l.t_us)?;
                (dt_us > 0 && dt_us <= MAX_BEND_INTERVAL_US)
                    .then(|| across(v, l.velocity_per_s, dt_us as f32 / US_PER_S))
            })
            .unwrap_or((0.0, 0.0));
        self.last = Some(Seen {
            t_us,
            reference,
            method,
            velocity_per_s: v,
        });
        Some(Motion {
            velocity_per_s: v,
            acceleration_per_s2,
        })
    }
}

/// The acceleration from `before` to `now` over `dt_s`, keeping only its part across `now`.
fn across(now: (f32, f32), before: (f32, f32), dt_s: f32) -> (f32, f32) {
    let a = ((now.0 - before.0) / dt_s, (now.1 - before.1) / dt_s);
    let speed = now.0.hypot(now.1);
    if speed <= f32::EPSILON {
        return (0.0, 0.0);
    }
    let (ux, uy) = (now.0 / speed, now.1 / speed);
    let along = a.0 * ux + a.1 * uy;
    (a.0 - along * ux, a.1 - along * uy)
}

#[cfg(test)]
mod tests {
    use super::*;

    const PX: Reference = Reference::Pixels;
    const STREAK: VelocityMethod = VelocityMethod::Streak;

    #[test]
    fn a_straight_line_has_no_bend_and_extrapolates_linearly() {
        let mut p = Predictor::new();
        let m = p.observe(0, PX, Some(((300.0, 0.0), STREAK))).unwrap();
        assert_eq!(m.acceleration_per_s2, (0.0, 0.0));
        // Speeding up along the line is not a bend.
        let m = p.observe(33_333, PX, Some(((330.0, 0.0), STREAK))).unwrap();
        assert_eq!(m.acceleration_per_s2, (0.0, 0.0));
        assert_eq!(m.extrapolate((10.0, 5.0), 0.1), (43.0, 5.0));
    }

    #[test]
    fn a_circle_bends_towards_its_centre_by_v_squared_over_r() {
        // 100 px radius at 2 rad/s... speed 200 px/s: centripetal 400 px/s².
        let (r, omega) = (100.0f32, 2.0f32);
        let velocity = |t: f32| {
            let a = omega * t;
            (-r * omega * a.sin(), r * omega * a.cos())
        };
        let mut p = Predictor::new();
        p.observe(0, PX, Some((velocity(0.0), STREAK)));
        let dt = 0.033_f32;
        let m = p.observe(33_000, PX, Some((velocity(dt), STREAK))).unwrap();
        let (ax, ay) = m.acceleration_per_s2;
        let magnitude = ax.hypot(ay);
        assert!(
            (magnitude - r * omega * omega).abs() < 0.02 * 400.0,
            "{magnitude}"
        );
        // Towards the centre: at angle ω·dt the centre lies at −(cos, sin).
        let towards = -(ax * (omega * dt).cos() + ay * (omega * dt).sin()) / magnitude;
        assert!(towards > 0.99, "{towards}");
    }

    #[test]
    fn a_lost_frame_a_long_gap_a_new_reference_or_method_forgets_the_bend() {
        let mut p = Predictor::new();
        p.observe(0, PX, Some(((100.0, 0.0), STREAK)));
        assert_eq!(p.observe(10_000, PX, None), None);
        let m = p.observe(20_000, PX, Some(((0.0, 100.0), STREAK))).unwrap();
        assert_eq!(m.acceleration_per_s2, (0.0, 0.0));
        let m = p.observe(
            20_000 + MAX_BEND_INTERVAL_US + 1,
            PX,
            Some(((100.0, 0.0), STREAK)),
        );
        assert_eq!(m.unwrap().acceleration_per_s2, (0.0, 0.0));
        let m = p.observe(230_000, Reference::Floor, Some(((0.0, 100.0), STREAK)));
        assert_eq!(m.unwrap().acceleration_per_s2, (0.0, 0.0));
        let frames = Some(((100.0, 0.0), VelocityMethod::Frames));
        let m = p.observe(240_000, Reference::Floor, frames);
        assert_eq!(m.unwrap().acceleration_per_s2, (0.0, 0.0));
        assert_eq!(
            p.observe(250_000, PX, Some(((f32::NAN, 0.0), STREAK))),
            None
        );
    }
}
