//! The serial link to the robot: a position update per frame and a heartbeat about once a
//! second, in the `glint-protocol` wire format (`board/protocol/SPEC.md`), over a UART.
//!
//! The capture thread only encodes (into a stack buffer) and posts into a one-slot
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

mod link;
mod mailbox;
mod updates;

use core::fmt;
use std::io;
use std::sync::atomic::Ordering;
use std::sync::Arc;
use std::thread::JoinHandle;

use glint_protocol::{encode, Message};

pub use link::{
    line_time, BITS_PER_BYTE, DRAIN_LIMIT, REOPEN_BACKOFF_MAX, REOPEN_BACKOFF_MIN, WRITE_TIMEOUT,
};
pub use updates::{Located, Updates, HEARTBEAT_INTERVAL_US};
// The MAVLink sink (`super::mavlink`) opens its port the same way.
pub use link::open_port;

use super::Sink;
use crate::pipeline::FrameReport;
use crate::source::FrameMeta;
use link::{Counters, Link};
use mailbox::{Kind, Mailbox, SLOT_BYTES};

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

impl std::error::Error for SerialError {
    fn source(&self) -> Option<&(dyn std::error::Error + 'static)> {
        match self {
            SerialError::Open { source, .. } => Some(source),
            SerialError::Thread(e) => Some(e),
        }
    }
}

/// What the link did over a run. Once the sink has finished, every frame posted (`updates` +
/// `heartbeats`) is counted in exactly one of `sent`, `superseded`, `timed_out` and
/// `port_down`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct SerialStats {
    /// Position updates posted (one per frame).
    pub updates: u64,
    /// Heartbeats posted.
    pub heartbeats: u64,
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
            "updates={} heartbeats={} sent={} dropped={} stale={} timed_out={} port_down={} \
             losses={} reopens={}",
            self.updates,
            self.heartbeats,
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
            clamp_warned: false,
        })
    }

    /// Posts the frame's position update (found with `located`, lost without) and, when due,
    /// a heartbeat. Returns at once: the writer thread sends them.
    pub fn send(&mut self, meta: &FrameMeta, located: Option<&Located>) {
        let quantised = self.updates.position(meta, located);
        if quantised.clamped.any() && !self.clamp_warned {
            self.clamp_warned = true;
            log::warn!(
                "frame {}: position or velocity beyond the wire's 16-bit range, saturated \
                 (warned once)",
                meta.index
            );
        }
        if let Some(heartbeat) = self.updates.heartbeat(meta) {
            self.posted_heartbeats += 1;
            self.post(Kind::Heartbeat, &Message::Heartbeat(heartbeat));
        }
        self.posted_updates += 1;
        self.post(Kind::Position, &Message::Position(quantised.position));
    }

    /// Counts so far; final once [`Sink::finish`] has returned.
    pub fn stats(&self) -> SerialStats {
        let c = &self.counters;
        SerialStats {
            updates: self.posted_updates,
            heartbeats: self.posted_heartbeats,
            sent: c.sent.load(Ordering::Relaxed),
            superseded: self.mailbox.superseded(),
            timed_out: c.timed_out.load(Ordering::Relaxed),
            port_down: c.port_down.load(Ordering::Relaxed),
            losses: c.losses.load(Ordering::Relaxed),
            reopens: c.reopens.load(Ordering::Relaxed),
        }
    }

    fn post(&self, kind: Kind, message: &Message) {
        let mut frame = [0u8; SLOT_BYTES];
        match encode(message, &mut frame) {
            Ok(bytes) => {
                self.mailbox.post(kind, bytes);
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

impl Sink for SerialSink {
    /// Never fails: link faults are handled (and counted) by the writer thread.
    fn write(&mut self, report: &FrameReport) -> io::Result<()> {
        let located = report
            .position
            .as_ref()
            .map(|e| Located::from_estimate(e, report.floor.as_ref()));
        self.send(&report.meta, located.as_ref());
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
        let state = if stats.losses > stats.reopens {
            "down"
        } else {
            "up"
        };
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
