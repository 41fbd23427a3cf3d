//! The MAVLink writer thread: the serial sink's design (`super::super::serial`) with MAVLink
//! framing. The capture thread posts plain message structs into one slot per kind (newest wins,
//! a replaced one is counted); this thread numbers, frames and writes them, sends a `HEARTBEAT`
//! every [`HEARTBEAT_INTERVAL`] of wall-clock time whether or not frames come, and reopens a
//! port that vanished with doubling back-off.
//!
//! Sequence numbers are given here, as each message is framed, so they count the messages put
//! on the line: a gap at the receiver is a loss on the line, not a message replaced unsent.

use std::io;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Condvar, Mutex, MutexGuard, PoisonError};
use std::time::{Duration, Instant};

use mavlink::dialects::common::{
    MavAutopilot, MavMessage, MavModeFlag, MavState, MavType, HEARTBEAT_DATA,
    VISION_POSITION_ESTIMATE_DATA, VISION_SPEED_ESTIMATE_DATA,
};
use mavlink::MavHeader;
use serialport::TTYPort;

use crate::sink::serial::{open_port, write_all, REOPEN_BACKOFF_MAX, REOPEN_BACKOFF_MIN};

/// Wall-clock time between heartbeats: MAVLink components announce themselves at 1 Hz.
pub const HEARTBEAT_INTERVAL: Duration = Duration::from_secs(1);

/// Longest MAVLink 2 frame (unsigned): 10 header bytes, 255 payload bytes, 2 CRC bytes.
const MAX_FRAME_BYTES: usize = 10 + 255 + 2;

/// `mavlink_version` of a heartbeat: the protocol's, 3 since MAVLink 1.0.
const HEARTBEAT_MAVLINK_VERSION: u8 = 3;

/// Who glint is on the MAVLink network.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Identity {
    /// The vehicle's system id (ArduPilot's `SYSID_THISMAV`, 1 by default): a companion
    /// computer shares its vehicle's.
    pub system_id: u8,
    /// The component id (`MAV_COMP_ID_VISUAL_INERTIAL_ODOMETRY` by default).
    pub component_id: u8,
}

/// What the writer did, shared with the sink for its summary.
#[derive(Debug, Default)]
pub struct Counters {
    /// Messages handed to the kernel in full (heartbeats included).
    pub sent: AtomicU64,
    /// Heartbeats handed to the kernel.
    pub heartbeats: AtomicU64,
    /// Messages given up because a write timed out.
    pub timed_out: AtomicU64,
    /// Messages dropped while the port was gone.
    pub port_down: AtomicU64,
    /// Times the port vanished.
    pub losses: AtomicU64,
    /// Times it was reopened.
    pub reopens: AtomicU64,
}

#[derive(Debug, Default)]
struct Slots {
    position: Option<VISION_POSITION_ESTIMATE_DATA>,
    speed: Option<VISION_SPEED_ESTIMATE_DATA>,
    closing: bool,
}

/// The hand-over: one slot per message kind, newest wins.
#[derive(Debug, Default)]
pub struct Mailbox {
    slots: Mutex<Slots>,
    posted: Condvar,
    superseded: AtomicU64,
}

impl Mailbox {
    /// Replaces the pending position (and speed, when given) and wakes the writer. Copies a few
    /// hundred bytes under the lock; never waits for the line.
    pub fn post(
        &self,
        position: VISION_POSITION_ESTIMATE_DATA,
        speed: Option<VISION_SPEED_ESTIMATE_DATA>,
    ) {
        let mut slots = self.lock();
        let replaced = u64::from(slots.position.replace(position).is_some())
            + u64::from(speed.is_some() && slots.speed.is_some());
        if speed.is_some() {
            slots.speed = speed;
        }
        drop(slots);
        self.superseded.fetch_add(replaced, Ordering::Relaxed);
        self.posted.notify_one();
    }

    /// Tells the writer to send what is pending and stop.
    pub fn close(&self) {
        self.lock().closing = true;
        self.posted.notify_one();
    }

    /// Messages replaced by a newer one before the writer took them.
    pub fn superseded(&self) -> u64 {
        self.superseded.load(Ordering::Relaxed)
    }

    /// Waits at most `timeout` for something posted; takes it all. `closing` once closed.
    fn take(&self, timeout: Duration) -> (Slots, bool) {
        let slots = self.lock();
        let mut slots = self
            .posted
            .wait_timeout_while(slots, timeout, |s| {
                s.position.is_none() && s.speed.is_none() && !s.closing
            })
            .unwrap_or_else(PoisonError::into_inner)
            .0;
        let closing = slots.closing;
        (core::mem::take(&mut *slots), closing)
    }

    /// The slots, even after a panic elsewhere: plain data, always consistent.
    fn lock(&self) -> MutexGuard<'_, Slots> {
        self.slots.lock().unwrap_or_else(PoisonError::into_inner)
    }
}

/// The writer's state; [`Writer::run`] is the thread's body.
pub struct Writer {
    path: String,
    baud: u32,
    port: Option<TTYPort>,
    identity: Identity,
    sequence: u8,
    next_heartbeat: Instant,
    /// When the port is down: the next reopening attempt and the current back-off.
    reopen: Option<(Instant, Duration)>,
    counters: Arc<Counters>,
    /// Up to three frames, written at once.
    out: [u8; 3 * MAX_FRAME_BYTES],
}

impl Writer {
    /// A writer for an already opened `port` at `path`; the first heartbeat goes out at once.
    pub fn new(
        path: &str,
        baud: u32,
        port: TTYPort,
        identity: Identity,
        counters: Arc<Counters>,
    ) -> Writer {
        Writer {
            path: path.to_owned(),
            baud,
            port: Some(port),
            identity,
            sequence: 0,
            next_heartbeat: Instant::now(),
            reopen: None,
            counters,
            out: [0; 3 * MAX_FRAME_BYTES],
        }
    }

    /// Sends heartbeats and whatever is posted until the mailbox closes.
    pub fn run(mut self, mailbox: &Mailbox) {
        loop {
            let now = Instant::now();
            if let Some((at, _)) = self.reopen {
                if now >= at {
                    self.try_reopen();
                }
            }
            let heartbeat = now >= self.next_heartbeat;
            if heartbeat {
                self.next_heartbeat = now + HEARTBEAT_INTERVAL;
            }
            let (slots, closing) = if heartbeat {
                mailbox.take(Duration::ZERO)
            } else {
                let mut wait = self.next_heartbeat.saturating_duration_since(now);
                if let Some((at, _)) = self.reopen {
                    wait = wait.min(at.saturating_duration_since(now));
                }
                mailbox.take(wait)
            };
            self.send(heartbeat, &slots);
            if closing {
                return;
            }
        }
    }

    /// Frames the heartbeat (when due), the position and the speed, and writes them at once.
    fn send(&mut self, heartbeat: bool, slots: &Slots) {
        let messages = [
            heartbeat.then(heartbeat_message),
            slots
                .position
                .clone()
                .map(MavMessage::VISION_POSITION_ESTIMATE),
            slots.speed.clone().map(MavMessage::VISION_SPEED_ESTIMATE),
        ];
        let count = messages.iter().flatten().count() as u64;
        if count == 0 {
            return;
        }
        if self.port.is_none() {
            self.counters.port_down.fetch_add(count, Ordering::Relaxed);
            return;
        }
        let mut len = 0;
        for message in messages.iter().flatten() {
            let header = MavHeader {
                system_id: u32::from(self.identity.system_id),
                component_id: self.identity.component_id,
                sequence: self.sequence,
            };
            let Some(mut dst) = self.out.get_mut(len..) else {
                break;
            };
            let room = dst.len();
            // Cannot fail: the buffer holds three frames of the longest payload.
            if let Err(e) = mavlink::write_v2_msg(&mut dst, header, message) {
                log::error!("mavlink: cannot frame a message: {e}");
                continue;
            }
            len += room - dst.len();
            self.sequence = self.sequence.wrapping_add(1);
        }
        let Some(port) = self.port.as_mut() else {
            return;
        };
        match write_all(port, self.out.get(..len).unwrap_or(&[])) {
            Ok(()) => {
                self.counters.sent.fetch_add(count, Ordering::Relaxed);
                if heartbeat {
                    self.counters.heartbeats.fetch_add(1, Ordering::Relaxed);
                }
            }
            Err(e) if e.kind() == io::ErrorKind::TimedOut => {
                // A receiver resynchronises on the next start byte; a cut frame fails its CRC.
                self.counters.timed_out.fetch_add(count, Ordering::Relaxed);
            }
            Err(e) => {
                self.counters.port_down.fetch_add(count, Ordering::Relaxed);
                self.port = None;
                self.counters.losses.fetch_add(1, Ordering::Relaxed);
                log::warn!(
                    "mavlink port {} lost ({e}); tracking goes on, reopening with back-off up \
                     to {} s",
                    self.path,
                    REOPEN_BACKOFF_MAX.as_secs()
                );
                self.reopen = Some((Instant::now() + REOPEN_BACKOFF_MIN, REOPEN_BACKOFF_MIN));
            }
        }
    }

    fn try_reopen(&mut self) {
        let Some((_, backoff)) = self.reopen else {
            return;
        };
        match open_port(&self.path, self.baud) {
            Ok(port) => {
                log::info!("mavlink port {} reopened", self.path);
                self.counters.reopens.fetch_add(1, Ordering::Relaxed);
                self.port = Some(port);
                self.reopen = None;
            }
            Err(e) => {
                log::debug!("mavlink port {}: reopening failed: {e}", self.path);
                let backoff = (backoff * 2).min(REOPEN_BACKOFF_MAX);
                self.reopen = Some((Instant::now() + backoff, backoff));
            }
        }
    }
}

/// glint's heartbeat: an onboard controller that is no autopilot, active.
fn heartbeat_message() -> MavMessage {
    MavMessage::HEARTBEAT(HEARTBEAT_DATA {
        custom_mode: 0,
        mavtype: MavType::MAV_TYPE_ONBOARD_CONTROLLER,
        autopilot: MavAutopilot::MAV_AUTOPILOT_INVALID,
        base_mode: MavModeFlag::empty(),
        system_status: MavState::MAV_STATE_ACTIVE,
        mavlink_version: HEARTBEAT_MAVLINK_VERSION,
    })
}
