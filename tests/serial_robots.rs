//! Several robots on one serial line, over a real pseudo-terminal: each frame carries one robot
//! position (protocol version 3) per robot, each followed at once by its age, each robot
//! numbered in its own sequence, and a robot without a position is sent as lost under its own
//! id only.

use std::io::Read;
use std::sync::mpsc;
use std::time::Duration;

use glint::report::TrackState;
use glint::sink::serial::Located;
use glint::sink::SerialSink;
use glint::source::clock::monotonic_now_us;
use glint::source::FrameMeta;
use glint_protocol::{Decoder, Message, Received, RobotPosition, Status, Units};
use serialport::SerialPort;

/// Longest wait for a frame's updates; only reached when something is broken.
const PATIENCE: Duration = Duration::from_secs(30);

const FRAME_US: u64 = 33_333;

fn located(x_mm: f32) -> Located {
    Located {
        units: Units::Floor,
        position: (x_mm, 250.0),
        velocity_per_s: Some((100.0, 0.0)),
        velocity_method: None,
        quality: 170,
    }
}

#[test]
fn a_shared_line_carries_each_robots_update_and_age_in_its_own_sequence() {
    let (mut master, slave) = serialport::TTYPort::pair().expect("pty pair");
    master
        .set_timeout(Duration::from_millis(50))
        .expect("timeout");
    let name = slave.name().expect("slave name");
    let (tx, rx) = mpsc::channel();
    let reader = std::thread::spawn(move || {
        let mut decoder = Decoder::new();
        let mut buf = [0u8; 512];
        loop {
            let n = match master.read(&mut buf) {
                Ok(0) => return,
                Ok(n) => n,
                Err(e) if e.kind() == std::io::ErrorKind::TimedOut => continue,
                Err(_) => return,
            };
            for event in decoder.feed(&buf[..n]) {
                if tx.send(event).is_err() {
                    return;
                }
            }
        }
    });

    let mut sink = SerialSink::open(&name, 115_200).expect("open the pty");
    let mut seen = Vec::new();
    const FRAMES: u64 = 12;
    for frame in 0..FRAMES {
        let meta = FrameMeta {
            index: frame,
            sequence: frame,
            dropped: 0,
            timestamp_us: frame * FRAME_US,
            monotonic_us: monotonic_now_us(),
        };
        // Robot 2 is not located in odd frames (its track is not bound, say).
        let robot_2 = (frame % 2 == 0).then(|| located(2000.0));
        sink.send_robots(
            &meta,
            &[
                (3, Some(located(3000.0))),
                (2, robot_2),
                (1, Some(located(1000.0))),
            ],
            TrackState::Tracking,
        );
        // Wait for this frame's three updates and ages before the next, so none is stale.
        let mut ages = 0;
        while ages < 3 {
            let event = rx
                .recv_timeout(PATIENCE)
                .expect("the frame's updates arrive");
            let message = match event {
                Ok(Received::Message(m)) => m,
                other => panic!("frame {frame}: {other:?}"),
            };
            if matches!(message, Message::Age(_)) {
                ages += 1;
            }
            if !matches!(message, Message::Heartbeat(_)) {
                seen.push((frame, message));
            }
        }
    }
    assert_eq!(sink.stats().updates, 3 * FRAMES);
    drop(sink);
    drop(slave);
    let _ = reader.join();

    // Per frame: robot 3, its age, robot 2, its age, robot 1, its age, in the order given.
    assert_eq!(seen.len() as u64, 6 * FRAMES);
    for chunk in seen.chunks(6) {
        let frame = chunk[0].0;
        for (pair, robot) in chunk.chunks(2).zip([3u8, 2, 1]) {
            let (
                Message::RobotPosition(RobotPosition {
                    robot: r,
                    position: p,
                }),
                Message::Age(a),
            ) = (pair[0].1, pair[1].1)
            else {
                panic!("frame {frame}: not a robot position and its age: {pair:?}");
            };
            assert_eq!(r, robot, "frame {frame}");
            // Each robot's own sequence: +1 per frame, whatever the others got.
            assert_eq!(p.seq, frame as u8, "robot {robot} in frame {frame}");
            assert_eq!(a.seq, p.seq, "the age follows its update");
            assert_eq!(p.timestamp_us, (frame * FRAME_US) as u32);
            let lost = robot == 2 && frame % 2 == 1;
            if lost {
                assert_eq!(p.status, Status::Lost, "frame {frame}");
                // The robot's own last position repeated, never another robot's.
                assert_eq!((p.x, p.y), (2000, 250));
            } else {
                assert_eq!(p.status, Status::Found, "robot {robot} frame {frame}");
                assert_eq!((p.x, p.y), (1000 * i16::from(robot), 250));
            }
        }
    }
}
