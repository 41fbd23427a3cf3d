//! The re-check's worker thread: made once at start, it takes one job at a time (a copy of a
//! frame's luma and the pose in force) and hands back the copy with its verdict.
//!
//! The hand-off is one slot under a mutex, with a condition variable to wake either side: a
//! futex on Linux, nothing allocated per job (a channel's blocking receive may allocate its
//! waiter's context). The copy's buffer is allocated once and travels with the job, so neither
//! side ever allocates for it.

use std::sync::{Arc, Condvar, Mutex, MutexGuard, PoisonError};
use std::thread::JoinHandle;
use std::time::Duration;

use super::judge::{Checker, Verdict};
use crate::frame::{Frame, FrameSize, PixelFormat};
use crate::geometry::camera::CameraModel;

/// How long the tracking thread waits before it looks whether the worker is still there.
const WAIT_SLICE: Duration = Duration::from_millis(100);

/// One check to make.
pub struct Job {
    /// The frame's luma, row after row (`size`'s width apart).
    pub luma: Box<[u8]>,
    /// The pose in force when the frame was taken.
    pub camera: CameraModel,
}

// One slot, made once and moved once a check: boxing the verdict would allocate per check.
#[allow(clippy::large_enum_variant)]
enum Slot {
    /// Nothing to do; the tracking thread holds the buffer.
    Idle,
    /// A job for the worker.
    Job(Job),
    /// The worker is checking.
    Busy,
    /// The job's buffer and its verdict, for the tracking thread.
    Done(Job, Verdict),
    /// The worker is to end.
    Quit,
}

struct Shared {
    slot: Mutex<Slot>,
    changed: Condvar,
}

impl Shared {
    fn lock(&self) -> MutexGuard<'_, Slot> {
        // A panic while holding the lock leaves a slot that is still a valid state.
        self.slot.lock().unwrap_or_else(PoisonError::into_inner)
    }
}

/// The worker thread and its slot.
pub struct Worker {
    shared: Arc<Shared>,
    handle: Option<JoinHandle<()>>,
}

impl Worker {
    /// Starts the worker thread, which owns `checker` and checks frames of `size`.
    pub fn start(mut checker: Checker, size: FrameSize) -> std::io::Result<Worker> {
        let shared = Arc::new(Shared {
            slot: Mutex::new(Slot::Idle),
            changed: Condvar::new(),
        });
        let theirs = Arc::clone(&shared);
        let handle = std::thread::Builder::new()
            .name("glint-recheck".into())
            .spawn(move || loop {
                let job = {
                    let mut slot = theirs.lock();
                    loop {
                        match core::mem::replace(&mut *slot, Slot::Busy) {
                            Slot::Job(job) => break job,
                            Slot::Quit => return,
                            other => {
                                *slot = other;
                                slot = theirs
                                    .changed
                                    .wait(slot)
                                    .unwrap_or_else(PoisonError::into_inner);
                            }
                        }
                    }
                };
                let width = size.width();
                let verdict = match Frame::new_checked_as(&job.luma, size, width, PixelFormat::Grey)
                {
                    Ok(frame) => checker.check(&frame, &job.camera),
                    // The buffer is made for `size` at start: never reached.
                    Err(_) => return,
                };
                let mut slot = theirs.lock();
                if matches!(*slot, Slot::Quit) {
                    return;
                }
                *slot = Slot::Done(job, verdict);
                theirs.changed.notify_all();
            })?;
        Ok(Worker {
            shared,
            handle: Some(handle),
        })
    }

    /// Hands `job` to the worker (the previous job's verdict must have been taken).
    pub fn submit(&self, job: Job) {
        let mut slot = self.shared.lock();
        *slot = Slot::Job(job);
        self.shared.changed.notify_all();
    }

    /// Waits for the job's verdict; `None` if the worker has ended (it panicked).
    pub fn wait(&self) -> Option<(Job, Verdict)> {
        let mut slot = self.shared.lock();
        loop {
            match core::mem::replace(&mut *slot, Slot::Idle) {
                Slot::Done(job, verdict) => return Some((job, verdict)),
                Slot::Quit | Slot::Idle => return None,
                other => *slot = other,
            }
            if self.handle.as_ref().is_none_or(JoinHandle::is_finished) {
                return None;
            }
            slot = self
                .shared
                .changed
                .wait_timeout(slot, WAIT_SLICE)
                .unwrap_or_else(PoisonError::into_inner)
                .0;
        }
    }
}

impl Drop for Worker {
    fn drop(&mut self) {
        *self.shared.lock() = Slot::Quit;
        self.shared.changed.notify_all();
        if let Some(handle) = self.handle.take() {
            // A worker that panicked has nothing more to say.
            let _ = handle.join();
        }
    }
}
