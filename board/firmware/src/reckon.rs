//! Where the robot is now, from where the camera saw it: the wheel commands this firmware gave
//! since that exposure, followed through the motors' lag, drive the pose glint measured on to
//! the present (dead reckoning over the position's age only, so its drift never builds up).
//!
//! A position is tens of milliseconds old when it arrives (a USB webcam alone takes 30 to
//! 100 ms to deliver a frame). Over that time the robot kept driving the commands it had been
//! given, and the firmware knows them: which speeds, which turn rates, and when. Moving the
//! position on along the last commanded arc instead misses every change of command within the
//! age, and the motors' lag, which at a 30 ms lag and a 70 ms age are most of the turn.

use libm::{cosf, expf, sinf};

use crate::clock::reached;

/// Commands kept: at 30 updates a second, half a second of them, beyond any usable age.
pub const COMMANDS_KEPT: usize = 16;
/// Step of the integration, µs.
const STEP_US: u32 = 1_000;
/// The motors are followed from this many lag times before the exposure, so that their speeds
/// at the exposure no longer depend on where the integration started.
const SETTLE_LAGS: u32 = 4;
/// At most this many steps (one second): an age beyond it is moved on for a second only.
const MAX_STEPS: u32 = 1_000;
/// Microseconds per second.
const US_PER_S: f32 = 1e6;

/// A pose, mm and radians.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pose {
    /// Position, mm.
    pub x_mm: f32,
    /// Position, mm.
    pub y_mm: f32,
    /// Heading, radians from +x toward +y.
    pub heading_rad: f32,
}

/// One command as given: forward speed and turn rate, from the robot's clock.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
struct Given {
    at_us: u32,
    speed_mm_s: f32,
    turn_rad_s: f32,
}

/// The last [`COMMANDS_KEPT`] commands given, oldest overwritten first.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct CommandHistory {
    given: [Given; COMMANDS_KEPT],
    len: usize,
    /// Where the next command goes.
    next: usize,
}

impl CommandHistory {
    /// No command given yet.
    pub fn new() -> Self {
        Self::default()
    }

    /// Notes a command given at `at_us` of the robot's clock.
    pub fn push(&mut self, at_us: u32, speed_mm_s: f32, turn_rad_s: f32) {
        if let Some(slot) = self.given.get_mut(self.next) {
            *slot = Given {
                at_us,
                speed_mm_s,
                turn_rad_s,
            };
        }
        self.next = (self.next + 1) % COMMANDS_KEPT;
        self.len = (self.len + 1).min(COMMANDS_KEPT);
    }

    /// The kept commands, newest first.
    fn newest_first(&self) -> impl Iterator<Item = Given> + '_ {
        (1..=self.len).filter_map(move |k| {
            self.given
                .get((self.next + COMMANDS_KEPT - k) % COMMANDS_KEPT)
                .copied()
        })
    }

    /// The command in force at `t_us`: the last given at or before it, or the oldest kept when
    /// `t_us` lies before them all.
    fn in_force(&self, t_us: u32) -> Option<Given> {
        self.newest_first()
            .find(|g| reached(t_us, g.at_us))
            .or_else(|| self.newest_first().last())
    }

    /// `pose`, measured at `since_us`, driven on to `now_us` (both of the robot's clock) by the
    /// commands given, each followed by the wheels with a first-order lag of `motor_lag_us`.
    /// `None` before any command was given.
    pub fn drive_on(
        &self,
        pose: Pose,
        since_us: u32,
        now_us: u32,
        motor_lag_us: u32,
    ) -> Option<Pose> {
        let settle_us = motor_lag_us.saturating_mul(SETTLE_LAGS);
        let start_us = since_us.wrapping_sub(settle_us);
        let mut motors = self.in_force(start_us)?;
        // The share of the way to the command the motors go in one step.
        let follow = if motor_lag_us == 0 {
            1.0
        } else {
            1.0 - expf(-(STEP_US as f32) / motor_lag_us as f32)
        };
        let step_s = STEP_US as f32 / US_PER_S;
        let steps = (now_us.wrapping_sub(start_us) / STEP_US).min(MAX_STEPS + settle_us / STEP_US);
        let mut pose = pose;
        for k in 0..steps {
            let t_us = start_us.wrapping_add(k * STEP_US);
            let command = self.in_force(t_us).unwrap_or(motors);
            motors.speed_mm_s += (command.speed_mm_s - motors.speed_mm_s) * follow;
            motors.turn_rad_s += (command.turn_rad_s - motors.turn_rad_s) * follow;
            if !reached(t_us, since_us) {
                continue;
            }
            // Along the chord of the step's arc: its direction is the heading halfway.
            let turn = motors.turn_rad_s * step_s;
            let h = pose.heading_rad + 0.5 * turn;
            let travel = motors.speed_mm_s * step_s;
            pose = Pose {
                x_mm: pose.x_mm + travel * cosf(h),
                y_mm: pose.y_mm + travel * sinf(h),
                heading_rad: pose.heading_rad + turn,
            };
        }
        Some(pose)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const START: Pose = Pose {
        x_mm: 0.0,
        y_mm: 0.0,
        heading_rad: 0.0,
    };

    #[test]
    fn nothing_given_nothing_known() {
        assert_eq!(
            CommandHistory::new().drive_on(START, 0, 100_000, 30_000),
            None
        );
    }

    #[test]
    fn a_steady_command_drives_straight_on_by_its_speed() {
        let mut h = CommandHistory::new();
        h.push(0, 500.0, 0.0);
        let p = h.drive_on(START, 1_000_000, 1_070_000, 30_000).unwrap();
        // 70 ms at 500 mm/s.
        assert!((p.x_mm - 35.0).abs() < 0.1 && p.y_mm.abs() < 1e-3, "{p:?}");
    }

    #[test]
    fn a_turn_given_within_the_age_is_followed_through_the_motors_lag() {
        // Straight until 20 ms after the exposure, then a 1 rad/s left turn.
        let mut h = CommandHistory::new();
        h.push(0, 500.0, 0.0);
        h.push(1_020_000, 500.0, 1.0);
        let p = h.drive_on(START, 1_000_000, 1_070_000, 30_000).unwrap();
        // 50 ms of the turn, the motors reaching 1 − e^(−50/30) = 81 % of it by the end: the
        // heading gains 50 ms − 30 ms × 0.81 = 25.6 mrad.
        assert!((p.heading_rad - 0.0256).abs() < 0.001, "{p:?}");
        assert!(p.y_mm > 0.1 && p.y_mm < 0.5, "{p:?}");
        // Without a lag, the whole 50 ms of the turn.
        let q = h.drive_on(START, 1_000_000, 1_070_000, 0).unwrap();
        assert!((q.heading_rad - 0.05).abs() < 0.001, "{q:?}");
    }

    #[test]
    fn the_oldest_commands_are_overwritten_and_the_clock_may_wrap() {
        let mut h = CommandHistory::new();
        for k in 0..40u32 {
            h.push(u32::MAX - 2_000_000 + k * 33_333, 100.0 + k as f32, 0.0);
        }
        // The newest (k = 39) is in force from its moment on, across the clock's wrap.
        let at = (u32::MAX - 2_000_000).wrapping_add(39 * 33_333);
        let p = h.drive_on(START, at.wrapping_add(200_000), at.wrapping_add(300_000), 0);
        assert!((p.unwrap().x_mm - 13.9).abs() < 0.05, "{p:?}");
        // Before the oldest kept (k = 24), the oldest is taken to have been in force.
        let old = (u32::MAX - 2_000_000).wrapping_add(24 * 33_333);
        let p = h.drive_on(
            START,
            old.wrapping_sub(100_000),
            old.wrapping_sub(50_000),
            0,
        );
        assert!((p.unwrap().x_mm - 6.2).abs() < 0.05, "{p:?}");
    }
}
