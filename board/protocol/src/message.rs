//! The messages glint sends to the robot, as plain Rust values.
//!
//! Each message travels as a one-byte message id followed by its body (see `SPEC.md`). The
//! bodies use postcard's encoding through serde; where a compact or strict byte layout matters
//! (the flags byte of a position, the enums), the serde impls go through small wire structs so the
//! Rust API stays typed while the bytes stay exactly as the spec says.

use core::fmt;

use serde::{Deserialize, Serialize};

use crate::age::PositionAge;
use crate::led::LedRequest;
use crate::robot::RobotPosition;

/// Version of this wire format, sent in every [`Heartbeat`]. Version 2 added the
/// [`PositionAge`] and [`LedRequest`] messages under new ids, which version 1 decoders skip;
/// version 3 the [`RobotPosition`] (a position addressed to one robot of several on one line).
/// An existing id's layout only changes with a new version.
pub const PROTOCOL_VERSION: u8 = 3;

/// Message id of a [`Position`] update.
pub const POSITION_ID: u8 = 0x01;
/// Message id of a [`Heartbeat`].
pub const HEARTBEAT_ID: u8 = 0x02;

/// Fixed-point quanta per pixel when positions are in [`Units::Pixels`]: 1/8 px.
pub const QUANTA_PER_PX: f32 = 8.0;
/// Fixed-point quanta per millimetre when positions are in [`Units::Floor`]: 1 mm.
pub const QUANTA_PER_MM: f32 = 1.0;

/// Bit of the position flags byte that says the position is on the floor (mm), not in pixels.
const FLAG_FLOOR: u8 = 0b0000_0100;
/// Bits of the position flags byte that hold the [`Status`].
const FLAG_STATUS_MASK: u8 = 0b0000_0011;
/// Flag bits this version does not define; a sender keeps them zero and a decoder rejects a
/// position that sets them (a later meaning comes with a new message id, not a silent reuse).
const FLAG_RESERVED_MASK: u8 = !(FLAG_FLOOR | FLAG_STATUS_MASK);

/// Which frame of reference a position is in, and so what one fixed-point quantum is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Units {
    /// Image coordinates: 1 quantum = 1/8 px, velocity in 1/8 px/s. Sent until the camera is
    /// calibrated against the floor markers.
    Pixels,
    /// Floor coordinates: 1 quantum = 1 mm, velocity in mm/s.
    Floor,
}

impl Units {
    /// Fixed-point quanta per unit (per px or per mm).
    pub const fn quanta_per_unit(self) -> f32 {
        match self {
            Units::Pixels => QUANTA_PER_PX,
            Units::Floor => QUANTA_PER_MM,
        }
    }
}

/// What the tracker knows about the position it sends.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum Status {
    /// The light was not found and no prediction is made; the position is the last known one.
    Lost = 0,
    /// The light was found in this frame.
    Found = 1,
    /// The light was not found in this frame; the position is predicted from the track.
    Predicted = 2,
}

impl Status {
    const fn from_bits(bits: u8) -> Option<Status> {
        match bits {
            0 => Some(Status::Lost),
            1 => Some(Status::Found),
            2 => Some(Status::Predicted),
            _ => None,
        }
    }
}

/// The tracker's overall state, as reported by the [`Heartbeat`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(into = "u8", try_from = "u8")]
#[repr(u8)]
pub enum TrackerState {
    /// Starting up: the camera is not delivering frames yet.
    Starting = 0,
    /// Frames arrive but no light is being tracked.
    Searching = 1,
    /// A light is being tracked.
    Tracking = 2,
    /// The tracked light was lost recently; positions are predicted.
    Coasting = 3,
}

impl From<TrackerState> for u8 {
    fn from(state: TrackerState) -> u8 {
        state as u8
    }
}

impl TryFrom<u8> for TrackerState {
    type Error = InvalidField;

    fn try_from(byte: u8) -> Result<Self, InvalidField> {
        match byte {
            0 => Ok(TrackerState::Starting),
            1 => Ok(TrackerState::Searching),
            2 => Ok(TrackerState::Tracking),
            3 => Ok(TrackerState::Coasting),
            _ => Err(InvalidField::TrackerState(byte)),
        }
    }
}

/// A field value the wire format does not allow.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum InvalidField {
    /// The position flags byte sets reserved bits or an undefined status.
    PositionFlags(u8),
    /// The tracker state byte is not a defined state.
    TrackerState(u8),
    /// A robot position addressed to robot 0, which is no robot's id.
    PositionRobot(u8),
}

impl fmt::Display for InvalidField {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            InvalidField::PositionFlags(byte) => {
                write!(f, "invalid position flags byte {byte:#04x}")
            }
            InvalidField::TrackerState(byte) => write!(f, "invalid tracker state {byte}"),
            InvalidField::PositionRobot(byte) => {
                write!(f, "robot {byte} is no robot's id for a position")
            }
        }
    }
}

/// One position update: where the light was in one processed frame.
///
/// Coordinates and velocities are fixed-point integers in quanta of [`Units`]: 1 mm (mm/s) on
/// the floor, 1/8 px (1/8 px/s) in the image. Build one from `f32` values with
/// [`Position::from_reading`](crate::Position::from_reading), which saturates and says so.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(into = "WirePosition", try_from = "WirePosition")]
pub struct Position {
    /// Sequence number, +1 per sent update, wrapping at 256: gaps tell the robot what it missed.
    pub seq: u8,
    /// Capture time of the frame, in µs of glint's monotonic clock, truncated to 32 bits: it
    /// wraps every 2^32 µs (71 min 34.97 s), so compare timestamps with `wrapping_sub`.
    pub timestamp_us: u32,
    /// Frame of reference and fixed-point unit of `x`, `y`, `vx_per_s`, `vy_per_s`.
    pub units: Units,
    /// X position, in quanta of `units`.
    pub x: i16,
    /// Y position, in quanta of `units`.
    pub y: i16,
    /// X velocity, in quanta of `units` per second.
    pub vx_per_s: i16,
    /// Y velocity, in quanta of `units` per second.
    pub vy_per_s: i16,
    /// Whether the light was found, predicted or lost.
    pub status: Status,
    /// Detection quality, 0 (none) to 255 (best).
    pub quality: u8,
}

impl Position {
    /// X position in whole units (px or mm).
    pub fn x_in_units(&self) -> f32 {
        f32::from(self.x) / self.units.quanta_per_unit()
    }

    /// Y position in whole units (px or mm).
    pub fn y_in_units(&self) -> f32 {
        f32::from(self.y) / self.units.quanta_per_unit()
    }

    /// X velocity in whole units per second.
    pub fn vx_in_units_per_s(&self) -> f32 {
        f32::from(self.vx_per_s) / self.units.quanta_per_unit()
    }

    /// Y velocity in whole units per second.
    pub fn vy_in_units_per_s(&self) -> f32 {
        f32::from(self.vy_per_s) / self.units.quanta_per_unit()
    }
}

/// The byte layout of a position body: field order here is the order on the wire.
#[derive(Clone, Copy, Serialize, Deserialize)]
struct WirePosition {
    seq: u8,
    // A capture timestamp uses all 32 bits almost always, so a varint would cost 5 bytes where
    // fixed little-endian costs 4: this keeps the worst case inside 24 bytes on the wire.
    #[serde(with = "postcard::fixint::le")]
    timestamp_us: u32,
    flags: u8,
    x: i16,
    y: i16,
    vx_per_s: i16,
    vy_per_s: i16,
    quality: u8,
}

impl From<Position> for WirePosition {
    fn from(p: Position) -> Self {
        let floor = match p.units {
            Units::Floor => FLAG_FLOOR,
            Units::Pixels => 0,
        };
        WirePosition {
            seq: p.seq,
            timestamp_us: p.timestamp_us,
            flags: floor | p.status as u8,
            x: p.x,
            y: p.y,
            vx_per_s: p.vx_per_s,
            vy_per_s: p.vy_per_s,
            quality: p.quality,
        }
    }
}

impl TryFrom<WirePosition> for Position {
    type Error = InvalidField;

    fn try_from(w: WirePosition) -> Result<Self, InvalidField> {
        if w.flags & FLAG_RESERVED_MASK != 0 {
            return Err(InvalidField::PositionFlags(w.flags));
        }
        let status = Status::from_bits(w.flags & FLAG_STATUS_MASK)
            .ok_or(InvalidField::PositionFlags(w.flags))?;
        let units = if w.flags & FLAG_FLOOR != 0 {
            Units::Floor
        } else {
            Units::Pixels
        };
        Ok(Position {
            seq: w.seq,
            timestamp_us: w.timestamp_us,
            units,
            x: w.x,
            y: w.y,
            vx_per_s: w.vx_per_s,
            vy_per_s: w.vy_per_s,
            status,
            quality: w.quality,
        })
    }
}

/// Periodic link and tracker status, sent about once a second so the robot can tell a quiet
/// tracker from a dead link and a newer glint from an older one.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub struct Heartbeat {
    /// The sender's [`PROTOCOL_VERSION`].
    pub protocol_version: u8,
    /// Measured camera frame rate, in hundredths of a frame per second (3000 = 30 fps).
    pub frame_rate_centihz: u16,
    /// Frames dropped since glint started (camera overruns and frames skipped to keep up).
    pub dropped_frames: u32,
    /// What the tracker is doing.
    pub tracker_state: TrackerState,
}

/// Any message of this protocol version.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum Message {
    /// A position update (id [`POSITION_ID`]).
    Position(Position),
    /// A heartbeat (id [`HEARTBEAT_ID`]).
    Heartbeat(Heartbeat),
    /// The age of the position update just before it (id [`AGE_ID`](crate::AGE_ID)).
    Age(PositionAge),
    /// A request to switch a robot's LED off (id [`LED_ID`](crate::LED_ID)).
    Led(LedRequest),
    /// A position update for one robot of several on the line (id
    /// [`ROBOT_POSITION_ID`](crate::ROBOT_POSITION_ID)).
    RobotPosition(RobotPosition),
}

impl Message {
    /// The message id that precedes this message's body on the wire.
    pub const fn id(&self) -> u8 {
        match self {
            Message::Position(_) => POSITION_ID,
            Message::Heartbeat(_) => HEARTBEAT_ID,
            Message::Age(_) => crate::age::AGE_ID,
            Message::Led(_) => crate::led::LED_ID,
            Message::RobotPosition(_) => crate::robot::ROBOT_POSITION_ID,
        }
    }
}

impl From<Position> for Message {
    fn from(p: Position) -> Self {
        Message::Position(p)
    }
}

impl From<Heartbeat> for Message {
    fn from(h: Heartbeat) -> Self {
        Message::Heartbeat(h)
    }
}

impl From<PositionAge> for Message {
    fn from(a: PositionAge) -> Self {
        Message::Age(a)
    }
}

impl From<LedRequest> for Message {
    fn from(r: LedRequest) -> Self {
        Message::Led(r)
    }
}

impl From<RobotPosition> for Message {
    fn from(r: RobotPosition) -> Self {
        Message::RobotPosition(r)
    }
}
