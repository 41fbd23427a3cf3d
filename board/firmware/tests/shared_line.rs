//! The firmware on a line shared by several robots (protocol version 3): a robot takes its own
//! updates, their ages and its LED requests, and nothing of the others'.

use std::collections::VecDeque;

use embedded_io::{ErrorKind, ErrorType, Read};
use glint_firmware::demo::DemoLed;
use glint_firmware::{ArrivedAge, ControlLoop, Link, WithLed};
use glint_protocol::{
    encode, LedRequest, Message, Position, PositionAge, RobotPosition, Status, Units,
};

/// A scripted UART: each read returns the next chunk.
struct ScriptedUart(VecDeque<Vec<u8>>);

impl ErrorType for ScriptedUart {
    type Error = ErrorKind;
}

impl Read for ScriptedUart {
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, ErrorKind> {
        match self.0.pop_front() {
            Some(bytes) => {
                buf[..bytes.len()].copy_from_slice(&bytes);
                Ok(bytes.len())
            }
            None => Ok(0),
        }
    }
}

/// What a robot's control loop was handed.
#[derive(Default)]
struct Recorder {
    positions: Vec<Position>,
    ages: Vec<ArrivedAge>,
}

impl ControlLoop for Recorder {
    fn on_position(&mut self, p: &Position) {
        self.positions.push(*p);
    }
    fn on_age(&mut self, a: &ArrivedAge) {
        self.ages.push(*a);
    }
}

/// A position whose x says which robot it was meant for (x = 100 × robot).
fn position(seq: u8, robot: u8) -> Position {
    Position {
        seq,
        timestamp_us: 40_000 * u32::from(seq),
        units: Units::Floor,
        x: 100 * i16::from(robot),
        y: 0,
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

/// One robot's update and its age (age_us = 1000 × robot + seq), as glint writes them.
fn update(robot: u8, seq: u8) -> Vec<u8> {
    let mut bytes = encoded(Message::RobotPosition(RobotPosition {
        robot,
        position: position(seq, robot),
    }));
    bytes.extend(encoded(Message::Age(PositionAge {
        seq,
        age_us: 1_000 * u32::from(robot) + u32::from(seq),
        predicted: false,
    })));
    bytes
}

fn led(robot: u8, request: u8) -> Vec<u8> {
    encoded(Message::Led(LedRequest {
        robot,
        request,
        at_us: 0,
        delay_us: 0,
        off_us: 40_000,
    }))
}

/// Three robots on one line, each with its own sequence numbers, in varying order per frame; the
/// robots' seq numbers coincide, so only the order tells whose age is whose.
fn shared_line() -> VecDeque<Vec<u8>> {
    let mut chunks = VecDeque::new();
    for seq in 5..9u8 {
        let order: [u8; 3] = if seq % 2 == 0 { [1, 2, 3] } else { [2, 3, 1] };
        for robot in order {
            chunks.push_back(update(robot, seq));
        }
    }
    chunks
}

#[test]
fn a_robot_takes_its_own_updates_and_ages_only() {
    let mut link = Link::new(ScriptedUart(shared_line()), || 0).for_robot(2);
    let mut rec = Recorder::default();
    while link.poll(&mut rec).expect("scripted") > 0 {}
    let xs: Vec<(u8, i16)> = rec.positions.iter().map(|p| (p.seq, p.x)).collect();
    assert_eq!(xs, [(5, 200), (6, 200), (7, 200), (8, 200)]);
    // Robot 1's age (same seq) comes right after robot 2's in odd frames; only robot 2's own
    // ages are taken.
    let ages: Vec<u32> = rec.ages.iter().map(|a| a.age_us).collect();
    assert_eq!(ages, [2_005, 2_006, 2_007, 2_008]);
    let stats = link.stats();
    assert_eq!((stats.positions, stats.ages, stats.others), (4, 4, 8));
    // The other robots' updates in between are not missed updates of this robot.
    assert_eq!(stats.missed, 0);
}

#[test]
fn a_link_not_told_its_id_takes_no_addressed_update_but_plain_ones() {
    let mut chunks = shared_line();
    chunks.push_back(encoded(Message::Position(position(9, 7))));
    let mut link = Link::new(ScriptedUart(chunks), || 0);
    let mut rec = Recorder::default();
    while link.poll(&mut rec).expect("scripted") > 0 {}
    assert_eq!(rec.positions, [position(9, 7)]);
    assert!(rec.ages.is_empty());
    assert_eq!(link.stats().others, 12);
}

#[test]
fn the_led_answers_only_its_robots_requests_on_a_shared_line() {
    let mut chunks = shared_line();
    chunks.push_back(led(1, 0));
    chunks.push_back(led(3, 1));
    let mut link = Link::new(ScriptedUart(chunks.clone()), || 1_000).for_robot(2);
    let mut robot = WithLed::new(Recorder::default(), DemoLed::default(), 2);
    while link.poll(&mut robot).expect("scripted") > 0 {}
    assert!(robot.led_on());
    assert_eq!(robot.answered, 0);

    chunks.push_back(led(2, 2));
    let mut link = Link::new(ScriptedUart(chunks), || 1_000).for_robot(2);
    let mut robot = WithLed::new(Recorder::default(), DemoLed::default(), 2);
    while link.poll(&mut robot).expect("scripted") > 0 {}
    assert!(!robot.led_on());
    assert_eq!(robot.answered, 1);
    robot.tick(41_000);
    assert!(robot.led_on());
    assert_eq!(robot.control.positions.len(), 4);
}
