//! A streaming frame decoder for the receiving end of a UART, in the manner of postcard's
//! `CobsAccumulator`: feed it bytes one at a time or in chunks as they arrive, and it reports each
//! frame as it completes.
//!
//! Memory is one fixed buffer of `N` bytes inside the decoder. Resynchronisation needs no special
//! state: every 0x00 ends a frame, so garbage, a frame cut short by a reset or a frame with a bad
//! CRC costs exactly that one frame, reported once as an error, and the next frame decodes.
//! Empty frames (two delimiters in a row) are silently ignored, so a sender may send a lone 0x00
//! at any time to flush whatever partial frame the receiver holds.

use core::fmt;

use heapless::Vec;

use crate::frame::{parse_payload, PayloadError, Received, DELIMITER, MAX_ENCODED_LEN};

/// Why a frame was dropped. Every variant costs one frame and never the stream.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DecodeError {
    /// More bytes arrived before a delimiter than the decoder holds: a frame from a protocol that
    /// is not this one, or garbage. Discarded up to the next delimiter.
    Overflow,
    /// The bytes between two delimiters are not valid COBS (a code byte points past the end).
    Cobs,
    /// Fewer bytes than a message id and a CRC.
    TooShort,
    /// The CRC trailer does not match: corrupted on the line.
    Crc,
    /// The CRC matched but the body of a known message id is malformed.
    Malformed {
        /// The message id whose body was malformed.
        id: u8,
    },
}

impl fmt::Display for DecodeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            DecodeError::Overflow => write!(f, "frame longer than the decoder's buffer, dropped"),
            DecodeError::Cobs => write!(f, "frame is not valid COBS, dropped"),
            DecodeError::TooShort => {
                write!(f, "frame too short for a message id and a CRC, dropped")
            }
            DecodeError::Crc => write!(f, "frame CRC mismatch, dropped"),
            DecodeError::Malformed { id } => {
                write!(f, "malformed body for message id {id:#04x}, dropped")
            }
        }
    }
}

impl From<PayloadError> for DecodeError {
    fn from(e: PayloadError) -> Self {
        match e {
            PayloadError::TooShort => DecodeError::TooShort,
            PayloadError::Crc => DecodeError::Crc,
            PayloadError::Malformed { id } => DecodeError::Malformed { id },
        }
    }
}

/// A streaming decoder holding at most `N` COBS bytes of one frame.
///
/// `N` defaults to [`MAX_ENCODED_LEN`], enough for every message any protocol version may send;
/// a firmware that is short of RAM may pick a smaller `N` (at least 23 for positions), at the
/// price of seeing longer future messages as [`DecodeError::Overflow`] instead of
/// [`Received::Unknown`].
#[derive(Debug, Clone)]
pub struct Decoder<const N: usize = MAX_ENCODED_LEN> {
    buf: Vec<u8, N>,
    /// Set when the current frame outgrew `buf`: its remaining bytes are dropped until the next
    /// delimiter, where one `Overflow` is reported.
    overflowed: bool,
}

impl<const N: usize> Default for Decoder<N> {
    fn default() -> Self {
        Self::with_capacity()
    }
}

impl Decoder {
    /// An empty decoder of the default [`MAX_ENCODED_LEN`] bytes, waiting for the first byte.
    pub const fn new() -> Self {
        Self::with_capacity()
    }
}

impl<const N: usize> Decoder<N> {
    /// An empty decoder of `N` bytes, e.g. `Decoder::<23>::with_capacity()`.
    pub const fn with_capacity() -> Self {
        Decoder {
            buf: Vec::new(),
            overflowed: false,
        }
    }

    /// Feeds one byte. Returns `Some` when the byte completed a (non-empty) frame.
    pub fn push(&mut self, byte: u8) -> Option<Result<Received, DecodeError>> {
        if byte != DELIMITER {
            if !self.overflowed && self.buf.push(byte).is_err() {
                self.overflowed = true;
            }
            return None;
        }
        let outcome = if self.overflowed {
            Some(Err(DecodeError::Overflow))
        } else if self.buf.is_empty() {
            None
        } else {
            Some(decode_frame(&mut self.buf))
        };
        self.buf.clear();
        self.overflowed = false;
        outcome
    }

    /// Feeds a chunk, such as what one UART read returned. The iterator yields each frame the
    /// chunk completes, in order; bytes it does not reach (if dropped early) are not consumed,
    /// so drain it to consume the whole chunk.
    pub fn feed<'d, 'b>(&'d mut self, bytes: &'b [u8]) -> Frames<'d, 'b, N> {
        Frames {
            decoder: self,
            bytes: bytes.iter(),
        }
    }

    /// Forgets any partial frame, e.g. after the UART reported a framing error.
    pub fn reset(&mut self) {
        self.buf.clear();
        self.overflowed = false;
    }
}

/// Decodes the COBS bytes of one frame in place and parses the payload.
fn decode_frame(encoded: &mut [u8]) -> Result<Received, DecodeError> {
    let payload_len = cobs::decode_in_place(encoded).map_err(|_| DecodeError::Cobs)?;
    let payload = encoded.get(..payload_len).ok_or(DecodeError::Cobs)?;
    Ok(parse_payload(payload)?)
}

/// The frames completed by one chunk; see [`Decoder::feed`].
#[derive(Debug)]
pub struct Frames<'d, 'b, const N: usize> {
    decoder: &'d mut Decoder<N>,
    bytes: core::slice::Iter<'b, u8>,
}

impl<const N: usize> Iterator for Frames<'_, '_, N> {
    type Item = Result<Received, DecodeError>;

    fn next(&mut self) -> Option<Self::Item> {
        for &byte in self.bytes.by_ref() {
            if let Some(outcome) = self.decoder.push(byte) {
                return Some(outcome);
            }
        }
        None
    }
}
