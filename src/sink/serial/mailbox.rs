//! The hand-over between the capture thread and the serial writer: one slot per message kind,
//! newest wins.
//!
//! The capture thread must never wait for the UART. It copies each message into its slot and
//! moves on; if the writer has not taken the previous one yet, that one is stale and is
//! overwritten (and counted), never queued behind. The lock is only ever held to copy a few
//! dozen bytes, by either side, so posting costs a copy and at most a futex wake.
//!
//! Heartbeats travel encoded. Position updates and LED requests travel as values, because part
//! of them is only known when the writer writes them: how old the position is by then (and, with
//! prediction, where the light is by then), and the host time of the request.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::{Condvar, Mutex, MutexGuard, PoisonError};
use std::time::Duration;

use glint_protocol::MAX_ENCODED_LEN;
use heapless::Vec as BoundedVec;

use crate::report::MAX_ROBOTS;

use super::stamp::{PendingLed, PendingUpdate};

/// Bytes of one slot: the longest frame any protocol version sends, plus its delimiter.
pub const SLOT_BYTES: usize = MAX_ENCODED_LEN + 1;

/// One encoded frame, delimiter included, or nothing.
#[derive(Debug, Clone, Copy)]
pub struct Slot {
    len: usize,
    bytes: [u8; SLOT_BYTES],
}

impl Slot {
    const EMPTY: Slot = Slot {
        len: 0,
        bytes: [0; SLOT_BYTES],
    };

    /// The frame's bytes (empty when the slot is).
    pub fn as_bytes(&self) -> &[u8] {
        self.bytes.get(..self.len).unwrap_or(&[])
    }

    /// Whether the slot holds a frame.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Holds a copy of `frame`; returns `false` (and holds nothing) if it does not fit.
    fn fill(&mut self, frame: &[u8]) -> bool {
        match self.bytes.get_mut(..frame.len()) {
            Some(dst) => {
                dst.copy_from_slice(frame);
                self.len = frame.len();
                true
            }
            None => {
                self.len = 0;
                false
            }
        }
    }
}

/// What is posted: one per slot. The slots are independent: a new position does not make a
/// pending heartbeat or LED request stale.
#[derive(Debug, Clone)]
pub enum Post<'a> {
    /// An encoded heartbeat frame.
    Heartbeat(&'a [u8]),
    /// A position update, stamped with its age when written.
    Update(PendingUpdate),
    /// A LED request, stamped with the host time when written.
    Led(PendingLed),
    /// One frame's updates for several robots on one line (at most [`MAX_ROBOTS`]; more are
    /// dropped), each stamped with its age when written; they replace the previous frame's as a
    /// whole.
    Robots(&'a [PendingUpdate]),
}

/// One frame's updates for the robots on a shared line, in the order they go out.
pub type RobotUpdates = BoundedVec<PendingUpdate, MAX_ROBOTS>;

/// Messages taken for sending, in the order they go out: heartbeat, LED request, update.
#[derive(Debug, Clone)]
pub struct Batch {
    /// The newest heartbeat, if one was posted.
    pub heartbeat: Slot,
    /// The newest LED request, if one was posted.
    pub led: Option<PendingLed>,
    /// The newest position update, if one was posted.
    pub update: Option<PendingUpdate>,
    /// The newest frame's robot updates (empty if none was posted).
    pub robots: RobotUpdates,
}

impl Batch {
    /// Messages in the batch (an update and its age count as one).
    pub fn frames(&self) -> u64 {
        u64::from(!self.heartbeat.is_empty())
            + u64::from(self.led.is_some())
            + u64::from(self.update.is_some())
            + self.robots.len() as u64
    }
}

/// What [`Mailbox::take`] found.
// A batch is large (a frame's updates for every robot), but boxing it would allocate per write.
#[allow(clippy::large_enum_variant)]
#[derive(Debug)]
pub enum Take {
    /// Frames to send.
    Work(Batch),
    /// The wait timed out with nothing posted.
    Idle,
    /// The sink closed and everything posted has been taken.
    Closed,
}

#[derive(Debug)]
struct State {
    heartbeat: Slot,
    led: Option<PendingLed>,
    update: Option<PendingUpdate>,
    robots: RobotUpdates,
    closing: bool,
}

impl State {
    fn is_empty(&self) -> bool {
        self.heartbeat.is_empty()
            && self.led.is_none()
            && self.update.is_none()
            && self.robots.is_empty()
    }
}

/// The two slots, a wake-up for the writer, and the count of frames overwritten unsent.
#[derive(Debug)]
pub struct Mailbox {
    state: Mutex<State>,
    posted: Condvar,
    superseded: AtomicU64,
}

impl Default for Mailbox {
    fn default() -> Self {
        Mailbox {
            state: Mutex::new(State {
                heartbeat: Slot::EMPTY,
                led: None,
                update: None,
                robots: RobotUpdates::new(),
                closing: false,
            }),
            posted: Condvar::new(),
            superseded: AtomicU64::new(0),
        }
    }
}

impl Mailbox {
    /// An empty mailbox.
    pub fn new() -> Self {
        Mailbox::default()
    }

    /// Replaces the message's slot with it and wakes the writer. A message still in the slot
    /// was never taken: it is stale now, and counted in [`Mailbox::superseded`]. A heartbeat
    /// frame longer than a slot is refused (returns `false`); no message of the protocol is.
    pub fn post(&self, post: Post<'_>) -> bool {
        let mut state = self.lock();
        let (replaced, filled) = match post {
            Post::Heartbeat(frame) => (
                u64::from(!state.heartbeat.is_empty()),
                state.heartbeat.fill(frame),
            ),
            Post::Update(u) => (u64::from(state.update.replace(u).is_some()), true),
            Post::Led(l) => (u64::from(state.led.replace(l).is_some()), true),
            Post::Robots(updates) => {
                let replaced = state.robots.len() as u64;
                state.robots.clear();
                let kept = updates.get(..MAX_ROBOTS).unwrap_or(updates);
                // Cannot fail: `kept` fits the capacity.
                let filled = state.robots.extend_from_slice(kept).is_ok();
                (replaced, filled && kept.len() == updates.len())
            }
        };
        if replaced > 0 {
            self.superseded.fetch_add(replaced, Ordering::Relaxed);
        }
        drop(state);
        self.posted.notify_one();
        filled
    }

    /// Waits until something is posted (at most `timeout`, or indefinitely for `None`) and takes
    /// everything posted. After [`Mailbox::close`], pending frames are still handed out once;
    /// then it reports [`Take::Closed`].
    pub fn take(&self, timeout: Option<Duration>) -> Take {
        let idle = |s: &mut State| s.is_empty() && !s.closing;
        let mut state = self.lock();
        state = match timeout {
            None => self
                .posted
                .wait_while(state, |s| idle(s))
                .unwrap_or_else(PoisonError::into_inner),
            Some(t) => {
                self.posted
                    .wait_timeout_while(state, t, |s| idle(s))
                    .unwrap_or_else(PoisonError::into_inner)
                    .0
            }
        };
        let batch = Batch {
            heartbeat: core::mem::replace(&mut state.heartbeat, Slot::EMPTY),
            led: state.led.take(),
            update: state.update.take(),
            robots: core::mem::take(&mut state.robots),
        };
        if batch.frames() > 0 {
            Take::Work(batch)
        } else if state.closing {
            Take::Closed
        } else {
            Take::Idle
        }
    }

    /// Tells the writer to send what is pending and stop.
    pub fn close(&self) {
        self.lock().closing = true;
        self.posted.notify_one();
    }

    /// Frames overwritten by a newer one before the writer took them.
    pub fn superseded(&self) -> u64 {
        self.superseded.load(Ordering::Relaxed)
    }

    /// The state, even if a thread panicked while holding it: it is plain values and a flag,
    /// always consistent.
    fn lock(&self) -> MutexGuard<'_, State> {
        self.state.lock().unwrap_or_else(PoisonError::into_inner)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sink::serial::stamp::tests::{led, update};
    use std::sync::Arc;

    #[test]
    fn newest_wins_and_stale_messages_are_counted() {
        let m = Mailbox::new();
        assert!(m.post(Post::Update(update(1))));
        assert!(m.post(Post::Update(update(2))));
        assert!(m.post(Post::Heartbeat(&[9, 0])));
        assert!(m.post(Post::Led(led(7))));
        assert!(m.post(Post::Update(update(3))));
        assert_eq!(m.superseded(), 2);
        let Take::Work(batch) = m.take(None) else {
            panic!("expected work");
        };
        assert_eq!(batch.update.map(|u| u.measured.seq), Some(3));
        assert_eq!(batch.led.map(|l| l.request.request), Some(7));
        assert_eq!(batch.heartbeat.as_bytes(), [9, 0]);
        assert_eq!(batch.frames(), 3);
        // Taken slots are empty: the next post replaces nothing.
        assert!(m.post(Post::Update(update(4))));
        assert_eq!(m.superseded(), 2);
    }

    #[test]
    fn idle_after_timeout_and_closed_after_pending_work() {
        let m = Mailbox::new();
        assert!(matches!(m.take(Some(Duration::from_millis(1))), Take::Idle));
        m.post(Post::Update(update(1)));
        m.close();
        assert!(matches!(m.take(None), Take::Work(b) if b.frames() == 1));
        assert!(matches!(m.take(None), Take::Closed));
    }

    #[test]
    fn oversized_frame_is_refused() {
        let m = Mailbox::new();
        assert!(!m.post(Post::Heartbeat(&[1; SLOT_BYTES + 1])));
        assert!(matches!(m.take(Some(Duration::from_millis(1))), Take::Idle));
    }

    #[test]
    fn a_waiting_writer_wakes_on_post() {
        let m = Arc::new(Mailbox::new());
        let writer = {
            let m = Arc::clone(&m);
            std::thread::spawn(move || match m.take(None) {
                Take::Work(b) => b.update.map(|u| u.measured.seq),
                other => panic!("expected work, got {other:?}"),
            })
        };
        m.post(Post::Update(update(42)));
        assert_eq!(writer.join().unwrap(), Some(42));
    }
}
