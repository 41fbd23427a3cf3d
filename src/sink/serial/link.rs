//! The writer thread: owns the serial port, sends what the mailbox hands it, and survives the
//! port vanishing.
//!
//! Each batch (heartbeat, LED request, then position update and its age) goes out in one
//! `write`; the update's age and the request's host time are stamped just before it (see
//! `stamp`). After a write the thread waits
//! until the UART's output queue has drained before taking the next batch, so the kernel never
//! holds a backlog of stale positions either: when the line is slower than the frame rate,
//! the mailbox drops the stale ones and the next write carries the newest.
//!
//! When a write fails with anything but a timeout (EIO, ENXIO, a hang-up: a USB adapter
//! unplugged), the port is closed, the fault is logged once, and the thread tries to reopen it
//! with doubling back-off, dropping (and counting) whatever is posted meanwhile. Every
//! successful open starts with a lone 0x00, so a frame cut by the fault cannot merge with the
//! next one at the receiver.

use std::io::{self, Write};
use std::os::unix::io::AsRawFd;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Arc, Mutex, PoisonError};
use std::time::{Duration, Instant};

use glint_protocol::{DELIMITER, MAX_LED_WIRE_LEN, MAX_UPDATE_WIRE_LEN};
use nix::fcntl::{fcntl, FcntlArg, OFlag};
use serialport::{DataBits, FlowControl, Parity, SerialPort, StopBits, TTYPort};

use super::mailbox::{Batch, Mailbox, Take, SLOT_BYTES};
use super::stamp::{encode_led, encode_update, SentLed};
use crate::report::MAX_ROBOTS;
use crate::source::clock::monotonic_now_us;

/// Bytes of the longest write: a delimiter, a heartbeat, a LED request, an update and its age,
/// and a frame's updates (and ages) for every robot on a shared line.
const OUT_BYTES: usize = 1 + SLOT_BYTES + MAX_LED_WIRE_LEN + (1 + MAX_ROBOTS) * MAX_UPDATE_WIRE_LEN;

/// How long one batch may wait for room in the output queue (a receiver that stopped reading a
/// pty, a stuck line) before it is given up as unsent.
pub const WRITE_TIMEOUT: Duration = Duration::from_millis(100);

/// Pause before retrying a write the kernel refused for want of room.
const WOULD_BLOCK_PAUSE: Duration = Duration::from_millis(1);

/// How long the thread waits for the output queue to drain after a write before taking the
/// next batch anyway. A full batch at 9600 Bd takes 94 ms.
pub const DRAIN_LIMIT: Duration = Duration::from_millis(150);

/// First wait before reopening a lost port; doubles per failed attempt.
pub const REOPEN_BACKOFF_MIN: Duration = Duration::from_millis(100);

/// Longest wait between reopening attempts.
pub const REOPEN_BACKOFF_MAX: Duration = Duration::from_secs(5);

/// Shortest and longest sleep while polling the output queue.
const DRAIN_POLL_MIN: Duration = Duration::from_micros(100);
const DRAIN_POLL_MAX: Duration = Duration::from_millis(10);

/// Bit times per byte on the line: start bit, 8 data bits, stop bit (8N1).
pub const BITS_PER_BYTE: u64 = 10;

/// What the writer did, shared with the sink for its summary.
#[derive(Debug, Default)]
pub struct Counters {
    /// Frames handed to the kernel in full.
    pub sent: AtomicU64,
    /// Frames given up because the write timed out (the line or the receiver is stuck).
    pub timed_out: AtomicU64,
    /// Frames dropped because the port was gone.
    pub port_down: AtomicU64,
    /// Times the port vanished.
    pub losses: AtomicU64,
    /// Times it was reopened.
    pub reopens: AtomicU64,
    /// The last LED request handed to the kernel, with the frame time it left at.
    pub last_led: Mutex<Option<SentLed>>,
}

impl Counters {
    /// The last LED request sent, if any.
    pub fn last_led(&self) -> Option<SentLed> {
        *self.last_led.lock().unwrap_or_else(PoisonError::into_inner)
    }
}

/// Opens `path` as 8N1 without flow control, non-blocking: serialport waits for room with
/// `poll` and a timeout, but a blocking `write` could still wait for all its bytes when only
/// some fit, forever if the receiver stopped reading.
pub fn open_port(path: &str, baud: u32) -> serialport::Result<TTYPort> {
    let port = serialport::new(path, baud)
        .data_bits(DataBits::Eight)
        .parity(Parity::None)
        .stop_bits(StopBits::One)
        .flow_control(FlowControl::None)
        .timeout(WRITE_TIMEOUT)
        .open_native()?;
    fcntl(port.as_raw_fd(), FcntlArg::F_SETFL(OFlag::O_NONBLOCK))?;
    Ok(port)
}

/// An outage in progress.
#[derive(Debug)]
struct Outage {
    since: Instant,
    attempts: u32,
    backoff: Duration,
    next_attempt: Instant,
}

/// The writer's state; [`Link::run`] is the thread's body.
pub struct Link {
    path: String,
    baud: u32,
    port: Option<TTYPort>,
    outage: Option<Outage>,
    /// The receiver may hold a partial frame (a write timed out part-way, or the port was just
    /// opened): the next write starts with a delimiter.
    needs_delimiter: bool,
    /// One write: a delimiter, a heartbeat, a LED request, a position and its age.
    out: [u8; OUT_BYTES],
    counters: Arc<Counters>,
}

impl Link {
    /// A writer for an already opened `port` at `path`.
    pub fn new(path: &str, baud: u32, port: TTYPort, counters: Arc<Counters>) -> Self {
        let mut link = Link {
            path: path.to_owned(),
            baud,
            port: Some(port),
            outage: None,
            needs_delimiter: true,
            out: [0; OUT_BYTES],
            counters,
        };
        link.send_delimiter();
        link
    }

    /// Sends batches from `mailbox` until it closes.
    pub fn run(mut self, mailbox: &Mailbox) {
        loop {
            let wait = self
                .outage
                .as_ref()
                .map(|o| o.next_attempt.saturating_duration_since(Instant::now()));
            let take = mailbox.take(wait);
            if self
                .outage
                .as_ref()
                .is_some_and(|o| Instant::now() >= o.next_attempt)
            {
                self.reopen();
            }
            match take {
                Take::Work(batch) => self.send(&batch),
                Take::Idle => {}
                Take::Closed => return,
            }
        }
    }

    /// Writes `batch` in one write, or counts it dropped.
    fn send(&mut self, batch: &Batch) {
        let frames = batch.frames();
        if self.port.is_none() {
            self.counters.port_down.fetch_add(frames, Ordering::Relaxed);
            return;
        }
        let mut len = 0;
        let parts: [&[u8]; 2] = [
            if self.needs_delimiter {
                &[DELIMITER]
            } else {
                &[]
            },
            batch.heartbeat.as_bytes(),
        ];
        for part in parts {
            if let Some(dst) = self.out.get_mut(len..len + part.len()) {
                dst.copy_from_slice(part);
                len += part.len();
            }
        }
        // Stamped now, as late as can be: the write follows at once.
        let now_us = monotonic_now_us();
        let mut sent_led = None;
        if let Some(led) = &batch.led {
            let out = self.out.get_mut(len..).unwrap_or(&mut []);
            match encode_led(led, now_us, len, self.baud, out) {
                Ok((n, sent)) => {
                    len += n;
                    sent_led = Some(sent);
                }
                // Cannot happen: the buffer holds the longest write.
                Err(e) => log::error!("serial: {e}"),
            }
        }
        // Each update's age counts the line time of everything ahead of it in this write.
        for update in batch.update.iter().chain(&batch.robots) {
            let out = self.out.get_mut(len..).unwrap_or(&mut []);
            match encode_update(update, now_us, len, self.baud, out) {
                Ok((n, _)) => len += n,
                Err(e) => log::error!("serial: {e}"),
            }
        }
        let Some(port) = self.port.as_mut() else {
            return;
        };
        match write_all(port, self.out.get(..len).unwrap_or(&[])) {
            Ok(()) => {
                self.needs_delimiter = false;
                self.counters.sent.fetch_add(frames, Ordering::Relaxed);
                if sent_led.is_some() {
                    *self
                        .counters
                        .last_led
                        .lock()
                        .unwrap_or_else(PoisonError::into_inner) = sent_led;
                }
                drain(port, self.baud);
            }
            Err(e) if is_timeout(&e) => {
                // Part of a frame may be on the line: close it off before the next one.
                self.needs_delimiter = true;
                self.counters.timed_out.fetch_add(frames, Ordering::Relaxed);
                log::debug!(
                    "serial port {}: write timed out, {frames} frames dropped",
                    self.path
                );
            }
            Err(e) => {
                self.counters.port_down.fetch_add(frames, Ordering::Relaxed);
                self.lose(&e);
            }
        }
    }

    /// Writes the lone 0x00 that starts every (re)opened port.
    fn send_delimiter(&mut self) {
        let Some(port) = self.port.as_mut() else {
            return;
        };
        match write_all(port, &[DELIMITER]) {
            Ok(()) => self.needs_delimiter = false,
            // Still owed: it goes in front of the next frame.
            Err(e) if is_timeout(&e) => self.needs_delimiter = true,
            Err(e) => self.lose(&e),
        }
    }

    /// Closes the port after a fault and schedules the first reopening attempt.
    fn lose(&mut self, e: &io::Error) {
        self.port = None;
        self.counters.losses.fetch_add(1, Ordering::Relaxed);
        log::warn!(
            "serial port {} lost ({e}); tracking goes on, reopening with back-off up to {} s",
            self.path,
            REOPEN_BACKOFF_MAX.as_secs()
        );
        let now = Instant::now();
        self.outage = Some(Outage {
            since: now,
            attempts: 0,
            backoff: REOPEN_BACKOFF_MIN,
            next_attempt: now + REOPEN_BACKOFF_MIN,
        });
    }

    /// One reopening attempt; on failure the back-off doubles up to [`REOPEN_BACKOFF_MAX`].
    fn reopen(&mut self) {
        let Some(outage) = self.outage.as_mut() else {
            return;
        };
        outage.attempts = outage.attempts.saturating_add(1);
        match open_port(&self.path, self.baud) {
            Ok(port) => {
                log::info!(
                    "serial port {} reopened after {:.1} s ({} attempts)",
                    self.path,
                    outage.since.elapsed().as_secs_f64(),
                    outage.attempts
                );
                self.counters.reopens.fetch_add(1, Ordering::Relaxed);
                self.port = Some(port);
                self.outage = None;
                self.send_delimiter();
            }
            Err(e) => {
                log::debug!("serial port {}: reopening failed: {e}", self.path);
                outage.backoff = (outage.backoff * 2).min(REOPEN_BACKOFF_MAX);
                outage.next_attempt = Instant::now() + outage.backoff;
            }
        }
    }
}

/// Writes all of `bytes` within about [`WRITE_TIMEOUT`] (each write waits for room at most
/// that long, and no new write starts after it).
pub(crate) fn write_all(port: &mut TTYPort, mut bytes: &[u8]) -> io::Result<()> {
    let deadline = Instant::now() + WRITE_TIMEOUT;
    while !bytes.is_empty() {
        if Instant::now() >= deadline {
            return Err(io::ErrorKind::TimedOut.into());
        }
        match port.write(bytes) {
            Ok(0) => return Err(io::ErrorKind::WriteZero.into()),
            Ok(n) => bytes = bytes.get(n..).unwrap_or(&[]),
            Err(e) if e.kind() == io::ErrorKind::Interrupted => {}
            Err(e) if e.kind() == io::ErrorKind::WouldBlock => {
                std::thread::sleep(WOULD_BLOCK_PAUSE)
            }
            Err(e) => return Err(e),
        }
    }
    Ok(())
}

fn is_timeout(e: &io::Error) -> bool {
    e.kind() == io::ErrorKind::TimedOut
}

/// Waits (at most [`DRAIN_LIMIT`]) until the UART has sent what is queued, sleeping about as
/// long as the queued bytes take on the line. Ports that cannot tell (a pty says 0) return at
/// once; a failing query is left for the next write to find.
fn drain(port: &TTYPort, baud: u32) {
    let deadline = Instant::now() + DRAIN_LIMIT;
    while let Ok(queued @ 1..) = port.bytes_to_write() {
        let now = Instant::now();
        if now >= deadline {
            return;
        }
        let wait = line_time(u64::from(queued), baud).clamp(DRAIN_POLL_MIN, DRAIN_POLL_MAX);
        std::thread::sleep(wait.min(deadline - now));
    }
}

/// Time `bytes` take on the line at `baud`, 8N1.
pub fn line_time(bytes: u64, baud: u32) -> Duration {
    let micros = bytes
        .saturating_mul(BITS_PER_BYTE)
        .saturating_mul(1_000_000)
        / u64::from(baud.max(1));
    Duration::from_micros(micros)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn line_time_is_ten_bit_times_per_byte() {
        assert_eq!(line_time(24, 115_200), Duration::from_micros(2_083));
        assert_eq!(line_time(24, 9_600), Duration::from_micros(25_000));
        assert_eq!(line_time(1, 0), Duration::from_secs(10));
    }
}
