//! Protocol version 3's position update for one robot among several on one line.
//!
//! A radio bridge (or any shared serial line) carries every robot's updates, so each must say
//! whose it is. It is a new message id rather than a field appended to [`Position`]: a version 1
//! or 2 decoder rejects a position with bytes left over as malformed, and worse, a firmware that
//! did decode it would steer by another robot's position. Under a new id, an older firmware on a
//! shared line skips every update (it cannot know which is its own, and a robot without updates
//! stops), while on a line of its own glint keeps sending it plain [`Position`] updates.

use serde::{Deserialize, Serialize};

use crate::message::{InvalidField, Position};

/// Message id of a [`RobotPosition`].
pub const ROBOT_POSITION_ID: u8 = 0x05;

/// A position update addressed to one robot: `robot` ‖ the body of a [`Position`].
///
/// `position.seq` counts this robot's updates (+1 per update to this robot), so a gap is an
/// update this robot missed, whatever the other robots on the line received. Its
/// [`PositionAge`](crate::PositionAge) follows it at once in the same write; on a shared line a
/// robot takes an age only if it comes right after its own update.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(into = "WireRobotPosition", try_from = "WireRobotPosition")]
pub struct RobotPosition {
    /// The robot this update is for, 1..=255; 0 (every robot) is not an address for a position.
    pub robot: u8,
    /// The update itself, exactly as a [`Position`] frame carries it.
    pub position: Position,
}

/// The byte layout: the robot id, then the position body.
#[derive(Clone, Copy, Serialize, Deserialize)]
struct WireRobotPosition {
    robot: u8,
    position: Position,
}

impl From<RobotPosition> for WireRobotPosition {
    fn from(r: RobotPosition) -> Self {
        WireRobotPosition {
            robot: r.robot,
            position: r.position,
        }
    }
}

impl TryFrom<WireRobotPosition> for RobotPosition {
    type Error = InvalidField;

    fn try_from(w: WireRobotPosition) -> Result<Self, InvalidField> {
        if w.robot == crate::led::EVERY_ROBOT {
            return Err(InvalidField::PositionRobot(w.robot));
        }
        Ok(RobotPosition {
            robot: w.robot,
            position: w.position,
        })
    }
}
