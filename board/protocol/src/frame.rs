//! One frame on the wire: `COBS(id ‖ body ‖ CRC-16 little-endian) ‖ 0x00`.
//!
//! Encoding is a single postcard serialisation through stacked flavors: the CRC flavor sees the
//! raw payload bytes, the COBS flavor stuffs payload and CRC as they come, and the slice flavor
//! writes into the caller's buffer. Nothing is allocated and no intermediate copy is made.

use core::fmt;

use crc::{Crc, CRC_16_IBM_3740};
use postcard::ser_flavors::crc::CrcModifier;
use postcard::ser_flavors::{Cobs, Slice};

use crate::age::{PositionAge, AGE_ID};
use crate::led::{LedRequest, LED_ID};
use crate::message::{Heartbeat, Message, Position, HEARTBEAT_ID, POSITION_ID};
use crate::robot::{RobotPosition, ROBOT_POSITION_ID};

/// The frame check: CRC-16/IBM-3740, better known as CRC-16/CCITT-FALSE. Polynomial 0x1021,
/// initial value 0xFFFF, no input or output reflection, no final XOR; check value (CRC of the
/// ASCII bytes `123456789`) 0x29B1. Its Hamming distance is 4 for any message up to 4095 bytes,
/// so every 1-, 2- and 3-bit error and every burst of up to 16 bits in a payload is caught.
pub const FRAME_CRC: Crc<u16> = Crc::<u16>::new(&CRC_16_IBM_3740);

/// Bytes of the CRC trailer.
pub const CRC_LEN: usize = 2;
/// Bytes of the message id.
pub const ID_LEN: usize = 1;
/// The frame delimiter; COBS guarantees it occurs nowhere else in a frame.
pub const DELIMITER: u8 = 0x00;

/// Longest position update on the wire, delimiter included: id 1 + seq 1 + timestamp 4 +
/// flags 1 + four 3-byte varints + quality 1 + CRC 2 + COBS overhead 1 + delimiter 1.
pub const MAX_POSITION_WIRE_LEN: usize = 24;

/// Longest robot position update (version 3) on the wire: a position update and the robot id.
pub const MAX_ROBOT_POSITION_WIRE_LEN: usize = MAX_POSITION_WIRE_LEN + 1;

/// Longest age frame on the wire, delimiter included: id 1 + seq 1 + 5-byte varint + flags 1 +
/// CRC 2 + COBS overhead 1 + delimiter 1.
pub const MAX_AGE_WIRE_LEN: usize = 12;

/// Longest position update (either kind) with its age frame, as versions 2 and 3 send them in
/// one write.
pub const MAX_UPDATE_WIRE_LEN: usize = MAX_ROBOT_POSITION_WIRE_LEN + MAX_AGE_WIRE_LEN;

/// Longest LED request on the wire, delimiter included: id 1 + robot 1 + request 1 + at 4 +
/// two 5-byte varints + CRC 2 + COBS overhead 1 + delimiter 1.
pub const MAX_LED_WIRE_LEN: usize = 21;

/// Longest frame any protocol version may send, counting the COBS bytes between two delimiters
/// (the delimiter itself not included). Decoders hold this much and discard longer frames; future
/// messages must fit in it, which leaves them 60 bytes of id and body.
pub const MAX_ENCODED_LEN: usize = 64;

/// Why a message could not be encoded.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum EncodeError {
    /// The output buffer is smaller than the frame; [`MAX_ENCODED_LEN`] + 1 bytes always suffice.
    BufferTooSmall,
}

impl fmt::Display for EncodeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            EncodeError::BufferTooSmall => {
                write!(
                    f,
                    "output buffer too small for the frame (give it {} bytes)",
                    MAX_ENCODED_LEN + 1
                )
            }
        }
    }
}

/// Encodes `message` as one complete frame, trailing 0x00 delimiter included, into `out`, and
/// returns the part of `out` that holds it.
pub fn encode<'a>(message: &Message, out: &'a mut [u8]) -> Result<&'a [u8], EncodeError> {
    let cobs = Cobs::try_new(Slice::new(out)).map_err(|_| EncodeError::BufferTooSmall)?;
    let flavor = CrcModifier::new(cobs, FRAME_CRC.digest());
    let written = match message {
        Message::Position(p) => postcard::serialize_with_flavor(&(POSITION_ID, p), flavor),
        Message::Heartbeat(h) => postcard::serialize_with_flavor(&(HEARTBEAT_ID, h), flavor),
        Message::Age(a) => postcard::serialize_with_flavor(&(AGE_ID, a), flavor),
        Message::Led(r) => postcard::serialize_with_flavor(&(LED_ID, r), flavor),
        Message::RobotPosition(r) => {
            postcard::serialize_with_flavor(&(ROBOT_POSITION_ID, r), flavor)
        }
    };
    // The only way these serde types can fail to serialise is running out of buffer.
    written
        .map(|bytes| &*bytes)
        .map_err(|_| EncodeError::BufferTooSmall)
}

/// Why a payload (a COBS-decoded frame) was rejected.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PayloadError {
    /// Fewer bytes than a message id and a CRC.
    TooShort,
    /// The CRC trailer does not match the bytes before it.
    Crc,
    /// The CRC matched but the body of a known message id is malformed: bad varint, undefined
    /// flag or enum value, or bytes left over after the last field.
    Malformed {
        /// The message id whose body was malformed.
        id: u8,
    },
}

/// What a valid payload holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Received {
    /// A message this version knows.
    Message(Message),
    /// A message with an id this version does not know (from a newer glint): its CRC was good,
    /// so it was a real message, and the stream goes on.
    Unknown {
        /// The unknown message id.
        id: u8,
    },
}

/// Checks and parses a COBS-decoded payload: `id ‖ body ‖ CRC-16 LE`.
pub fn parse_payload(payload: &[u8]) -> Result<Received, PayloadError> {
    if payload.len() < ID_LEN + CRC_LEN {
        return Err(PayloadError::TooShort);
    }
    let (checked, trailer) = payload.split_at(payload.len() - CRC_LEN);
    let sent_crc = match trailer {
        [lo, hi] => u16::from_le_bytes([*lo, *hi]),
        _ => return Err(PayloadError::TooShort),
    };
    if FRAME_CRC.checksum(checked) != sent_crc {
        return Err(PayloadError::Crc);
    }
    let (id, body) = match checked.split_first() {
        Some((id, body)) => (*id, body),
        None => return Err(PayloadError::TooShort),
    };
    let malformed = PayloadError::Malformed { id };
    let message = match id {
        POSITION_ID => Message::Position(parse_exact::<Position>(body).ok_or(malformed)?),
        HEARTBEAT_ID => Message::Heartbeat(parse_exact::<Heartbeat>(body).ok_or(malformed)?),
        AGE_ID => Message::Age(parse_exact::<PositionAge>(body).ok_or(malformed)?),
        LED_ID => Message::Led(parse_exact::<LedRequest>(body).ok_or(malformed)?),
        ROBOT_POSITION_ID => {
            Message::RobotPosition(parse_exact::<RobotPosition>(body).ok_or(malformed)?)
        }
        _ => return Ok(Received::Unknown { id }),
    };
    Ok(Received::Message(message))
}

/// Deserialises a `T` that must use every byte of `body`: leftovers mean the frame is not what
/// its id claims, so it is rejected rather than half-read.
fn parse_exact<'de, T: serde::Deserialize<'de>>(body: &'de [u8]) -> Option<T> {
    match postcard::take_from_bytes::<T>(body) {
        Ok((value, [])) => Some(value),
        _ => None,
    }
}
