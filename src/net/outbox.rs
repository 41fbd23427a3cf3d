//! The one queue-and-thread pattern both publishers use: the producing thread (tracking or
//! fusing) offers an item and returns at once; a bounded queue, allocated when the outbox
//! starts, hands it to a thread of its own that sends it. When the queue is full (a slow
//! network, a stalled link) the item is dropped and counted, so the producer never waits for
//! the network. `try_send` on a bounded std channel allocates nothing, so a producer that
//! offers values that own no heap memory stays allocation-free (`tests/alloc_free.rs`).

use std::io;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc::{self, Receiver, SyncSender, TrySendError};
use std::sync::Arc;
use std::thread::JoinHandle;

use super::{PublishStats, QUEUE_REPORTS};

/// What the sending thread counts, read by the producer for its status line.
#[derive(Debug, Default)]
pub struct Counters {
    /// Items the sending thread handed to Zenoh whole.
    pub sent: AtomicU64,
    /// Items of which Zenoh refused a put.
    pub failed: AtomicU64,
    /// Whether any subscriber matched at the last item (set by senders that ask Zenoh).
    pub subscribed: AtomicBool,
}

/// The producer's end: the queue, the sending thread, and the counts.
pub struct Outbox<T> {
    queue: Option<SyncSender<T>>,
    thread: Option<JoinHandle<()>>,
    counters: Arc<Counters>,
    queued: u64,
    dropped: u64,
}

impl<T: Send + 'static> Outbox<T> {
    /// Starts the thread `name`, which runs `send` over every queued item until the producer
    /// hangs up ([`Outbox::close`]).
    pub fn start<F>(name: &str, send: F) -> io::Result<Outbox<T>>
    where
        F: FnOnce(Receiver<T>, &Counters) + Send + 'static,
    {
        let (queue, items) = mpsc::sync_channel(QUEUE_REPORTS);
        let counters = Arc::new(Counters::default());
        let thread_counters = Arc::clone(&counters);
        let thread = std::thread::Builder::new()
            .name(name.into())
            .spawn(move || send(items, &thread_counters))?;
        Ok(Outbox {
            queue: Some(queue),
            thread: Some(thread),
            counters,
            queued: 0,
            dropped: 0,
        })
    }

    /// Queues `item`, or drops and counts it when the queue is full, the sending thread is
    /// gone, or the outbox was closed. Never waits.
    pub fn offer(&mut self, item: T) {
        let Some(queue) = &self.queue else {
            self.dropped += 1;
            return;
        };
        match queue.try_send(item) {
            Ok(()) => self.queued += 1,
            Err(TrySendError::Full(_) | TrySendError::Disconnected(_)) => self.dropped += 1,
        }
    }
}

impl<T> Outbox<T> {
    /// The counts so far; final once [`Outbox::close`] has returned.
    pub fn stats(&self) -> PublishStats {
        PublishStats {
            queued: self.queued,
            dropped: self.dropped,
            sent: self.counters.sent.load(Ordering::Relaxed),
            failed: self.counters.failed.load(Ordering::Relaxed),
        }
    }

    /// Whether a subscriber matched at the last item sent.
    pub fn subscribed(&self) -> bool {
        self.counters.subscribed.load(Ordering::Relaxed)
    }

    /// Whether the outbox still takes items (it was not closed yet).
    pub fn is_open(&self) -> bool {
        self.thread.is_some()
    }

    /// Lets the sending thread send what is queued and waits for it. Later items are dropped.
    pub fn close(&mut self) {
        drop(self.queue.take());
        if let Some(thread) = self.thread.take() {
            if thread.join().is_err() {
                log::warn!("publish: the sending thread panicked");
            }
        }
    }
}

impl<T> Drop for Outbox<T> {
    fn drop(&mut self) {
        self.close();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// With the sending thread held up before it takes any item, the queue takes exactly its
    /// capacity and drops the rest; once released, everything queued is sent, and an item offered
    /// after closing is dropped.
    #[test]
    fn a_full_queue_drops_and_counts_without_waiting() {
        let (release, held) = mpsc::channel::<()>();
        let mut outbox = Outbox::start("outbox-test", move |items: Receiver<u32>, counters| {
            held.recv().ok();
            for _ in items {
                counters.sent.fetch_add(1, Ordering::Relaxed);
            }
        })
        .unwrap();
        let offered = 3 * QUEUE_REPORTS as u64;
        for item in 0..offered {
            outbox.offer(item as u32);
        }
        let stats = outbox.stats();
        assert_eq!(stats.queued + stats.dropped, offered, "{stats}");
        assert_eq!(stats.queued, QUEUE_REPORTS as u64, "{stats}");
        release.send(()).unwrap();
        outbox.close();
        outbox.offer(0);
        let stats = outbox.stats();
        assert_eq!(stats.sent, QUEUE_REPORTS as u64, "{stats}");
        assert_eq!(stats.dropped, offered - QUEUE_REPORTS as u64 + 1, "{stats}");
    }
}
