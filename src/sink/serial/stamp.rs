//! What the writer does at the moment it writes: stamps each position update with its age on
//! arrival (protocol version 2) and each LED request with the host time.
//!
//! The age is how old the position is when the last byte of its age frame leaves the host: from
//! the frame's capture (the end of its exposure, on the monotonic clock) to now, plus the line
//! time of everything this write puts on the line up to that byte. It is computed here, in the
//! writer thread, just before the write, and not when the frame was processed: the time an
//! update waits in the mailbox and behind the previous write is part of its age. With
//! `--predict arrival`, the position itself is moved on by that age, so it says where the light
//! is when the update arrives.
//!
//! Everything is on the stack; nothing allocates.

use glint_protocol::{
    encode, quantise, EncodeError, LedRequest, Message, Position, PositionAge, RobotPosition,
    Status,
};

use super::link::line_time;
use crate::sink::predict::Motion;

/// Rounds of stamping an update: the age's varint length and the predicted position's varint
/// lengths change the line time, which changes the age. Two rounds settle it in practice (a
/// length changes by a byte at most); a third can only move it by one byte time.
const STAMP_ROUNDS: usize = 3;

/// Microseconds per second.
const US_PER_S: f32 = 1e6;

/// A measured position (in units, before quantisation) and how to move it on.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Prediction {
    /// The measured position, px or mm.
    pub from: (f32, f32),
    /// How the light moves there.
    pub motion: Motion,
}

/// A position update waiting for the writer.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PendingUpdate {
    /// The update as measured, quantised on the capture thread.
    pub measured: Position,
    /// With `--predict arrival` and a found light with a known velocity: how to move the
    /// position on to its arrival. `None` sends the measurement.
    pub prediction: Option<Prediction>,
    /// The frame's capture time on the monotonic clock, µs.
    pub captured_monotonic_us: u64,
    /// The robot it is addressed to, on a line shared by several (protocol version 3's robot
    /// position); `None` on a line of one robot's own (a plain position update).
    pub robot: Option<u8>,
}

impl PendingUpdate {
    /// The message carrying `position` for this update's addressee.
    fn message(&self, position: Position) -> Message {
        match self.robot {
            Some(robot) => Message::RobotPosition(RobotPosition { robot, position }),
            None => Message::Position(position),
        }
    }
}

/// A LED request waiting for the writer; its `at_us` is filled in when written.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PendingLed {
    /// The request.
    pub request: LedRequest,
    /// The frame clock's origin on the monotonic clock (monotonic − frame time of the latest
    /// frame), to express the write's moment in the clock of the positions' timestamps.
    pub frame_clock_origin_us: i64,
}

/// A LED request as it went out.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct SentLed {
    /// Its request number.
    pub request: u8,
    /// Frame time (µs since the first frame) when its last byte left the host: `at_us`, not
    /// truncated to 32 bits.
    pub at_frame_us: u64,
}

/// Line time of `bytes` at `baud`, in µs.
fn line_us(bytes: usize, baud: u32) -> u64 {
    line_time(bytes as u64, baud).as_micros() as u64
}

/// The position to send for `update` when it will be `age_us` old on arrival.
fn position_at(update: &PendingUpdate, age_us: u64) -> Position {
    match update.prediction {
        Some(p) if update.measured.status == Status::Found => {
            let ahead_s = age_us as f32 / US_PER_S;
            let (x, y) = p.motion.extrapolate(p.from, ahead_s);
            let scale = update.measured.units.quanta_per_unit();
            Position {
                x: quantise(x, scale).0,
                y: quantise(y, scale).0,
                ..update.measured
            }
        }
        _ => update.measured,
    }
}

/// Encodes `update` and its age frame into `out`, for a write in which `bytes_before` bytes go
/// out ahead of them, at `baud`, starting now (`now_monotonic_us`). Returns the bytes written
/// and the age sent.
pub fn encode_update(
    update: &PendingUpdate,
    now_monotonic_us: u64,
    bytes_before: usize,
    baud: u32,
    out: &mut [u8],
) -> Result<(usize, PositionAge), EncodeError> {
    let waited_us = now_monotonic_us.saturating_sub(update.captured_monotonic_us);
    let predicted = update.prediction.is_some() && update.measured.status == Status::Found;
    let mut age_us = waited_us;
    let mut written = (
        0,
        PositionAge {
            seq: update.measured.seq,
            age_us: 0,
            predicted,
        },
    );
    for _ in 0..STAMP_ROUNDS {
        let position = encode(&update.message(position_at(update, age_us)), out)?.len();
        let age = PositionAge {
            seq: update.measured.seq,
            age_us: u32::try_from(age_us).unwrap_or(u32::MAX),
            predicted,
        };
        let rest = out.get_mut(position..).ok_or(EncodeError::BufferTooSmall)?;
        let len = position + encode(&Message::Age(age), rest)?.len();
        written = (len, age);
        let settled_us = waited_us + line_us(bytes_before + len, baud);
        if settled_us == age_us {
            break;
        }
        age_us = settled_us;
    }
    Ok(written)
}

/// Encodes `led` into `out` with `at_us` set to the frame time at which its last byte leaves
/// the host, for a write with `bytes_before` bytes ahead of it, at `baud`, starting now.
pub fn encode_led(
    led: &PendingLed,
    now_monotonic_us: u64,
    bytes_before: usize,
    baud: u32,
    out: &mut [u8],
) -> Result<(usize, SentLed), EncodeError> {
    // `at_us` is fixed-width: the frame's length does not depend on it.
    let len = encode(&Message::Led(led.request), out)?.len();
    let leaves_us = now_monotonic_us.saturating_add(line_us(bytes_before + len, baud));
    let at_frame_us =
        u64::try_from(i128::from(leaves_us) - i128::from(led.frame_clock_origin_us)).unwrap_or(0);
    let request = LedRequest {
        at_us: at_frame_us as u32,
        ..led.request
    };
    let len = encode(&Message::Led(request), out)?.len();
    Ok((
        len,
        SentLed {
            request: request.request,
            at_frame_us,
        },
    ))
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use glint_protocol::{Decoder, Reading, Received, Units, MAX_UPDATE_WIRE_LEN};

    /// A found floor position, measured at monotonic 1 s, moving at 500 mm/s along x.
    pub(crate) fn update(seq: u8) -> PendingUpdate {
        let reading = Reading {
            units: Units::Floor,
            x: 1000.0,
            y: -200.0,
            vx_per_s: 500.0,
            vy_per_s: 0.0,
        };
        PendingUpdate {
            measured: Position::from_reading(seq, 7, Status::Found, 255, reading).position,
            prediction: None,
            captured_monotonic_us: 1_000_000,
            robot: None,
        }
    }

    pub(crate) fn led(request: u8) -> PendingLed {
        PendingLed {
            request: LedRequest {
                robot: 0,
                request,
                at_us: 0,
                delay_us: 0,
                off_us: 100_000,
            },
            frame_clock_origin_us: 400_000,
        }
    }

    fn decode(bytes: &[u8]) -> Vec<Message> {
        Decoder::new()
            .feed(bytes)
            .map(|e| match e {
                Ok(Received::Message(m)) => m,
                other => panic!("{other:?}"),
            })
            .collect()
    }

    #[test]
    fn the_age_runs_from_capture_to_the_last_byte_of_the_age_frame() {
        let mut out = [0u8; MAX_UPDATE_WIRE_LEN];
        // Written 12.5 ms after capture, behind 30 bytes of other frames, at 9600 Bd.
        let (len, age) = encode_update(&update(5), 1_012_500, 30, 9_600, &mut out).unwrap();
        let messages = decode(&out[..len]);
        let [Message::Position(p), Message::Age(a)] = messages[..] else {
            panic!("{messages:?}");
        };
        assert_eq!(a, age);
        assert_eq!((a.seq, p.seq, a.predicted), (5, 5, false));
        // 12.5 ms + (30 + len bytes) × 10 bits / 9600 Bd.
        let line_us = ((30 + len) as u64 * 10 * 1_000_000) / 9_600;
        assert_eq!(u64::from(a.age_us), 12_500 + line_us);
        // Measured, not moved.
        assert_eq!((p.x, p.y), (1000, -200));
    }

    #[test]
    fn predicted_positions_move_on_by_the_age_they_are_sent_with() {
        let mut u = update(9);
        u.prediction = Some(Prediction {
            from: (1000.0, -200.0),
            motion: Motion {
                velocity_per_s: (500.0, 0.0),
                acceleration_per_s2: (0.0, -2000.0),
            },
        });
        let mut out = [0u8; MAX_UPDATE_WIRE_LEN];
        let (len, age) = encode_update(&u, 1_020_000, 0, 115_200, &mut out).unwrap();
        let messages = decode(&out[..len]);
        let [Message::Position(p), Message::Age(a)] = messages[..] else {
            panic!("{messages:?}");
        };
        assert!(a.predicted && age.predicted);
        let t_s = f64::from(a.age_us) * 1e-6;
        assert!(t_s > 0.020 && t_s < 0.024, "{t_s}");
        assert_eq!(f64::from(p.x), (1000.0 + 500.0 * t_s).round());
        assert_eq!(f64::from(p.y), (-200.0 - 1000.0 * t_s * t_s).round());
        // The measured timestamp and velocity stay as they were.
        assert_eq!((p.timestamp_us, p.vx_per_s), (7, 500));

        // A lost update is never predicted.
        u.measured.status = Status::Lost;
        let (len, age) = encode_update(&u, 1_020_000, 0, 115_200, &mut out).unwrap();
        assert!(!age.predicted);
        assert!(matches!(decode(&out[..len])[0], Message::Position(p) if p.x == 1000));
    }

    #[test]
    fn a_capture_time_after_now_is_an_age_of_line_time_only() {
        let mut out = [0u8; MAX_UPDATE_WIRE_LEN];
        let (len, age) = encode_update(&update(1), 0, 0, 115_200, &mut out).unwrap();
        assert_eq!(u64::from(age.age_us), line_us(len, 115_200));
    }

    #[test]
    fn a_led_request_carries_the_frame_time_its_last_byte_leaves() {
        let mut out = [0u8; 32];
        let (len, sent) = encode_led(&led(3), 1_000_000, 20, 9_600, &mut out).unwrap();
        let line_us = ((20 + len) as u64 * 10 * 1_000_000) / 9_600;
        assert_eq!(sent.at_frame_us, 600_000 + line_us);
        let messages = decode(&out[..len]);
        let [Message::Led(r)] = messages[..] else {
            panic!("{messages:?}");
        };
        assert_eq!((r.request, u64::from(r.at_us)), (3, sent.at_frame_us));
        assert_eq!(sent.request, 3);
    }

    #[test]
    fn a_short_buffer_is_an_error() {
        let mut out = [0u8; 20];
        assert!(encode_update(&update(1), 0, 0, 115_200, &mut out).is_err());
    }
}
