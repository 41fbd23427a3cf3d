//! A differential-drive robot on the floor, stepped at 1 kHz: two wheels whose speeds follow
//! their commands through a first-order motor lag and are limited to the motors' top speed, and
//! the body moving along the arc those speeds make.

use std::f64::consts::TAU;

/// The physics step: 1 kHz.
pub const STEP_S: f64 = 0.001;

/// The robot's build.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DriveParams {
    /// Distance between the wheels' contact points, m.
    pub wheel_base_m: f64,
    /// Top wheel speed, either way, m/s.
    pub max_wheel_speed_m_s: f64,
    /// Time constant of the motors' response to a new command, s.
    pub motor_lag_s: f64,
}

/// Left and right wheel speeds over the floor, m/s (positive forwards).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct WheelSpeeds {
    /// The left wheel.
    pub left_m_s: f64,
    /// The right wheel.
    pub right_m_s: f64,
}

/// The robot's state.
#[derive(Debug, Clone, PartialEq)]
pub struct DiffDrive {
    params: DriveParams,
    /// Position of the midpoint between the wheels (where the LED sits), m.
    pub position_m: (f64, f64),
    /// Heading, radians from +x towards +y, in [0, 2π).
    pub heading_rad: f64,
    /// What the wheels do now.
    pub wheels: WheelSpeeds,
    /// What they were told to do.
    pub command: WheelSpeeds,
}

impl DiffDrive {
    /// A robot at rest at `position_m`, facing `heading_rad`.
    pub fn new(params: DriveParams, position_m: (f64, f64), heading_rad: f64) -> Self {
        DiffDrive {
            params,
            position_m,
            heading_rad: heading_rad.rem_euclid(TAU),
            wheels: WheelSpeeds::default(),
            command: WheelSpeeds::default(),
        }
    }

    /// Sets the wheel speed command (limited to the motors' top speed).
    pub fn set_command(&mut self, command: WheelSpeeds) {
        let max = self.params.max_wheel_speed_m_s;
        self.command = WheelSpeeds {
            left_m_s: command.left_m_s.clamp(-max, max),
            right_m_s: command.right_m_s.clamp(-max, max),
        };
    }

    /// Forward speed and turn rate now: m/s and rad/s.
    pub fn twist(&self) -> (f64, f64) {
        let WheelSpeeds {
            left_m_s,
            right_m_s,
        } = self.wheels;
        (
            0.5 * (left_m_s + right_m_s),
            (right_m_s - left_m_s) / self.params.wheel_base_m,
        )
    }

    /// Advances one physics step of [`STEP_S`].
    pub fn step(&mut self) {
        // The motors approach their commands exactly as a first-order lag would over the step.
        let follow = 1.0 - (-STEP_S / self.params.motor_lag_s.max(f64::MIN_POSITIVE)).exp();
        self.wheels.left_m_s += (self.command.left_m_s - self.wheels.left_m_s) * follow;
        self.wheels.right_m_s += (self.command.right_m_s - self.wheels.right_m_s) * follow;
        let (v, omega) = self.twist();
        let (x, y) = self.position_m;
        let h = self.heading_rad;
        let turn = omega * STEP_S;
        // Along the arc of the step (a straight segment when the turn vanishes).
        let (dx, dy) = if turn.abs() < 1e-12 {
            (v * STEP_S * h.cos(), v * STEP_S * h.sin())
        } else {
            let r = v / omega;
            (
                r * ((h + turn).sin() - h.sin()),
                -r * ((h + turn).cos() - h.cos()),
            )
        };
        self.position_m = (x + dx, y + dy);
        self.heading_rad = (h + turn).rem_euclid(TAU);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const PARAMS: DriveParams = DriveParams {
        wheel_base_m: 0.12,
        max_wheel_speed_m_s: 0.8,
        motor_lag_s: 0.05,
    };

    fn run(robot: &mut DiffDrive, seconds: f64) {
        for _ in 0..(seconds / STEP_S).round() as usize {
            robot.step();
        }
    }

    #[test]
    fn the_motors_follow_a_step_with_their_lag() {
        let mut r = DiffDrive::new(PARAMS, (0.0, 0.0), 0.0);
        r.set_command(WheelSpeeds {
            left_m_s: 0.5,
            right_m_s: 0.5,
        });
        run(&mut r, PARAMS.motor_lag_s);
        // 1 − 1/e of the step after one time constant.
        let expected = 0.5 * (1.0 - (-1.0f64).exp());
        assert!((r.wheels.left_m_s - expected).abs() < 1e-9);
        run(&mut r, 2.0);
        // Straight along +x: after the lag, 0.5 m/s.
        assert!((r.twist().0 - 0.5).abs() < 1e-9);
        assert!(r.position_m.1.abs() < 1e-12 && r.heading_rad == 0.0);
        // Distance: 0.5 m/s for 2.05 s less the lag's deficit (τ × 0.5 m/s).
        let expected_x = 0.5 * (2.0 + PARAMS.motor_lag_s) - 0.5 * PARAMS.motor_lag_s;
        assert!(
            (r.position_m.0 - expected_x).abs() < 2e-3,
            "{:?}",
            r.position_m
        );
    }

    #[test]
    fn commands_beyond_the_motors_top_speed_are_limited() {
        let mut r = DiffDrive::new(PARAMS, (0.0, 0.0), 0.0);
        r.set_command(WheelSpeeds {
            left_m_s: -3.0,
            right_m_s: 3.0,
        });
        assert_eq!(r.command.right_m_s, PARAMS.max_wheel_speed_m_s);
        run(&mut r, 1.0);
        // Turning on the spot: the midpoint stays put, the heading turns at 2 v / L.
        assert!(r.position_m.0.hypot(r.position_m.1) < 1e-9);
        assert!((r.twist().1 - 2.0 * 0.8 / 0.12).abs() < 1e-6);
    }

    #[test]
    fn unequal_wheels_drive_a_circle_of_the_expected_radius() {
        // Radius L/2 · (r + l) / (r − l) = 0.06 · 0.6 / 0.2 = 0.18 m.
        let mut r = DiffDrive::new(PARAMS, (0.0, 0.0), 0.0);
        r.set_command(WheelSpeeds {
            left_m_s: 0.2,
            right_m_s: 0.4,
        });
        run(&mut r, 1.0);
        let (v, omega) = r.twist();
        let radius = v / omega;
        assert!((radius - 0.18).abs() < 1e-9);
        // Once at speed every point is on the circle round the current centre of turning.
        let centre = (
            r.position_m.0 - radius * r.heading_rad.sin(),
            r.position_m.1 + radius * r.heading_rad.cos(),
        );
        let mut max_off: f64 = 0.0;
        for _ in 0..2_000 {
            r.step();
            let d = (r.position_m.0 - centre.0).hypot(r.position_m.1 - centre.1);
            max_off = max_off.max((d - radius).abs());
        }
        assert!(max_off < 1e-6, "{max_off}");
    }
}
