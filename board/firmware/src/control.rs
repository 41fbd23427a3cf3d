//! The control loop's side of the link: what it is told, and a stub that steers toward a point.

use glint_protocol::{DecodeError, Heartbeat, Position, Status, Units};

/// What a robot's control loop receives from the link.
pub trait ControlLoop {
    /// A new position update arrived.
    fn on_position(&mut self, position: &Position);
    /// A heartbeat arrived; the default ignores it.
    fn on_heartbeat(&mut self, _heartbeat: &Heartbeat) {}
    /// A frame was dropped; the default ignores it (the next frame comes within a camera frame).
    fn on_link_error(&mut self, _error: DecodeError) {}
}

/// Proportional gain of the stub: wheel speed command per mm of error, as a shift (1/8).
const GAIN_SHIFT: u32 = 3;

/// A control-loop stub: drives toward a target point on the floor with a proportional command,
/// and stops when the light is lost or the camera is not calibrated yet. A real robot replaces
/// `command` with its motor driver.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct HoldPosition {
    /// Where to go, in floor mm.
    pub target_mm: (i32, i32),
    /// The last command, in mm/s along x and y: what a motor driver would be given.
    pub command_mm_per_s: (i32, i32),
    /// The last position used, if any.
    pub last: Option<Position>,
}

impl HoldPosition {
    /// A stub steering toward `target_mm`.
    pub fn new(target_mm: (i32, i32)) -> Self {
        HoldPosition {
            target_mm,
            command_mm_per_s: (0, 0),
            last: None,
        }
    }
}

impl ControlLoop for HoldPosition {
    fn on_position(&mut self, p: &Position) {
        self.last = Some(*p);
        let steerable = p.units == Units::Floor && p.status != Status::Lost;
        self.command_mm_per_s = if steerable {
            (
                (self.target_mm.0 - i32::from(p.x)) >> GAIN_SHIFT,
                (self.target_mm.1 - i32::from(p.y)) >> GAIN_SHIFT,
            )
        } else {
            (0, 0)
        };
    }
}
