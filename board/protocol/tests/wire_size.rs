//! The position update's worst case on the wire: at most 24 bytes, framing and CRC included.

use glint_protocol::{
    encode, Heartbeat, LedRequest, Message, Position, PositionAge, RobotPosition, Status,
    TrackerState, Units, MAX_AGE_WIRE_LEN, MAX_ENCODED_LEN, MAX_LED_WIRE_LEN,
    MAX_POSITION_WIRE_LEN, MAX_ROBOT_POSITION_WIRE_LEN, MAX_UPDATE_WIRE_LEN,
};
use proptest::prelude::*;

/// The budget the protocol promises for a position update (issue #6).
const POSITION_BUDGET_BYTES: usize = 24;

fn wire_len(message: &Message) -> usize {
    let mut out = [0u8; MAX_ENCODED_LEN + 1];
    encode(message, &mut out).expect("fits").len()
}

/// Values at the edges of each varint length and of the type's range.
const I16_EDGES: [i16; 8] = [i16::MIN, -8193, -8192, -65, 0, 63, 8191, i16::MAX];

#[test]
fn every_extreme_position_fits_the_budget_and_the_worst_reaches_it() {
    const { assert!(MAX_POSITION_WIRE_LEN <= POSITION_BUDGET_BYTES) };
    let mut longest = 0;
    let mut longest_robot = 0;
    for &seq in &[0u8, 255] {
        for &timestamp_us in &[0u32, u32::MAX] {
            for &units in &[Units::Pixels, Units::Floor] {
                for &status in &[Status::Lost, Status::Found, Status::Predicted] {
                    for &x in &I16_EDGES {
                        for &y in &I16_EDGES {
                            for &vx_per_s in &I16_EDGES {
                                for &vy_per_s in &I16_EDGES {
                                    for &quality in &[0u8, 255] {
                                        let p = Position {
                                            seq,
                                            timestamp_us,
                                            units,
                                            x,
                                            y,
                                            vx_per_s,
                                            vy_per_s,
                                            status,
                                            quality,
                                        };
                                        let len = wire_len(&Message::Position(p));
                                        assert!(len <= MAX_POSITION_WIRE_LEN, "{p:?}: {len} bytes");
                                        longest = longest.max(len);
                                        // Addressed to a robot (version 3): one byte more.
                                        let addressed = RobotPosition {
                                            robot: 255,
                                            position: p,
                                        };
                                        let robot_len =
                                            wire_len(&Message::RobotPosition(addressed));
                                        assert_eq!(robot_len, len + 1, "{p:?}");
                                        longest_robot = longest_robot.max(robot_len);
                                    }
                                }
                            }
                        }
                    }
                }
            }
        }
    }
    // The bound is tight: some position really takes all of it.
    assert_eq!(longest, MAX_POSITION_WIRE_LEN);
    assert_eq!(longest_robot, MAX_ROBOT_POSITION_WIRE_LEN);
}

#[test]
fn heartbeat_fits_the_frame_limit_at_its_largest() {
    let h = Heartbeat {
        protocol_version: u8::MAX,
        frame_rate_centihz: u16::MAX,
        dropped_frames: u32::MAX,
        tracker_state: TrackerState::Coasting,
    };
    assert_eq!(wire_len(&Message::Heartbeat(h)), 15);
}

/// Values at the edges of each u32 varint length.
const U32_EDGES: [u32; 6] = [0, 127, 128, 16_383, 1 << 28, u32::MAX];

#[test]
fn age_and_led_frames_fit_their_bounds_and_the_worst_reach_them() {
    let mut longest_age = 0;
    for &age_us in &U32_EDGES {
        for predicted in [false, true] {
            for seq in [0u8, 255] {
                let a = PositionAge {
                    seq,
                    age_us,
                    predicted,
                };
                longest_age = longest_age.max(wire_len(&Message::Age(a)));
            }
        }
    }
    assert_eq!(longest_age, MAX_AGE_WIRE_LEN);
    assert_eq!(
        MAX_UPDATE_WIRE_LEN,
        MAX_ROBOT_POSITION_WIRE_LEN + MAX_AGE_WIRE_LEN
    );

    let mut longest_led = 0;
    for &delay_us in &U32_EDGES {
        for &off_us in &U32_EDGES {
            for at_us in [0, u32::MAX] {
                let r = LedRequest {
                    robot: 255,
                    request: 255,
                    at_us,
                    delay_us,
                    off_us,
                };
                longest_led = longest_led.max(wire_len(&Message::Led(r)));
            }
        }
    }
    assert_eq!(longest_led, MAX_LED_WIRE_LEN);
    // Every message stays inside the decoders' 64-byte buffer.
    const { assert!(MAX_LED_WIRE_LEN - 1 <= MAX_ENCODED_LEN) };
}

fn any_position() -> impl Strategy<Value = Position> {
    (
        any::<u8>(),
        any::<u32>(),
        any::<bool>(),
        any::<[i16; 4]>(),
        0u8..3,
        any::<u8>(),
    )
        .prop_map(
            |(seq, timestamp_us, floor, [x, y, vx_per_s, vy_per_s], status, quality)| Position {
                seq,
                timestamp_us,
                units: if floor { Units::Floor } else { Units::Pixels },
                x,
                y,
                vx_per_s,
                vy_per_s,
                status: [Status::Lost, Status::Found, Status::Predicted][usize::from(status)],
                quality,
            },
        )
}

proptest! {
    #[test]
    fn random_positions_fit_the_budget(p in any_position()) {
        prop_assert!(wire_len(&Message::Position(p)) <= MAX_POSITION_WIRE_LEN);
    }

    #[test]
    fn a_buffer_one_byte_short_is_an_error_not_a_panic(p in any_position()) {
        let len = wire_len(&Message::Position(p));
        let mut out = [0u8; MAX_ENCODED_LEN];
        let short = &mut out[..len - 1];
        prop_assert!(encode(&Message::Position(p), short).is_err());
    }
}
