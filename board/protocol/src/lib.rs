//! glint-protocol: the serial wire format between glint and the robot's microcontroller.
//!
//! glint sends a [`Position`] update per processed frame (a [`RobotPosition`] per robot when
//! several robots share the line), each followed by its [`PositionAge`]
//! (how old the position is when it arrives), a [`Heartbeat`] about once a second, and on
//! request a [`LedRequest`] (switch the LED off for a while). Each message is one frame on the
//! UART:
//!
//! ```text
//! COBS( id:u8 ‖ postcard body ‖ CRC-16/CCITT-FALSE, little-endian ) ‖ 0x00
//! ```
//!
//! A position update is at most [`MAX_POSITION_WIRE_LEN`] (24) bytes on the wire. The byte
//! layout is written out in `SPEC.md`, with test vectors the tests parse from that file.
//!
//! # Memory model
//!
//! Nothing here allocates: the crate is `no_std` without `alloc`. [`encode`] writes into a
//! buffer the caller owns; a [`Decoder`] is one fixed `N`-byte buffer (64 by default) plus a flag,
//! and decodes each frame in place in it.
//!
//! ```
//! use glint_protocol::{encode, Decoder, Message, Position, Reading, Received, Status, Units};
//!
//! let q = Position::from_reading(1, 123_456, Status::Found, 200, Reading {
//!     units: Units::Floor, x: 1520.0, y: -310.0, vx_per_s: 250.0, vy_per_s: 0.0,
//! });
//! assert!(!q.clamped.any());
//! let mut out = [0u8; 32];
//! let frame = encode(&Message::Position(q.position), &mut out).unwrap();
//!
//! let mut decoder = Decoder::new();
//! let got: Vec<_> = decoder.feed(frame).collect();
//! assert_eq!(got, [Ok(Received::Message(Message::Position(q.position)))]);
//! ```
#![no_std]
#![forbid(unsafe_code)]
#![warn(missing_docs)]

mod age;
mod decoder;
mod frame;
mod led;
mod message;
mod quantise;
mod robot;

pub use age::{InvalidAgeFlags, PositionAge, AGE_ID};
pub use decoder::{DecodeError, Decoder, Frames};
pub use frame::{
    encode, parse_payload, EncodeError, PayloadError, Received, CRC_LEN, DELIMITER, FRAME_CRC,
    ID_LEN, MAX_AGE_WIRE_LEN, MAX_ENCODED_LEN, MAX_LED_WIRE_LEN, MAX_POSITION_WIRE_LEN,
    MAX_ROBOT_POSITION_WIRE_LEN, MAX_UPDATE_WIRE_LEN,
};
pub use led::{LedRequest, EVERY_ROBOT, LED_ID};
pub use message::{
    Heartbeat, InvalidField, Message, Position, Status, TrackerState, Units, HEARTBEAT_ID,
    POSITION_ID, PROTOCOL_VERSION, QUANTA_PER_MM, QUANTA_PER_PX,
};
pub use quantise::{quantise, Clamped, Quantised, Reading};
pub use robot::{RobotPosition, ROBOT_POSITION_ID};
