//! The firmware's link logic on the host: UART bytes in, control-loop calls out.

use std::collections::VecDeque;

use embedded_io::{ErrorKind, ErrorType, Read};
use glint_firmware::demo::{Replay, DEMO_STREAM};
use glint_firmware::{ControlLoop, HoldPosition, Link, LinkStats};
use glint_protocol::{encode, DecodeError, Heartbeat, Message, Position, Status, Units};

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

fn frame(p: Position) -> Vec<u8> {
    let mut out = [0u8; 64];
    encode(&Message::Position(p), &mut out)
        .expect("fits")
        .to_vec()
}

#[test]
fn demo_stream_steers_the_stub_toward_home() {
    let mut link = Link::new(Replay::new(DEMO_STREAM));
    let mut control = HoldPosition::new((1000, 500));
    let mut read = 0;
    while read < DEMO_STREAM.len() {
        read += link.poll(&mut control).expect("replay cannot fail");
    }
    let p = control.last.expect("a position arrived");
    assert_eq!((p.x, p.y), (1520, -310));
    // (1000 − 1520) / 8 and (500 + 310) / 8, rounded toward −∞ by the shift.
    assert_eq!(control.command_mm_per_s, (-65, 101));
    assert_eq!(
        link.stats(),
        LinkStats {
            positions: 1,
            heartbeats: 1,
            ..LinkStats::default()
        }
    );
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
    let mut link = Link::new(ScriptedUart(chunks));
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
    let mut link = Link::new(ScriptedUart(script));
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
