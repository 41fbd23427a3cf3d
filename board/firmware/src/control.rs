//! The control loop's side of the link: what it is told, and a stub that steers toward a point.

use glint_protocol::{DecodeError, Heartbeat, LedRequest, Position, Status, Units};

/// A position's age (protocol version 2) as it arrived, in this robot's clock.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ArrivedAge {
    /// The `seq` of the position it belongs to (always the last position received).
    pub seq: u8,
    /// The position's age when the age frame's last byte left glint, in µs.
    pub age_us: u32,
    /// The robot's clock when the age frame arrived (when the link read it).
    pub received_at_us: u32,
    /// Glint extrapolated the position by `age_us` (`--predict arrival`).
    pub predicted: bool,
}

impl ArrivedAge {
    /// How old the position is at `now_us` of the robot's clock: glint's age plus the robot's
    /// own receive latency since the age arrived.
    pub fn age_at_us(&self, now_us: u32) -> u32 {
        self.age_us
            .saturating_add(now_us.wrapping_sub(self.received_at_us))
    }
}

/// What a robot's control loop receives from the link.
pub trait ControlLoop {
    /// A new position update arrived.
    fn on_position(&mut self, position: &Position);
    /// The age of the position just received arrived (from a version 2 glint); the default
    /// ignores it, as a version 1 firmware would.
    fn on_age(&mut self, _age: &ArrivedAge) {}
    /// A heartbeat arrived; the default ignores it.
    fn on_heartbeat(&mut self, _heartbeat: &Heartbeat) {}
    /// Glint asked a robot to switch its LED off (see [`WithLed`](crate::WithLed)); the default
    /// ignores it.
    fn on_led(&mut self, _request: &LedRequest, _received_at_us: u32) {}
    /// A frame was dropped; the default ignores it (the next frame comes within a camera frame).
    fn on_link_error(&mut self, _error: DecodeError) {}
}

/// Proportional gain of the stub: wheel speed command per mm of error, as a shift (1/8).
const GAIN_SHIFT: u32 = 3;

/// Microseconds per second.
const US_PER_S: i64 = 1_000_000;

/// A control-loop stub: drives toward a target point on the floor with a proportional command,
/// and stops when the light is lost or the camera is not calibrated yet. A real robot replaces
/// `command` with its motor driver.
///
/// With a version 2 glint, it steers from where the robot is when the age arrives, not where
/// the camera saw it: the measured position moved on by its velocity for its age (unless glint
/// already predicted it to the arrival).
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct HoldPosition {
    /// Where to go, in floor mm.
    pub target_mm: (i32, i32),
    /// The last command, in mm/s along x and y: what a motor driver would be given.
    pub command_mm_per_s: (i32, i32),
    /// The last position used, if any.
    pub last: Option<Position>,
    /// The last position's age, if it arrived.
    pub last_age: Option<ArrivedAge>,
}

impl HoldPosition {
    /// A stub steering toward `target_mm`.
    pub fn new(target_mm: (i32, i32)) -> Self {
        HoldPosition {
            target_mm,
            command_mm_per_s: (0, 0),
            last: None,
            last_age: None,
        }
    }

    /// The last position in floor mm, moved on by its velocity over `ahead_us`.
    fn steer_from(&mut self, p: &Position, ahead_us: u32) {
        let steerable = p.units == Units::Floor && p.status != Status::Lost;
        self.command_mm_per_s = if steerable {
            let ahead = |x: i16, v: i16| {
                i32::from(x) + (i64::from(v) * i64::from(ahead_us) / US_PER_S) as i32
            };
            (
                (self.target_mm.0 - ahead(p.x, p.vx_per_s)) >> GAIN_SHIFT,
                (self.target_mm.1 - ahead(p.y, p.vy_per_s)) >> GAIN_SHIFT,
            )
        } else {
            (0, 0)
        };
    }
}

impl ControlLoop for HoldPosition {
    fn on_position(&mut self, p: &Position) {
        self.last = Some(*p);
        self.last_age = None;
        self.steer_from(p, 0);
    }

    fn on_age(&mut self, age: &ArrivedAge) {
        let Some(p) = self.last.filter(|p| p.seq == age.seq) else {
            return;
        };
        self.last_age = Some(*age);
        // A predicted position is already where the robot was when the age left glint.
        let ahead_us = if age.predicted { 0 } else { age.age_us };
        self.steer_from(&p, ahead_us);
    }
}
