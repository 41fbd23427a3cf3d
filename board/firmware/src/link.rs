//! The receiving end of the serial link: UART bytes in, decoded messages out to a control loop.
//!
//! The link reads the robot's clock as each chunk arrives, so a position's age (protocol
//! version 2) reaches the control loop in the robot's own clock.
//!
//! On a line shared by several robots (protocol version 3, a radio bridge say), glint addresses
//! each update to one robot; a link told its robot id ([`Link::for_robot`]) hands on only its own,
//! and only the age frame right after its own update.

use embedded_io::Read;
use glint_protocol::{Decoder, Message, Position, Received};

use crate::clock::Clock;
use crate::control::{ArrivedAge, ControlLoop};

/// Bytes read from the UART per call. Small: a frame is at most 24 bytes for positions, and a
/// small read keeps the latency between a byte arriving and its position being used low.
const READ_CHUNK_LEN: usize = 32;

/// What the link has seen since start-up, for a status LED or a debug console.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct LinkStats {
    /// Position updates handed to the control loop.
    pub positions: u32,
    /// Heartbeats received.
    pub heartbeats: u32,
    /// Ages handed to the control loop (each for the position just before it).
    pub ages: u32,
    /// LED requests handed to the control loop.
    pub led_requests: u32,
    /// Frames with a message id this firmware does not know (from a newer glint), skipped.
    pub unknown: u32,
    /// Frames dropped as corrupt (CRC, COBS, overflow, malformed).
    pub dropped: u32,
    /// Position updates that never arrived, from gaps in the sequence numbers.
    pub missed: u32,
    /// Position updates addressed to other robots on a shared line, skipped.
    pub others: u32,
}

/// A UART carrying glint's frames, with its decoder, the robot's clock and counters.
pub struct Link<R: Read, K: Clock> {
    uart: R,
    clock: K,
    decoder: Decoder,
    chunk: [u8; READ_CHUNK_LEN],
    /// The robot id that addressed updates must carry to be this robot's; `None` takes none of
    /// them (a link on a line of its own, or not told its id).
    robot_id: Option<u8>,
    own: OwnUpdates,
}

/// What the link knows of this robot's own updates (apart from the decoder, which is borrowed
/// while they are handed on).
#[derive(Debug, Default)]
struct OwnUpdates {
    last_seq: Option<u8>,
    /// This robot's update came last: no other robot's update (nor a corrupted frame, which may
    /// have been one) came since, so an age frame with its seq is its age.
    age_expected: bool,
    stats: LinkStats,
}

impl<R: Read, K: Clock> Link<R, K> {
    /// Wraps a UART (anything implementing `embedded_io::Read`) and the robot's µs clock.
    pub fn new(uart: R, clock: K) -> Self {
        Link {
            uart,
            clock,
            decoder: Decoder::new(),
            chunk: [0; READ_CHUNK_LEN],
            robot_id: None,
            own: OwnUpdates::default(),
        }
    }

    /// The same link for robot `robot_id` (1..=255) on a line that may be shared: it also takes
    /// the position updates glint addresses to this robot, and skips the others'. Plain position
    /// updates (a line of its own) are taken either way.
    pub fn for_robot(mut self, robot_id: u8) -> Self {
        self.robot_id = Some(robot_id);
        self
    }

    /// Counters since start-up.
    pub fn stats(&self) -> LinkStats {
        self.own.stats
    }

    /// Reads what the UART has (blocking until at least one byte, as `embedded_io::Read` does),
    /// decodes it and calls the control loop for each complete message. Returns the number of
    /// bytes read; 0 means the UART reported end of input.
    ///
    /// A UART error (overrun, framing) also drops the partial frame: the bytes around it are
    /// suspect, and the next delimiter would only find a CRC error later.
    pub fn poll<C: ControlLoop>(&mut self, control: &mut C) -> Result<usize, R::Error> {
        let read = match self.uart.read(&mut self.chunk) {
            Ok(n) => n,
            Err(e) => {
                self.decoder.reset();
                return Err(e);
            }
        };
        // The chunk's bytes arrived by now: the receive latency the robot adds to glint's age
        // is what passed since (the read returns as soon as a byte is there).
        let received_at_us = self.clock.now_us();
        let bytes = self.chunk.get(..read).unwrap_or(&[]);
        for event in self.decoder.feed(bytes) {
            let own = &mut self.own;
            match event {
                Ok(Received::Message(Message::Position(p))) => own.take_position(&p, control),
                Ok(Received::Message(Message::RobotPosition(r))) => {
                    if Some(r.robot) == self.robot_id {
                        own.take_position(&r.position, control);
                    } else {
                        // The age that follows is that robot's.
                        own.age_expected = false;
                        own.stats.others += 1;
                    }
                }
                Ok(Received::Message(Message::Heartbeat(h))) => {
                    own.stats.heartbeats += 1;
                    control.on_heartbeat(&h);
                }
                Ok(Received::Message(Message::Age(a))) => {
                    // An age whose position was lost belongs to nothing this robot holds; on a
                    // shared line one that does not follow this robot's update is another's.
                    if own.age_expected && own.last_seq == Some(a.seq) {
                        own.stats.ages += 1;
                        control.on_age(&ArrivedAge {
                            seq: a.seq,
                            age_us: a.age_us,
                            received_at_us,
                            predicted: a.predicted,
                        });
                    }
                }
                Ok(Received::Message(Message::Led(r))) => {
                    own.stats.led_requests += 1;
                    control.on_led(&r, received_at_us);
                }
                Ok(Received::Unknown { .. }) => own.stats.unknown += 1,
                Err(e) => {
                    // It may have been another robot's update.
                    own.age_expected = false;
                    own.stats.dropped += 1;
                    control.on_link_error(e);
                }
            }
        }
        Ok(read)
    }
}

impl OwnUpdates {
    /// Counts a position update of this robot, notes that its age may follow, and hands it on.
    fn take_position<C: ControlLoop>(&mut self, p: &Position, control: &mut C) {
        if let Some(last) = self.last_seq {
            // seq wraps at 256, so the gap is taken modulo 256 too.
            self.stats.missed += u32::from(p.seq.wrapping_sub(last).wrapping_sub(1));
        }
        self.last_seq = Some(p.seq);
        self.age_expected = true;
        self.stats.positions += 1;
        control.on_position(p);
    }
}
