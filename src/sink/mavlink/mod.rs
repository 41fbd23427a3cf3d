//! MAVLink out (`--mavlink`): the robot's floor position to an autopilot (ArduPilot, PX4) over
//! the serial port, as `VISION_POSITION_ESTIMATE` per frame with a floor position, plus
//! `VISION_SPEED_ESTIMATE` when the velocity is known, and a `HEARTBEAT` every second.
//! Messages are MAVLink 2, framed by the `mavlink` crate (common dialect).
//!
//! The axis convention and the covariance are in [`estimate`]. As in the serial sink, the
//! capture thread only builds the messages on the stack and posts them into a one-slot-per-kind
//! mailbox; a writer thread ([`writer`]) numbers, frames and writes them, so a slow or vanished
//! port never delays tracking.
//!
//! # Memory
//!
//! The mailbox, the writer's buffer and the thread are set up in [`MavlinkLink::open`]; per
//! frame the sink allocates nothing.

pub mod estimate;
pub mod writer;

use core::fmt;
use std::io;
use std::sync::atomic::Ordering;
use std::sync::Arc;
use std::thread::JoinHandle;

use mavlink::dialects::common::{VISION_POSITION_ESTIMATE_DATA, VISION_SPEED_ESTIMATE_DATA};

use super::serial::{open_port, SerialError};
use super::Sink;
use crate::report::FloorFix;
use crate::report::FrameReport;
pub use estimate::{Axes, ToLocal};
use writer::{Counters, Mailbox, Writer};
pub use writer::{Identity, HEARTBEAT_INTERVAL};

/// System id when none is given: ArduPilot's and PX4's default for the vehicle.
pub const DEFAULT_SYSTEM_ID: u8 = 1;

/// `MAV_COMP_ID_VISUAL_INERTIAL_ODOMETRY`: the component id MAVLink reserves for a vision
/// position source.
pub const VISION_COMPONENT_ID: u8 = 197;

/// What the MAVLink link did over a run. Once finished, every message posted or due
/// (`positions + speeds` and the heartbeats) is sent, superseded, timed out or dropped.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct MavlinkStats {
    /// `VISION_POSITION_ESTIMATE`s posted (frames with a floor position).
    pub positions: u64,
    /// `VISION_SPEED_ESTIMATE`s posted.
    pub speeds: u64,
    /// Heartbeats sent.
    pub heartbeats: u64,
    /// Messages handed to the kernel, heartbeats included.
    pub sent: u64,
    /// Messages replaced by a newer one before the writer took them.
    pub superseded: u64,
    /// Messages given up because a write timed out.
    pub timed_out: u64,
    /// Messages dropped while the port was gone.
    pub port_down: u64,
    /// Times the port vanished.
    pub losses: u64,
    /// Times it was reopened.
    pub reopens: u64,
}

/// One line of `key=value` pairs, for the log and for scripts that read it.
impl fmt::Display for MavlinkStats {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "positions={} speeds={} heartbeats={} sent={} stale={} timed_out={} port_down={} \
             losses={} reopens={}",
            self.positions,
            self.speeds,
            self.heartbeats,
            self.sent,
            self.superseded,
            self.timed_out,
            self.port_down,
            self.losses,
            self.reopens
        )
    }
}

/// The link to an autopilot: the port, its writer thread and the mailbox. Its caller builds
/// the messages ([`MavlinkSink`] from a frame's report, `glint fuse` from a fused track) and
/// posts them; posting never blocks.
pub struct MavlinkLink {
    path: String,
    mailbox: Arc<Mailbox>,
    counters: Arc<Counters>,
    writer: Option<JoinHandle<()>>,
    positions: u64,
    speeds: u64,
}

impl MavlinkLink {
    /// Opens `path` at `baud` (8N1, no flow control) and starts the writer thread, which sends
    /// the first heartbeat at once.
    pub fn open(path: &str, baud: u32, identity: Identity) -> Result<MavlinkLink, SerialError> {
        let port = open_port(path, baud).map_err(|source| SerialError::Open {
            path: path.to_owned(),
            source,
        })?;
        let mailbox = Arc::new(Mailbox::default());
        let counters = Arc::new(Counters::default());
        let writer = Writer::new(path, baud, port, identity, Arc::clone(&counters));
        let writer = {
            let mailbox = Arc::clone(&mailbox);
            std::thread::Builder::new()
                .name("glint-mavlink".into())
                .spawn(move || writer.run(&mailbox))
                .map_err(SerialError::Thread)?
        };
        Ok(MavlinkLink {
            path: path.to_owned(),
            mailbox,
            counters,
            writer: Some(writer),
            positions: 0,
            speeds: 0,
        })
    }

    /// Posts a position (and a speed, when known) for the writer; a newer post replaces one
    /// not yet written. Returns at once.
    pub fn post(
        &mut self,
        position: VISION_POSITION_ESTIMATE_DATA,
        speed: Option<VISION_SPEED_ESTIMATE_DATA>,
    ) {
        self.positions += 1;
        self.speeds += u64::from(speed.is_some());
        self.mailbox.post(position, speed);
    }

    /// Counts so far; final once [`MavlinkLink::finish`] has returned.
    pub fn stats(&self) -> MavlinkStats {
        let c = &self.counters;
        MavlinkStats {
            positions: self.positions,
            speeds: self.speeds,
            heartbeats: c.heartbeats.load(Ordering::Relaxed),
            sent: c.sent.load(Ordering::Relaxed),
            superseded: self.mailbox.superseded(),
            timed_out: c.timed_out.load(Ordering::Relaxed),
            port_down: c.port_down.load(Ordering::Relaxed),
            losses: c.losses.load(Ordering::Relaxed),
            reopens: c.reopens.load(Ordering::Relaxed),
        }
    }

    /// Lets the writer send what is pending, stops it and logs the counts.
    pub fn finish(&mut self) {
        self.close();
        log::info!("mavlink port {}: {}", self.path, self.stats());
    }

    /// `, mavlink up|down (sent N, stale M, reopened K)`.
    pub fn status(&self, out: &mut fmt::Formatter<'_>) -> fmt::Result {
        let stats = self.stats();
        let state = crate::sink::serial::link_state(stats.losses, stats.reopens);
        write!(
            out,
            ", mavlink {state} (sent {}, stale {}, reopened {})",
            stats.sent, stats.superseded, stats.reopens
        )
    }

    fn close(&mut self) {
        self.mailbox.close();
        if let Some(writer) = self.writer.take() {
            if writer.join().is_err() {
                log::error!("mavlink port {}: the writer thread panicked", self.path);
            }
        }
    }
}

impl Drop for MavlinkLink {
    fn drop(&mut self) {
        self.close();
    }
}

/// Sends one camera's vision position estimates to an autopilot without ever blocking the
/// caller.
pub struct MavlinkSink {
    link: MavlinkLink,
    local: ToLocal,
}

impl MavlinkSink {
    /// Opens the link (see [`MavlinkLink::open`]); positions are turned to the autopilot's
    /// frame by `local`.
    pub fn open(
        path: &str,
        baud: u32,
        identity: Identity,
        local: ToLocal,
    ) -> Result<MavlinkSink, SerialError> {
        Ok(MavlinkSink {
            link: MavlinkLink::open(path, baud, identity)?,
            local,
        })
    }

    /// Counts so far; final once [`Sink::finish`] has returned.
    pub fn stats(&self) -> MavlinkStats {
        self.link.stats()
    }
}

impl Sink for MavlinkSink {
    /// Posts the frame's messages when it has a floor position; a frame without one (lost, or
    /// beyond the horizon) sends nothing, as the autopilot only takes positions. Never fails.
    fn write(&mut self, report: &FrameReport) -> io::Result<()> {
        let (Some(estimate), Some(FloorFix::Mapped(floor))) = (&report.position, &report.floor)
        else {
            return Ok(());
        };
        let usec = report.meta.timestamp_us;
        let position = self.local.position(usec, estimate.position_px, floor);
        let speed = self.local.speed(usec, floor);
        self.link.post(position, speed);
        Ok(())
    }

    fn finish(&mut self) -> io::Result<()> {
        self.link.finish();
        Ok(())
    }

    /// `, mavlink up|down (sent N, stale M, reopened K)`.
    fn status(&self, out: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.link.status(out)
    }
}
