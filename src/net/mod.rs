//! Publishing reports on the network (`--publish KEY`), over Zenoh in peer mode: no router
//! needed, other peers found by Zenoh's own scouting or at the endpoints given.
//!
//! Every report goes out as glint's JSON line, in a compact binary form ([`wire`]), and, when it
//! has a floor position, as a ROS 2 `PointStamped` ([`ros`]); [`keys`] lists the key
//! expressions. [`subscriber`] is the other end, for `glint fuse --subscribe`; [`fused`]
//! publishes `glint fuse`'s own fused steps.
//!
//! # Threads and memory
//!
//! The tracking thread never waits for the network. [`PublishSink::write`] copies the report
//! (a fixed-size value that owns no heap memory) into a bounded queue, allocated in [`PublishSink::start`], and
//! returns; when the queue is full (the network or the publisher thread is slow) the report is
//! dropped and counted. `try_send` on a bounded std channel allocates nothing, so the tracking
//! thread stays allocation-free (`tests/alloc_free.rs`). The publisher thread (`publisher`)
//! formats and sends; it may allocate, and Zenoh's own threads do. The queue and its thread
//! are `outbox`'s, shared with [`fused`].
//!
//! A network that goes away costs reports, never the process: with no peer connected a put goes
//! nowhere at once; a stalled link blocks the publisher thread until Zenoh closes it (the queue
//! meanwhile drops and counts); and Zenoh reconnects to the endpoints it was given on its own.

pub mod fused;
pub mod keys;
mod outbox;
mod publisher;
pub mod ros;
pub mod subscriber;
pub mod wire;

use core::fmt;
use std::io;

use crate::report::FrameReport;
use crate::sink::Sink;
pub use keys::{KeyError, Keys};
use outbox::Outbox;
pub use publisher::open_session;

/// Reports the queue holds: a second at 32 fps, so a publisher thread stalled for less than
/// that loses nothing.
pub const QUEUE_REPORTS: usize = 32;

/// Bytes the queue takes, for the memory plan.
pub const QUEUE_BYTES: usize = QUEUE_REPORTS * core::mem::size_of::<FrameReport>();

/// Where and how to publish.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PublishConfig {
    /// The key expressions.
    pub keys: Keys,
    /// Endpoints to connect to (`tcp/host:port`).
    pub connect: Vec<String>,
    /// Endpoints to listen on.
    pub listen: Vec<String>,
}

/// Publishing could not start.
#[derive(Debug)]
pub enum PublishError {
    /// An endpoint that is not `tcp/HOST:PORT`.
    Endpoint(String),
    /// Zenoh refused the configuration.
    Config(String),
    /// The session or a publisher could not be opened (say, a port to listen on is taken).
    Open(String),
    /// The publisher thread could not be started.
    Thread(io::Error),
}

impl fmt::Display for PublishError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            PublishError::Endpoint(e) => write!(
                f,
                "endpoint {e:?}: write tcp/HOST:PORT (TCP is this build's only transport)"
            ),
            PublishError::Config(e) => write!(f, "zenoh configuration: {e}"),
            PublishError::Open(e) => write!(f, "cannot open the zenoh session: {e}"),
            PublishError::Thread(e) => write!(f, "cannot start the publisher thread: {e}"),
        }
    }
}

impl core::error::Error for PublishError {}

/// What publishing did over a run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct PublishStats {
    /// Reports handed to the publisher thread.
    pub queued: u64,
    /// Reports dropped because the queue was full (or the publisher thread gone).
    pub dropped: u64,
    /// Reports the publisher thread handed to Zenoh.
    pub sent: u64,
    /// Puts Zenoh refused.
    pub failed: u64,
}

impl fmt::Display for PublishStats {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "queued={} dropped={} sent={} failed={}",
            self.queued, self.dropped, self.sent, self.failed
        )
    }
}

/// The tracking thread's end: a [`Sink`] that queues reports for the publisher thread.
pub struct PublishSink {
    outbox: Outbox<FrameReport>,
}

impl PublishSink {
    /// Opens the Zenoh session and its publishers, and starts the publisher thread.
    pub fn start(config: &PublishConfig) -> Result<PublishSink, PublishError> {
        let publishers = publisher::Publishers::open(config)?;
        let outbox = Outbox::start("glint-publish", move |reports, counters| {
            publishers.run(reports, counters)
        })
        .map_err(PublishError::Thread)?;
        Ok(PublishSink { outbox })
    }

    /// The counts so far.
    pub fn stats(&self) -> PublishStats {
        self.outbox.stats()
    }
}

impl Sink for PublishSink {
    fn write(&mut self, report: &FrameReport) -> io::Result<()> {
        // After `finish` nothing is sent any more: a late report is dropped like any other.
        self.outbox.offer(report.clone());
        Ok(())
    }

    fn finish(&mut self) -> io::Result<()> {
        if self.outbox.is_open() {
            self.outbox.close();
            log::info!("publish: {}", self.stats());
        }
        Ok(())
    }

    fn status(&self, out: &mut fmt::Formatter<'_>) -> fmt::Result {
        let stats = self.stats();
        let audience = if self.outbox.subscribed() {
            "subscribed"
        } else {
            "no subscriber"
        };
        write!(
            out,
            ", publish {audience} (sent {}, dropped {})",
            stats.sent, stats.dropped
        )
    }
}
