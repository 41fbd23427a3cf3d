//! LED trajectories: analytic position AND velocity as functions of time in seconds.
//!
//! Ground truth comes straight from these formulas, never from the rendered pixels, so a
//! test can hold a detector to sub-pixel bounds. Time may be negative (frame 0's exposure
//! starts before t = 0). Coordinates are OpenCV pixel coordinates: (0, 0) is the centre of the
//! top-left pixel.

use std::f64::consts::TAU;

/// A point or vector in pixel coordinates (or px/s for velocities).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Point {
    /// Horizontal coordinate, growing to the right.
    pub x: f64,
    /// Vertical coordinate, growing downwards.
    pub y: f64,
}

impl Point {
    /// A point from its coordinates.
    pub const fn new(x: f64, y: f64) -> Self {
        Self { x, y }
    }

    /// Euclidean length of the vector.
    pub fn norm(self) -> f64 {
        self.x.hypot(self.y)
    }

    fn add(self, other: Point) -> Point {
        Point::new(self.x + other.x, self.y + other.y)
    }

    fn sub(self, other: Point) -> Point {
        Point::new(self.x - other.x, self.y - other.y)
    }

    fn scale(self, factor: f64) -> Point {
        Point::new(self.x * factor, self.y * factor)
    }

    pub(crate) fn is_finite(self) -> bool {
        self.x.is_finite() && self.y.is_finite()
    }
}

/// Position and velocity of the LED at one instant.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Motion {
    /// Centre of the LED disk, px.
    pub position_px: Point,
    /// Time derivative of the position, px/s.
    pub velocity_px_s: Point,
}

/// Number of Simpson intervals used for path lengths: far finer than any feature of the
/// trajectories over one exposure, so the length is exact to well under a micro-pixel.
const PATH_LENGTH_INTERVALS: usize = 256;

/// How the LED moves.
#[derive(Clone, Debug, PartialEq)]
pub enum Trajectory {
    /// Constant velocity from `start_px` at t = 0.
    Line {
        /// Position at t = 0.
        start_px: Point,
        /// Constant velocity.
        velocity_px_s: Point,
    },
    /// Back and forth between `a_px` and `b_px` at constant speed. The LED is at `a_px` at
    /// time `at_a_s` and turns round instantly at either end; place the turns between
    /// exposures to get straight constant-speed streaks in every frame.
    PingPong {
        /// One end of the segment.
        a_px: Point,
        /// The other end.
        b_px: Point,
        /// Constant speed along the segment.
        speed_px_s: f64,
        /// A time at which the LED turns round at `a_px`.
        at_a_s: f64,
    },
    /// Uniform circular motion, counter-clockwise in image coordinates for positive
    /// `rev_per_s` (which, with y down, looks clockwise on screen).
    Circle {
        /// Centre of the circle.
        centre_px: Point,
        /// Radius of the circle.
        radius_px: f64,
        /// Revolutions per second; negative turns the other way.
        rev_per_s: f64,
        /// Angle at t = 0 (0 = to the right of the centre).
        phase_rad: f64,
    },
    /// `centre + amplitude * sin(2π f t + phase)` per axis: a figure-eight when the y
    /// frequency is twice the x frequency, with speed changing along the path. Large
    /// amplitudes carry the LED out of the view and back.
    Lissajous {
        /// Centre of the figure.
        centre_px: Point,
        /// Amplitude per axis.
        amplitude_px: Point,
        /// Frequency per axis.
        freq_hz: Point,
        /// Phase per axis.
        phase_rad: Point,
    },
    /// Visits the waypoints in a closed loop. Each leg takes `move_s` with a raised-cosine
    /// speed profile (smooth start and stop, peak speed twice the mean), then the LED stands
    /// still for `hold_s`. At `start_s` the LED is at the first waypoint and about to move.
    StopGo {
        /// At least two points, visited in order and then back to the first.
        waypoints_px: Vec<Point>,
        /// Duration of each move.
        move_s: f64,
        /// Duration of each stop.
        hold_s: f64,
        /// Time at which the first move starts.
        start_s: f64,
    },
    /// Moves into place and stays (a robot arriving at where it will rest): from `from_px` to
    /// `to_px` in one raised-cosine move (as [`Trajectory::StopGo`]'s) that ends at
    /// `arrive_s`, then drifts on at `then_velocity_px_s` (zero: stands still). Before the
    /// move it stands at `from_px`.
    Arrive {
        /// Where the move starts.
        from_px: Point,
        /// Where the move ends.
        to_px: Point,
        /// Duration of the move.
        move_s: f64,
        /// Time at which the LED is at `to_px`.
        arrive_s: f64,
        /// Velocity after the arrival.
        then_velocity_px_s: Point,
    },
}

impl Trajectory {
    /// Position and velocity at time `t_s`.
    pub fn motion(&self, t_s: f64) -> Motion {
        match self {
            Trajectory::Line {
                start_px,
                velocity_px_s,
            } => Motion {
                position_px: start_px.add(velocity_px_s.scale(t_s)),
                velocity_px_s: *velocity_px_s,
            },
            Trajectory::PingPong {
                a_px,
                b_px,
                speed_px_s,
                at_a_s,
            } => ping_pong(*a_px, *b_px, *speed_px_s, t_s - at_a_s),
            Trajectory::Circle {
                centre_px,
                radius_px,
                rev_per_s,
                phase_rad,
            } => {
                let omega = TAU * rev_per_s;
                let angle = phase_rad + omega * t_s;
                let (sin, cos) = angle.sin_cos();
                Motion {
                    position_px: Point::new(
                        centre_px.x + radius_px * cos,
                        centre_px.y + radius_px * sin,
                    ),
                    velocity_px_s: Point::new(-radius_px * omega * sin, radius_px * omega * cos),
                }
            }
            Trajectory::Lissajous {
                centre_px,
                amplitude_px,
                freq_hz,
                phase_rad,
            } => {
                let (x, vx) = sinusoid(amplitude_px.x, freq_hz.x, phase_rad.x, t_s);
                let (y, vy) = sinusoid(amplitude_px.y, freq_hz.y, phase_rad.y, t_s);
                Motion {
                    position_px: Point::new(centre_px.x + x, centre_px.y + y),
                    velocity_px_s: Point::new(vx, vy),
                }
            }
            Trajectory::StopGo {
                waypoints_px,
                move_s,
                hold_s,
                start_s,
            } => stop_go(waypoints_px, *move_s, *hold_s, t_s - start_s),
            Trajectory::Arrive {
                from_px,
                to_px,
                move_s,
                arrive_s,
                then_velocity_px_s,
            } => {
                if t_s >= *arrive_s {
                    return Motion {
                        position_px: to_px.add(then_velocity_px_s.scale(t_s - arrive_s)),
                        velocity_px_s: *then_velocity_px_s,
                    };
                }
                let since_start_s = (t_s - (arrive_s - move_s)).max(0.0);
                raised_cosine_move(*from_px, *to_px, *move_s, since_start_s)
            }
        }
    }

    /// Length of the path travelled between `t0_s` and `t1_s` (the integral of the speed).
    pub fn path_length_px(&self, t0_s: f64, t1_s: f64) -> f64 {
        let n = PATH_LENGTH_INTERVALS;
        let h = (t1_s - t0_s) / n as f64;
        let speed = |k: usize| self.motion(t0_s + h * k as f64).velocity_px_s.norm();
        let inner: f64 = (1..n)
            .map(|k| if k % 2 == 1 { 4.0 } else { 2.0 } * speed(k))
            .sum();
        (speed(0) + inner + speed(n)) * h / 3.0
    }

    /// Checks that every parameter is finite and the motion well defined.
    pub(crate) fn validate(&self) -> Result<(), &'static str> {
        let ok = match self {
            Trajectory::Line {
                start_px,
                velocity_px_s,
            } => start_px.is_finite() && velocity_px_s.is_finite(),
            Trajectory::PingPong {
                a_px,
                b_px,
                speed_px_s,
                at_a_s,
            } => {
                a_px.is_finite()
                    && b_px.is_finite()
                    && b_px.sub(*a_px).norm() > 0.0
                    && speed_px_s.is_finite()
                    && *speed_px_s > 0.0
                    && at_a_s.is_finite()
            }
            Trajectory::Circle {
                centre_px,
                radius_px,
                rev_per_s,
                phase_rad,
            } => {
                centre_px.is_finite()
                    && radius_px.is_finite()
                    && *radius_px >= 0.0
                    && rev_per_s.is_finite()
                    && phase_rad.is_finite()
            }
            Trajectory::Lissajous {
                centre_px,
                amplitude_px,
                freq_hz,
                phase_rad,
            } => {
                centre_px.is_finite()
                    && amplitude_px.is_finite()
                    && freq_hz.is_finite()
                    && phase_rad.is_finite()
            }
            Trajectory::StopGo {
                waypoints_px,
                move_s,
                hold_s,
                start_s,
            } => {
                waypoints_px.len() >= 2
                    && waypoints_px.iter().all(|p| p.is_finite())
                    && move_s.is_finite()
                    && *move_s > 0.0
                    && hold_s.is_finite()
                    && *hold_s >= 0.0
                    && start_s.is_finite()
            }
            Trajectory::Arrive {
                from_px,
                to_px,
                move_s,
                arrive_s,
                then_velocity_px_s,
            } => {
                from_px.is_finite()
                    && to_px.is_finite()
                    && move_s.is_finite()
                    && *move_s > 0.0
                    && arrive_s.is_finite()
                    && then_velocity_px_s.is_finite()
            }
        };
        if ok {
            Ok(())
        } else {
            Err("trajectory parameters must be finite, with positive speeds, durations and lengths")
        }
    }
}

/// `a * sin(2π f t + φ)` and its derivative.
fn sinusoid(amplitude: f64, freq_hz: f64, phase_rad: f64, t_s: f64) -> (f64, f64) {
    let omega = TAU * freq_hz;
    let (sin, cos) = (omega * t_s + phase_rad).sin_cos();
    (amplitude * sin, amplitude * omega * cos)
}

/// Triangle-wave motion between `a` and `b`; `tau_s` is the time since a turn at `a`.
fn ping_pong(a: Point, b: Point, speed_px_s: f64, tau_s: f64) -> Motion {
    let span = b.sub(a);
    let length_px = span.norm();
    let leg_s = length_px / speed_px_s;
    let legs = tau_s / leg_s;
    let leg_index = legs.floor();
    let along = legs - leg_index;
    let outbound = leg_index.rem_euclid(2.0) < 1.0;
    let (fraction, sign) = if outbound {
        (along, 1.0)
    } else {
        (1.0 - along, -1.0)
    };
    Motion {
        position_px: a.add(span.scale(fraction)),
        velocity_px_s: span.scale(sign * speed_px_s / length_px),
    }
}

/// Closed-loop waypoint motion with raised-cosine moves and holds; `tau_s` is the time since
/// the first move started.
fn stop_go(waypoints: &[Point], move_s: f64, hold_s: f64, tau_s: f64) -> Motion {
    let count = waypoints.len();
    let leg_s = move_s + hold_s;
    let leg = (tau_s / leg_s).floor();
    let local_s = tau_s - leg * leg_s;
    // `leg` may be negative or huge; rem_euclid keeps the index in 0..count.
    let from_index = (leg.rem_euclid(count as f64)) as usize;
    let from = waypoints.get(from_index).copied().unwrap_or_default();
    let to = waypoints
        .get((from_index + 1) % count.max(1))
        .copied()
        .unwrap_or_default();
    raised_cosine_move(from, to, move_s, local_s)
}

/// A move from `from` to `to` in `move_s` from rest to rest (standing at `to` after it);
/// `local_s` is the time since it started.
fn raised_cosine_move(from: Point, to: Point, move_s: f64, local_s: f64) -> Motion {
    let span = to.sub(from);
    if local_s >= move_s {
        return Motion {
            position_px: to,
            velocity_px_s: Point::default(),
        };
    }
    // s(u) = u - sin(2πu)/(2π) runs 0..1 with zero slope at both ends.
    let u = local_s / move_s;
    let fraction = u - (TAU * u).sin() / TAU;
    let rate_per_s = (1.0 - (TAU * u).cos()) / move_s;
    Motion {
        position_px: from.add(span.scale(fraction)),
        velocity_px_s: span.scale(rate_per_s),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn examples() -> Vec<Trajectory> {
        vec![
            Trajectory::Line {
                start_px: Point::new(10.0, 20.0),
                velocity_px_s: Point::new(30.0, -40.0),
            },
            Trajectory::PingPong {
                a_px: Point::new(0.0, 0.0),
                b_px: Point::new(300.0, 400.0),
                speed_px_s: 1000.0,
                at_a_s: 0.01,
            },
            Trajectory::Circle {
                centre_px: Point::new(100.0, 100.0),
                radius_px: 20.0,
                rev_per_s: 5.0,
                phase_rad: 0.3,
            },
            Trajectory::Lissajous {
                centre_px: Point::new(320.0, 240.0),
                amplitude_px: Point::new(200.0, 150.0),
                freq_hz: Point::new(0.25, 0.5),
                phase_rad: Point::new(0.0, 0.0),
            },
            Trajectory::StopGo {
                waypoints_px: vec![
                    Point::new(0.0, 0.0),
                    Point::new(100.0, 0.0),
                    Point::new(100.0, 50.0),
                ],
                move_s: 0.5,
                hold_s: 0.25,
                start_s: -0.1,
            },
            Trajectory::Arrive {
                from_px: Point::new(0.0, 0.0),
                to_px: Point::new(30.0, 40.0),
                move_s: 0.04,
                arrive_s: 0.02,
                then_velocity_px_s: Point::new(60.0, 0.0),
            },
        ]
    }

    /// The analytic velocity must be the derivative of the analytic position everywhere the
    /// motion is smooth (the ping-pong's turns are the only kinks).
    #[test]
    fn velocity_is_the_derivative_of_position() {
        let h = 1e-5;
        for trajectory in examples() {
            for k in 0..400 {
                let t = -1.0 + k as f64 * 0.0137;
                let before = trajectory.motion(t - h).velocity_px_s;
                let after = trajectory.motion(t + h).velocity_px_s;
                if before.sub(after).norm() > 1.0 {
                    continue; // a ping-pong turn lies inside [t-h, t+h]
                }
                let p0 = trajectory.motion(t - h).position_px;
                let p1 = trajectory.motion(t + h).position_px;
                let numeric = p1.sub(p0).scale(0.5 / h);
                let analytic = trajectory.motion(t).velocity_px_s;
                let err = numeric.sub(analytic).norm();
                assert!(
                    err < 1e-3 * (1.0 + analytic.norm()),
                    "{trajectory:?} at t={t}: numeric {numeric:?} analytic {analytic:?}"
                );
            }
        }
    }

    #[test]
    fn path_length_of_a_line_is_speed_times_time() {
        let line = &examples()[0];
        assert!((line.path_length_px(0.0, 0.2) - 50.0 * 0.2).abs() < 1e-9);
    }

    #[test]
    fn path_length_of_a_circle_is_its_arc() {
        let circle = &examples()[2];
        let expected = TAU * 20.0 * 5.0 * 0.02;
        assert!((circle.path_length_px(1.0, 1.02) - expected).abs() < 1e-9);
    }

    #[test]
    fn ping_pong_turns_at_both_ends() {
        let pp = &examples()[1];
        let leg_s = 500.0 / 1000.0;
        let at_b = pp.motion(0.01 + leg_s).position_px;
        assert!(at_b.sub(Point::new(300.0, 400.0)).norm() < 1e-9);
        let back_at_a = pp.motion(0.01 + 2.0 * leg_s).position_px;
        assert!(back_at_a.norm() < 1e-9);
        let going = pp.motion(0.01 + 0.25).velocity_px_s;
        let coming = pp.motion(0.01 + 0.75).velocity_px_s;
        assert!((going.x - 600.0).abs() < 1e-9 && (coming.x + 600.0).abs() < 1e-9);
    }

    #[test]
    fn stop_go_stands_still_during_holds_and_loops() {
        let sg = &examples()[4];
        // First move: -0.1 .. 0.4, hold 0.4 .. 0.65 at the second waypoint.
        for t in [0.41, 0.5, 0.64] {
            let m = sg.motion(t);
            assert_eq!(m.position_px, Point::new(100.0, 0.0));
            assert_eq!(m.velocity_px_s, Point::default());
        }
        // The third leg (1.4 .. 1.9) returns to the first waypoint; the loop restarts at 2.15.
        let back = sg.motion(2.0).position_px;
        assert!(back.norm() < 1e-9, "{back:?}");
        // Peak speed of a raised-cosine move is twice the mean.
        let peak = sg.motion(-0.1 + 0.25).velocity_px_s.norm();
        assert!((peak - 2.0 * 100.0 / 0.5).abs() < 1e-9);
    }

    #[test]
    fn arrive_moves_into_place_then_drifts_on() {
        let arrive = &examples()[5];
        assert_eq!(arrive.motion(-0.03).position_px, Point::new(0.0, 0.0));
        assert_eq!(arrive.motion(-0.03).velocity_px_s, Point::default());
        // Halfway through the move: halfway there at twice the mean speed.
        let half = arrive.motion(0.0);
        assert!(half.position_px.sub(Point::new(15.0, 20.0)).norm() < 1e-9);
        assert!((half.velocity_px_s.norm() - 2.0 * 50.0 / 0.04).abs() < 1e-9);
        // Arrived, and on at 60 px/s.
        assert!(
            arrive
                .motion(0.02 - 1e-12)
                .position_px
                .sub(Point::new(30.0, 40.0))
                .norm()
                < 1e-6
        );
        assert_eq!(arrive.motion(0.07).position_px, Point::new(33.0, 40.0));
        assert_eq!(arrive.motion(0.07).velocity_px_s, Point::new(60.0, 0.0));
    }

    #[test]
    fn invalid_parameters_are_rejected() {
        let bad = Trajectory::StopGo {
            waypoints_px: vec![Point::new(0.0, 0.0)],
            move_s: 1.0,
            hold_s: 0.0,
            start_s: 0.0,
        };
        assert!(bad.validate().is_err());
        let bad = Trajectory::PingPong {
            a_px: Point::new(1.0, 1.0),
            b_px: Point::new(1.0, 1.0),
            speed_px_s: 10.0,
            at_a_s: 0.0,
        };
        assert!(bad.validate().is_err());
        assert!(examples().iter().all(|t| t.validate().is_ok()));
    }
}
