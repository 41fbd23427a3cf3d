//! Subscribing to the cameras' JSON lines (`glint fuse --subscribe KEY`): every sample under
//! `KEY/*` (one chunk below the key: each camera's JSON line, not its binary or ROS forms),
//! handed to the fusing thread through a bounded queue. `KEY/fused`, a fuser's own output
//! ([`super::fused`]), is no camera's and is left out.
//!
//! Zenoh's own thread runs the callback: it copies the payload into a [`Message`] (it may
//! allocate; it is no camera's per-frame path) and, when the queue is full because the fuser
//! is behind, drops the message and counts it, so Zenoh's threads never wait on the fuser.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::mpsc::{self, Receiver, TrySendError};
use std::sync::Arc;

use zenoh::pubsub::Subscriber;
use zenoh::{Session, Wait};

use super::keys::{check_key, KeyError, FUSED_CHUNK};
use super::publisher::open_session;
use super::PublishError;

/// Messages the queue holds: two seconds of 8 cameras at 32 fps.
pub const SUBSCRIBE_QUEUE_MESSAGES: usize = 512;

/// One sample: the last chunk of its key (the camera's name there) and its payload as text.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Message {
    /// The key's last chunk.
    pub key_camera: String,
    /// The payload, a JSON line without its newline.
    pub line: String,
}

/// Why a subscription could not start.
#[derive(Debug)]
pub enum SubscribeError {
    /// Not a key one can subscribe below.
    Key(KeyError),
    /// The session or the subscriber could not be opened.
    Open(PublishError),
}

impl core::fmt::Display for SubscribeError {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        match self {
            SubscribeError::Key(e) => write!(f, "{e}"),
            SubscribeError::Open(e) => write!(f, "{e}"),
        }
    }
}

impl core::error::Error for SubscribeError {}

/// What the subscriber's callback counts.
#[derive(Debug, Default)]
struct Counts {
    received: AtomicU64,
    dropped: AtomicU64,
    not_text: AtomicU64,
}

/// A live subscription to `KEY/*`; the messages come out of the receiver [`Subscription::open`]
/// returns.
pub struct Subscription {
    /// The session, when the subscription opened it (and so closes it).
    session: Option<Session>,
    subscriber: Subscriber<()>,
    counts: Arc<Counts>,
}

impl Subscription {
    /// Opens a peer session (the endpoints as `--publish` takes them) and subscribes to
    /// `key/*`.
    pub fn open(
        key: &str,
        connect: &[String],
        listen: &[String],
    ) -> Result<(Subscription, Receiver<Message>), SubscribeError> {
        check_key(key).map_err(SubscribeError::Key)?;
        let session = open_session(connect, listen).map_err(SubscribeError::Open)?;
        let (mut subscription, messages) = Subscription::on(&session, key)?;
        subscription.session = Some(session);
        Ok((subscription, messages))
    }

    /// Subscribes to `key/*` on a session its caller opened (and closes).
    pub fn on(
        session: &Session,
        key: &str,
    ) -> Result<(Subscription, Receiver<Message>), SubscribeError> {
        check_key(key).map_err(SubscribeError::Key)?;
        let (queue, messages) = mpsc::sync_channel(SUBSCRIBE_QUEUE_MESSAGES);
        let counts = Arc::new(Counts::default());
        let callback_counts = Arc::clone(&counts);
        let subscriber = session
            .declare_subscriber(format!("{key}/*"))
            .callback(move |sample| {
                let key_camera = sample
                    .key_expr()
                    .as_str()
                    .rsplit('/')
                    .next()
                    .unwrap_or_default();
                if key_camera == FUSED_CHUNK {
                    return;
                }
                callback_counts.received.fetch_add(1, Ordering::Relaxed);
                let Ok(line) = sample.payload().try_to_string() else {
                    callback_counts.not_text.fetch_add(1, Ordering::Relaxed);
                    return;
                };
                let message = Message {
                    key_camera: key_camera.to_owned(),
                    line: line.into_owned(),
                };
                match queue.try_send(message) {
                    Ok(()) => {}
                    Err(TrySendError::Full(_) | TrySendError::Disconnected(_)) => {
                        callback_counts.dropped.fetch_add(1, Ordering::Relaxed);
                    }
                }
            })
            .wait()
            .map_err(|e| {
                SubscribeError::Open(PublishError::Open(format!("subscriber on {key}/*: {e}")))
            })?;
        Ok((
            Subscription {
                session: None,
                subscriber,
                counts,
            },
            messages,
        ))
    }

    /// Samples received, dropped for a full queue, and dropped as not UTF-8 text.
    pub fn counts(&self) -> (u64, u64, u64) {
        (
            self.counts.received.load(Ordering::Relaxed),
            self.counts.dropped.load(Ordering::Relaxed),
            self.counts.not_text.load(Ordering::Relaxed),
        )
    }

    /// Undeclares the subscriber, and closes the session if it opened it.
    pub fn close(self) {
        if let Err(e) = self.subscriber.undeclare().wait() {
            log::warn!("subscribe: undeclaring the subscriber: {e}");
        }
        if let Some(session) = self.session {
            if let Err(e) = session.close().wait() {
                log::warn!("subscribe: closing the zenoh session: {e}");
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use std::time::Duration;

    use super::*;

    #[test]
    fn a_fusers_own_steps_are_no_cameras_lines() {
        // A session that only listens on the loopback (no scouting): its own puts reach its
        // own subscriber.
        let session = open_session(&[], &["tcp/127.0.0.1:0".to_owned()]).unwrap();
        let (subscription, messages) = Subscription::on(&session, "test/skip").unwrap();
        session.put("test/skip/fused", "{}").wait().unwrap();
        session.put("test/skip/cam", "{\"t\":1}").wait().unwrap();
        let first = messages.recv_timeout(Duration::from_secs(10)).unwrap();
        assert_eq!(first.key_camera, "cam");
        assert!(messages.recv_timeout(Duration::from_millis(200)).is_err());
        assert_eq!(subscription.counts(), (1, 0, 0));
        subscription.close();
        session.close().wait().unwrap();
    }
}
