//! Protocol version 2's companion of every position update: how old the position is on arrival,
//! and whether it was extrapolated to that moment.
//!
//! It travels as its own frame (id [`AGE_ID`]) right after the position update it belongs to,
//! in the same write, so that a version 1 decoder, which skips ids it does not know, still
//! decodes the position unchanged (see `SPEC.md`).

use core::fmt;

use serde::{Deserialize, Serialize};

/// Message id of a [`PositionAge`].
pub const AGE_ID: u8 = 0x03;

/// Bit of the age flags byte: the position's x and y were extrapolated to the moment the age
/// refers to (the last byte of the age frame leaving the host), not measured at capture.
const FLAG_PREDICTED: u8 = 0b0000_0001;
/// Flag bits this version does not define: zero from a sender, malformed for a decoder.
const FLAG_RESERVED_MASK: u8 = !FLAG_PREDICTED;

/// The age of one position update when the last byte of this frame leaves the host.
///
/// The robot adds only its own receive latency (from that byte arriving to when it reads the
/// age) to know how old the position is in its own clock; the host and robot clocks need not
/// agree.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(into = "WireAge", try_from = "WireAge")]
pub struct PositionAge {
    /// The `seq` of the position update this age belongs to (sent just before it).
    pub seq: u8,
    /// Microseconds from the end of the frame's exposure (its capture timestamp) to the moment
    /// the last byte of this frame leaves the host: processing, queueing, and the line time of
    /// the position and age frames at the configured baud.
    pub age_us: u32,
    /// The position's x and y were extrapolated by `age_us` (`--predict arrival`): they say
    /// where the light is when this frame's last byte leaves the host.
    pub predicted: bool,
}

/// A field value the age frame does not allow.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct InvalidAgeFlags(pub u8);

impl fmt::Display for InvalidAgeFlags {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "invalid age flags byte {:#04x}", self.0)
    }
}

/// The byte layout of an age body: field order here is the order on the wire.
#[derive(Clone, Copy, Serialize, Deserialize)]
struct WireAge {
    seq: u8,
    age_us: u32,
    flags: u8,
}

impl From<PositionAge> for WireAge {
    fn from(a: PositionAge) -> Self {
        WireAge {
            seq: a.seq,
            age_us: a.age_us,
            flags: if a.predicted { FLAG_PREDICTED } else { 0 },
        }
    }
}

impl TryFrom<WireAge> for PositionAge {
    type Error = InvalidAgeFlags;

    fn try_from(w: WireAge) -> Result<Self, InvalidAgeFlags> {
        if w.flags & FLAG_RESERVED_MASK != 0 {
            return Err(InvalidAgeFlags(w.flags));
        }
        Ok(PositionAge {
            seq: w.seq,
            age_us: w.age_us,
            predicted: w.flags & FLAG_PREDICTED != 0,
        })
    }
}
