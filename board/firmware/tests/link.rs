//! The firmware's link logic on the host: UART bytes in, control-loop calls out.

use std::collections::VecDeque;

use embedded_io::{ErrorKind, ErrorType, Read};
use glint_firmware::demo::{DemoLed, Replay, DEMO_STREAM};
use glint_firmware::{ArrivedAge, ControlLoop, HoldPosition, Link, LinkStats, WithLed};
use glint_protocol::{
    encode, DecodeError, Heartbeat, LedRequest, Message, Position, PositionAge, Status, Units,
};

/// A scripted UART: each read returns the next chunk or error.
struct ScriptedUart(VecDeque<Result<Vec<u8>, ErrorKind>>);

impl ErrorType for ScriptedUart {
    type Error = ErrorKind;
}

impl Read for ScriptedUart {
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, ErrorKind> {
        match self.0.pop_front() {
            Some(Ok(bytes)) => {
                buf[..bytes.len()].copy_from_slice(&bytes);
                Ok(bytes.len())
            }
            Some(Err(e)) => Err(e),
            None => Ok(0),
        }
    }
}

/// A clock that advances by a fixed step on every reading.
fn stepping_clock(start_us: u32, step_us: u32) -> impl FnMut() -> u32 {
    let mut now = start_us.wrapping_sub(step_us);
    move || {
        now = now.wrapping_add(step_us);
        now
    }
}

/// A control loop that records everything, as a version 1 firmware would (no `on_age`).
#[derive(Default)]
struct Recorder {
    positions: Vec<Position>,
    heartbeats: Vec<Heartbeat>,
    errors: Vec<DecodeError>,
}

impl ControlLoop for Recorder {
    fn on_position(&mut self, p: &Position) {
        self.positions.push(*p);
    }
    fn on_heartbeat(&mut self, h: &Heartbeat) {
        self.heartbeats.push(*h);
    }
    fn on_link_error(&mut self, e: DecodeError) {
        self.errors.push(e);
    }
}

fn position(seq: u8, x: i16, y: i16) -> Position {
    Position {
        seq,
        timestamp_us: 1_000 * u32::from(seq),
        units: Units::Floor,
        x,
        y,
        vx_per_s: 0,
        vy_per_s: 0,
        status: Status::Found,
        quality: 200,
    }
}

fn encoded(m: Message) -> Vec<u8> {
    let mut out = [0u8; 65];
    encode(&m, &mut out).expect("fits").to_vec()
}

fn frame(p: Position) -> Vec<u8> {
    encoded(Message::Position(p))
}

fn age(seq: u8, age_us: u32, predicted: bool) -> Vec<u8> {
    encoded(Message::Age(PositionAge {
        seq,
        age_us,
        predicted,
    }))
}

#[test]
fn demo_stream_steers_the_stub_toward_home() {
    let mut link = Link::new(Replay::new(DEMO_STREAM), stepping_clock(0, 100));
    let mut robot = WithLed::new(HoldPosition::new((1000, 500)), DemoLed::default(), 1);
    let mut read = 0;
    while read < DEMO_STREAM.len() {
        read += link.poll(&mut robot).expect("replay cannot fail");
    }
    let control = &robot.control;
    let p = control.last.expect("a position arrived");
    assert_eq!((p.x, p.y), (1520, -310));
    // The position moved on at 250 mm/s for its 5.23 ms age: x 1521.3. (1000 − 1521) / 8 and
    // (500 + 310) / 8, rounded toward −∞ by the shift (without the age: −65).
    assert_eq!(control.command_mm_per_s, (-66, 101));
    assert_eq!(control.last_age.map(|a| a.age_us), Some(5_230));
    // The demo's LED request (every robot, off at once for 200 ms) was carried out.
    assert!(!robot.led_on());
    assert_eq!(robot.answered, 1);
    assert_eq!(
        link.stats(),
        LinkStats {
            positions: 1,
            heartbeats: 1,
            ages: 1,
            led_requests: 1,
            ..LinkStats::default()
        }
    );
}

#[test]
fn the_age_is_counted_on_in_the_robots_clock() {
    // Each UART read returns one frame; the robot's clock reads 1000, 1250, ... per chunk.
    let script = VecDeque::from([Ok(frame(position(9, 100, 0))), Ok(age(9, 7_000, false))]);
    let mut link = Link::new(ScriptedUart(script), stepping_clock(1_000, 250));
    let mut control = HoldPosition::new((0, 0));
    while link.poll(&mut control).expect("no UART error") > 0 {}
    let arrived = control.last_age.expect("the age arrived");
    assert_eq!(
        arrived,
        ArrivedAge {
            seq: 9,
            age_us: 7_000,
            received_at_us: 1_250,
            predicted: false,
        }
    );
    // 3 ms after it arrived (the clock wrapped meanwhile), the position is 10 ms old.
    let late = ArrivedAge {
        received_at_us: u32::MAX - 999,
        ..arrived
    };
    assert_eq!(late.age_at_us(2_000), 10_000);
    assert_eq!(arrived.age_at_us(4_250), 10_000);
}

#[test]
fn an_age_for_a_lost_position_is_ignored_and_a_predicted_one_is_not_moved_again() {
    let fast = Position {
        vx_per_s: 1_000,
        ..position(3, 800, 0)
    };
    let script = VecDeque::from([
        Ok(frame(fast)),
        Ok(age(2, 50_000, false)), // the age of an update that never arrived
        Ok(age(3, 16_000, true)),
    ]);
    let mut link = Link::new(ScriptedUart(script), stepping_clock(0, 10));
    let mut control = HoldPosition::new((0, 0));
    while link.poll(&mut control).expect("no UART error") > 0 {}
    assert_eq!(link.stats().ages, 1);
    // Predicted by glint already: steer from x = 800 as sent (−800 / 8).
    assert_eq!(control.command_mm_per_s, (-100, 0));
    // Measured, 16 ms old at 1 m/s: the robot is 16 mm further on.
    control.on_age(&ArrivedAge {
        seq: 3,
        age_us: 16_000,
        received_at_us: 0,
        predicted: false,
    });
    assert_eq!(control.command_mm_per_s, (-102, 0));
}

#[test]
fn a_version_1_control_loop_steers_on_version_2_traffic() {
    // The new messages reach a loop that does not handle them and change nothing.
    let led = encoded(Message::Led(LedRequest {
        robot: 0,
        request: 1,
        at_us: 0,
        delay_us: 0,
        off_us: 1_000,
    }));
    let script = VecDeque::from([
        Ok(frame(position(1, 10, 20))),
        Ok(age(1, 4_000, false)),
        Ok(led),
        Ok(frame(position(2, 30, 40))),
        Ok(age(2, 4_000, true)),
    ]);
    let mut link = Link::new(ScriptedUart(script), stepping_clock(0, 1));
    let mut rec = Recorder::default();
    while link.poll(&mut rec).expect("no UART error") > 0 {}
    assert_eq!(rec.positions, [position(1, 10, 20), position(2, 30, 40)]);
    assert!(rec.errors.is_empty());
    assert_eq!(link.stats().dropped, 0);
}

#[test]
fn the_led_answers_requests_for_this_robot_at_the_requested_moments() {
    let request = |robot, delay_us, off_us| LedRequest {
        robot,
        request: 0,
        at_us: 0,
        delay_us,
        off_us,
    };
    let mut robot = WithLed::new(HoldPosition::new((0, 0)), DemoLed::default(), 4);
    assert!(robot.led_on());
    // For robot 5: ignored.
    robot.on_led(&request(5, 0, 10_000), 1_000);
    robot.tick(2_000);
    assert!(robot.led_on());
    assert_eq!(robot.answered, 0);
    // For robot 4, 3 ms after arrival, for 10 ms; the clock wraps in between.
    let t0 = u32::MAX - 5_000;
    robot.on_led(&request(4, 3_000, 10_000), t0);
    robot.tick(t0.wrapping_add(2_999));
    assert!(robot.led_on());
    robot.tick(t0.wrapping_add(3_000));
    assert!(!robot.led_on());
    robot.tick(t0.wrapping_add(12_999));
    assert!(!robot.led_on());
    robot.tick(t0.wrapping_add(13_000));
    assert!(robot.led_on());
    // Every robot, at once, then "back on now" cancels it.
    robot.on_led(&request(0, 0, 50_000), 100);
    assert!(!robot.led_on());
    robot.on_led(&request(4, 0, 0), 200);
    assert!(robot.led_on());
    robot.tick(1_000);
    assert!(robot.led_on());
    assert_eq!(robot.answered, 3);
}

#[test]
fn stub_stops_when_the_light_is_lost_or_uncalibrated() {
    let mut control = HoldPosition::new((0, 0));
    control.on_position(&position(1, 800, 800));
    assert_eq!(control.command_mm_per_s, (-100, -100));
    control.on_position(&Position {
        status: Status::Lost,
        ..position(2, 800, 800)
    });
    assert_eq!(control.command_mm_per_s, (0, 0));
    control.on_position(&Position {
        units: Units::Pixels,
        ..position(3, 800, 800)
    });
    assert_eq!(control.command_mm_per_s, (0, 0));
}

#[test]
fn sequence_gaps_count_missed_updates_across_the_wrap() {
    let seqs = [253u8, 254, 1, 2, 6];
    let chunks = seqs.iter().map(|&s| Ok(frame(position(s, 0, 0)))).collect();
    let mut link = Link::new(ScriptedUart(chunks), stepping_clock(0, 1));
    let mut rec = Recorder::default();
    while link.poll(&mut rec).expect("no UART error") > 0 {}
    assert_eq!(
        rec.positions.iter().map(|p| p.seq).collect::<Vec<_>>(),
        seqs
    );
    // 254 → 1 skips 255 and 0; 2 → 6 skips 3, 4, 5.
    assert_eq!(link.stats().missed, 5);
}

#[test]
fn a_uart_error_drops_the_partial_frame_and_the_link_recovers() {
    let first = frame(position(1, 10, 20));
    let (head, tail) = first.split_at(8);
    let script = VecDeque::from([
        Ok(head.to_vec()),
        Err(ErrorKind::Other), // overrun: the rest of frame 1 is lost
        Ok(tail.to_vec()),     // the tail alone is not a frame
        Ok(frame(position(2, 30, 40))),
    ]);
    let mut link = Link::new(ScriptedUart(script), stepping_clock(0, 1));
    let mut rec = Recorder::default();
    assert_eq!(link.poll(&mut rec), Ok(8));
    assert_eq!(link.poll(&mut rec), Err(ErrorKind::Other));
    while link.poll(&mut rec).expect("no more errors") > 0 {}
    assert_eq!(rec.positions, [position(2, 30, 40)]);
    assert_eq!(
        rec.errors.len(),
        1,
        "the orphaned tail is dropped once: {:?}",
        rec.errors
    );
    assert_eq!(link.stats().dropped, 1);
}
