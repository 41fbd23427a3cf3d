//! The serial link to the robot: a position update per frame and a heartbeat about once a
//! second, in the `glint-protocol` wire format (`board/protocol/SPEC.md`), over a UART.
//!
//! Every update is followed by its age on arrival (protocol version 2): how old the position is
//! when the last byte leaves the host, stamped by the writer as it writes (`stamp`). On request
//! ([`SerialSink::request_led`]) a LED request goes out too. On a line shared by several robots
//! ([`SerialSink::send_robots`]), each frame carries one robot position (protocol version 3) per
//! robot, each numbered in that robot's own sequence, in one write.
//!
//! The capture thread only builds messages (on the stack) and posts them into a one-slot-per-kind
//! `mailbox`; a writer thread owns the port and does the blocking I/O. A slow line therefore
//! never slows tracking: the newest position replaces a stale one still waiting, and the count
//! of replaced, timed-out and port-down frames is reported in [`SerialStats`]. A port that
//! vanishes (a USB adapter unplugged) is logged once and reopened with back-off while tracking
//! goes on; see the `link` module.
//!
//! # Memory
//!
//! The mailbox, the writer's buffer and the thread are set up in [`SerialSink::open`]. Per frame
//! the sink allocates nothing: messages are built on the stack and copied into fixed slots.

mod lines;
mod link;
mod mailbox;
mod stamp;
mod updates;

use core::fmt;
use std::io;
use std::sync::atomic::Ordering;
use std::sync::Arc;
use std::thread::JoinHandle;

use glint_protocol::{encode, LedRequest, Message};

pub use lines::RobotLines;
pub use link::{
    line_time, BITS_PER_BYTE, DRAIN_LIMIT, REOPEN_BACKOFF_MAX, REOPEN_BACKOFF_MIN, WRITE_TIMEOUT,
};
pub use stamp::SentLed;
pub use updates::{Located, Updates, HEARTBEAT_INTERVAL_US};
// The MAVLink sink (`super::mavlink`) opens and writes its port the same way.
pub use link::open_port;
pub(crate) use link::write_all;

use super::Sink;
use crate::report::{FrameMeta, FrameReport, TrackReport, TrackState, MAX_ROBOTS};
use crate::source::clock::monotonic_now_us;
use heapless::Vec as BoundedVec;
use link::{Counters, Link};
use mailbox::{Mailbox, Post, RobotUpdates, SLOT_BYTES};
use stamp::{PendingLed, PendingUpdate, Prediction};

use super::predict::Predictor;

/// The line rate when none is given: fast enough for a 24-byte update per frame at 240 fps,
/// and supported by every USB-serial adapter and microcontroller UART.
pub const DEFAULT_BAUD: u32 = 115_200;

/// Why the serial sink could not start.
#[derive(Debug)]
pub enum SerialError {
    /// The port could not be opened (no such device, no permission, in use).
    Open {
        /// The port's path.
        path: String,
        /// What the OS said.
        source: serialport::Error,
    },
    /// The writer thread could not be started.
    Thread(io::Error),
}

impl fmt::Display for SerialError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SerialError::Open { path, source } => {
                write!(f, "cannot open serial port {path}: {source}")
            }
            SerialError::Thread(e) => write!(f, "cannot start the serial writer thread: {e}"),
        }
    }
}

// The messages include the OS's text, so it is not also given as a source: an error chain
// printed whole (`{:#}`) would say it twice ("Not a typewriter: Not a typewriter").
impl std::error::Error for SerialError {}

/// What the link did over a run. Once the sink has finished, every message posted (`updates` +
/// `heartbeats` + `led_requests`; an update and its age count as one) is counted in exactly one
/// of `sent`, `superseded`, `timed_out` and `port_down`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct SerialStats {
    /// Position updates posted (one per frame).
    pub updates: u64,
    /// Heartbeats posted.
    pub heartbeats: u64,
    /// LED requests posted.
    pub led_requests: u64,
    /// Frames (updates and heartbeats) handed to the kernel.
    pub sent: u64,
    /// Frames replaced by a newer one before the writer took them: the line was slower than
    /// the frame rate.
    pub superseded: u64,
    /// Frames given up because a write timed out (the receiver stopped reading).
    pub timed_out: u64,
    /// Frames dropped while the port was gone.
    pub port_down: u64,
    /// Times the port vanished.
    pub losses: u64,
    /// Times it was reopened.
    pub reopens: u64,
}

impl SerialStats {
    /// Frames not sent, for whatever reason.
    pub fn dropped(&self) -> u64 {
        self.superseded + self.timed_out + self.port_down
    }
}

/// One line of `key=value` pairs, for the log and for scripts that read it.
impl fmt::Display for SerialStats {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "updates={} heartbeats={} led_requests={} sent={} dropped={} stale={} timed_out={} \
             port_down={} losses={} reopens={}",
            self.updates,
            self.heartbeats,
            self.led_requests,
            self.sent,
            self.dropped(),
            self.superseded,
            self.timed_out,
            self.port_down,
            self.losses,
            self.reopens
        )
    }
}

/// Sends position updates and heartbeats to a serial port without ever blocking the caller.
pub struct SerialSink {
    path: String,
    updates: Updates,
    mailbox: Arc<Mailbox>,
    counters: Arc<Counters>,
    writer: Option<JoinHandle<()>>,
    posted_updates: u64,
    posted_heartbeats: u64,
    posted_led_requests: u64,
    /// Number of the next LED request.
    next_led_request: u8,
    /// The frame clock's origin on the monotonic clock, from the latest frame.
    frame_clock_origin_us: Option<i64>,
    /// With `--predict arrival`: the motion each update is moved on by, at write time.
    predictor: Option<Predictor>,
    /// Per robot on a shared line (index: id − 1): its sequence numbers and last position.
    robots: [Updates; MAX_ROBOTS],
    clamp_warned: bool,
}

impl SerialSink {
    /// Opens `path` at `baud` (8N1, no flow control), sends the opening 0x00, and starts the
    /// writer thread. Failing to open the port at start is an error (a wrong path should be
    /// said at once); losing it later is not.
    pub fn open(path: &str, baud: u32) -> Result<SerialSink, SerialError> {
        let port = link::open_port(path, baud).map_err(|source| SerialError::Open {
            path: path.to_owned(),
            source,
        })?;
        let mailbox = Arc::new(Mailbox::new());
        let counters = Arc::new(Counters::default());
        let link = Link::new(path, baud, port, Arc::clone(&counters));
        let writer = {
            let mailbox = Arc::clone(&mailbox);
            std::thread::Builder::new()
                .name("glint-serial".into())
                .spawn(move || link.run(&mailbox))
                .map_err(SerialError::Thread)?
        };
        Ok(SerialSink {
            path: path.to_owned(),
            updates: Updates::new(),
            mailbox,
            counters,
            writer: Some(writer),
            posted_updates: 0,
            posted_heartbeats: 0,
            posted_led_requests: 0,
            next_led_request: 0,
            frame_clock_origin_us: None,
            predictor: None,
            robots: core::array::from_fn(|_| Updates::new()),
            clamp_warned: false,
        })
    }

    /// Sends every found position extrapolated to its arrival (`--predict arrival`): moved on
    /// by the age it is sent with, flagged as predicted in its age frame.
    pub fn predicting(mut self) -> Self {
        self.predictor = Some(Predictor::new());
        self
    }

    /// Posts the frame's position update (found with `located`, lost without) and, when due,
    /// a heartbeat carrying the tracker's `state`. Returns at once: the writer thread sends
    /// them.
    pub fn send(&mut self, meta: &FrameMeta, located: Option<&Located>, state: TrackState) {
        let quantised = self.updates.position(meta, located);
        if quantised.clamped.any() && !self.clamp_warned {
            self.clamp_warned = true;
            log::warn!(
                "frame {}: position or velocity beyond the wire's 16-bit range, saturated \
                 (warned once)",
                meta.index
            );
        }
        if let Some(heartbeat) = self.updates.heartbeat(meta, state) {
            self.posted_heartbeats += 1;
            self.post_heartbeat(&Message::Heartbeat(heartbeat));
        }
        self.frame_clock_origin_us = Some(frame_clock_origin_us(meta));
        self.posted_updates += 1;
        let prediction = self.predictor.as_mut().and_then(|predictor| {
            // A lost frame observes no velocity, which ends the bend being measured.
            let velocity = located.and_then(|l| l.velocity_per_s.zip(l.velocity_method));
            let units = quantised.position.units;
            let motion = predictor.observe(meta.timestamp_us, units, velocity)?;
            Some(Prediction {
                from: located?.position,
                motion,
            })
        });
        self.mailbox.post(Post::Update(PendingUpdate {
            measured: quantised.position,
            prediction,
            captured_monotonic_us: meta.monotonic_us,
            robot: None,
        }));
    }

    /// Posts one frame's updates for several robots on this shared line: for each `(robot,
    /// located)`, robot `robot` (1..=[`MAX_ROBOTS`]) found at `located`, or lost without (the
    /// robot's last position repeated, as for one robot). Each robot's updates carry its own
    /// sequence numbers. Robots out of range are skipped; `--predict arrival` applies to one
    /// robot's line only. A heartbeat (with `state`, the line's tracker state) goes out when
    /// due, as with [`SerialSink::send`].
    pub fn send_robots(
        &mut self,
        meta: &FrameMeta,
        robots: &[(u8, Option<Located>)],
        state: TrackState,
    ) {
        if let Some(heartbeat) = self.updates.heartbeat(meta, state) {
            self.posted_heartbeats += 1;
            self.post_heartbeat(&Message::Heartbeat(heartbeat));
        }
        self.frame_clock_origin_us = Some(frame_clock_origin_us(meta));
        let mut posted = RobotUpdates::new();
        for (robot, located) in robots {
            let Some(updates) = usize::from(*robot)
                .checked_sub(1)
                .and_then(|i| self.robots.get_mut(i))
            else {
                continue;
            };
            let quantised = updates.position(meta, located.as_ref());
            let pending = PendingUpdate {
                measured: quantised.position,
                prediction: None,
                captured_monotonic_us: meta.monotonic_us,
                robot: Some(*robot),
            };
            if posted.push(pending).is_err() {
                break;
            }
        }
        self.posted_updates += posted.len() as u64;
        if !posted.is_empty() {
            self.mailbox.post(Post::Robots(&posted));
        }
    }

    /// Asks robot `robot` (0: every robot) to switch its LED off for `off_us`, `delay_us` after
    /// the request's last byte leaves; returns the request's number. The writer sends it with
    /// the next batch and records when ([`SerialSink::last_led_sent`]).
    pub fn request_led(&mut self, robot: u8, delay_us: u32, off_us: u32) -> u8 {
        let request = self.next_led_request;
        self.next_led_request = request.wrapping_add(1);
        self.posted_led_requests += 1;
        let frame_clock_origin_us = self
            .frame_clock_origin_us
            .unwrap_or_else(|| i64::try_from(monotonic_now_us()).unwrap_or(i64::MAX));
        self.mailbox.post(Post::Led(PendingLed {
            request: LedRequest {
                robot,
                request,
                at_us: 0,
                delay_us,
                off_us,
            },
            frame_clock_origin_us,
        }));
        request
    }

    /// The last LED request the writer handed to the kernel, and the frame time its last byte
    /// left at.
    pub fn last_led_sent(&self) -> Option<SentLed> {
        self.counters.last_led()
    }

    /// Counts so far; final once [`Sink::finish`] has returned.
    pub fn stats(&self) -> SerialStats {
        let c = &self.counters;
        SerialStats {
            updates: self.posted_updates,
            heartbeats: self.posted_heartbeats,
            led_requests: self.posted_led_requests,
            sent: c.sent.load(Ordering::Relaxed),
            superseded: self.mailbox.superseded(),
            timed_out: c.timed_out.load(Ordering::Relaxed),
            port_down: c.port_down.load(Ordering::Relaxed),
            losses: c.losses.load(Ordering::Relaxed),
            reopens: c.reopens.load(Ordering::Relaxed),
        }
    }

    fn post_heartbeat(&self, message: &Message) {
        let mut frame = [0u8; SLOT_BYTES];
        match encode(message, &mut frame) {
            Ok(bytes) => {
                self.mailbox.post(Post::Heartbeat(bytes));
            }
            // Cannot happen: a slot holds the longest frame of the protocol.
            Err(e) => log::error!("serial: {e}"),
        }
    }

    /// Lets the writer send what is pending (bounded by its write timeout) and waits for it.
    fn close(&mut self) {
        self.mailbox.close();
        if let Some(writer) = self.writer.take() {
            if writer.join().is_err() {
                log::error!("serial port {}: the writer thread panicked", self.path);
            }
        }
    }
}

impl SerialSink {
    /// One frame on a line shared by several robots: robot k (1..=the number of tracks) gets
    /// the track bound to it by identification, found or lost; a provisional track goes out
    /// under no robot's id. The frame's LED request (identification's) goes in the same write.
    fn write_robots(&mut self, report: &FrameReport) {
        let mut robots: BoundedVec<(u8, Option<Located>), MAX_ROBOTS> = BoundedVec::new();
        let mut state = TrackState::Searching;
        for robot in (1..=MAX_ROBOTS).take(report.tracks.len()) {
            let id = u8::try_from(robot).unwrap_or(u8::MAX);
            let bound = bound_track(report, id);
            if let Some(t) = bound {
                state = busier(state, t.state);
            }
            let located = bound.and_then(|t| {
                t.estimate
                    .map(|e| Located::from_estimate(&e, t.floor.as_ref()))
            });
            // Cannot fail: at most MAX_ROBOTS robots.
            let _ = robots.push((id, located));
        }
        self.send_robots(&report.meta, &robots, state);
        // After the frame's updates, so that the request's host time counts from this frame.
        if let Some(blink) = report.blink {
            self.request_led(blink.robot, blink.delay_us, blink.off_us);
        }
    }
}

/// The track bound to robot `robot` by identification, if any: a provisional track is no
/// robot's.
pub(crate) fn bound_track(report: &FrameReport, robot: u8) -> Option<&TrackReport> {
    report
        .tracks
        .iter()
        .find(|t| !t.provisional && t.id == robot)
}

/// The state a line of several robots reports: tracking if any of its robots is, else
/// coasting if any is, else searching.
fn busier(a: TrackState, b: TrackState) -> TrackState {
    let rank = |s: TrackState| match s {
        TrackState::Searching => 0,
        TrackState::Coasting => 1,
        TrackState::Tracking => 2,
    };
    if rank(b) > rank(a) {
        b
    } else {
        a
    }
}

/// Where frame time 0 lies on the monotonic clock, by `meta`: exact for a camera (both are the
/// driver's timestamps), the latest frame's arrival for a file or a pipe.
fn frame_clock_origin_us(meta: &FrameMeta) -> i64 {
    let monotonic = i128::from(meta.monotonic_us) - i128::from(meta.timestamp_us);
    i64::try_from(monotonic).unwrap_or(i64::MAX)
}

/// `down` from a port's loss until its reopening, else `up`: the state the status line shows
/// for a port written by a reopening writer thread (this sink's, or the MAVLink sink's).
pub(crate) fn link_state(losses: u64, reopens: u64) -> &'static str {
    if losses > reopens {
        "down"
    } else {
        "up"
    }
}

impl Sink for SerialSink {
    /// Never fails: link faults are handled (and counted) by the writer thread. A report of
    /// several robots sends a robot position per robot, found only for the tracks bound to it
    /// by identification (see `write_robots`).
    fn write(&mut self, report: &FrameReport) -> io::Result<()> {
        if report.several() {
            self.write_robots(report);
            return Ok(());
        }
        let located = report
            .position
            .as_ref()
            .map(|e| Located::from_estimate(e, report.floor.as_ref()));
        self.send(&report.meta, located.as_ref(), report.single_state());
        Ok(())
    }

    fn finish(&mut self) -> io::Result<()> {
        self.close();
        log::info!("serial port {}: {}", self.path, self.stats());
        Ok(())
    }

    /// `, serial up|down (sent N, dropped M, reopened K)`: the port is down from a loss until
    /// its reopening.
    fn status(&self, out: &mut fmt::Formatter<'_>) -> fmt::Result {
        let stats = self.stats();
        let state = link_state(stats.losses, stats.reopens);
        write!(
            out,
            ", serial {state} (sent {}, dropped {}, reopened {})",
            stats.sent,
            stats.dropped(),
            stats.reopens
        )
    }
}

impl Drop for SerialSink {
    fn drop(&mut self) {
        self.close();
    }
}
