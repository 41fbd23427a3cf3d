//! A source that ends cleanly once a stop flag is set (by SIGTERM, say), so that a run over a
//! pipe or a file winds down like a camera run: the frame being processed is finished, the sinks
//! are flushed and the serial link is closed.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

use super::{FrameMeta, FrameSource};
use crate::frame::Frame;

/// `inner` until `stop` is set, then the end of the stream.
#[derive(Debug)]
pub struct Stoppable<S> {
    inner: S,
    stop: Arc<AtomicBool>,
}

impl<S> Stoppable<S> {
    /// Wraps `inner`; setting `stop` ends the stream before the next frame.
    pub fn new(inner: S, stop: Arc<AtomicBool>) -> Self {
        Stoppable { inner, stop }
    }
}

impl<S: FrameSource> FrameSource for Stoppable<S> {
    type Error = S::Error;

    /// Checked before and after the wait: a frame that arrives after the stop is not processed,
    /// and an error that ends the wait after the stop (a reader giving up, see
    /// [`super::interruptible`], or a half-read frame) is the stop, not a failure.
    fn next_frame(&mut self) -> Result<Option<(Frame<'_>, FrameMeta)>, S::Error> {
        if self.stop.load(Ordering::Relaxed) {
            return Ok(None);
        }
        let next = self.inner.next_frame();
        if self.stop.load(Ordering::Relaxed) {
            return Ok(None);
        }
        next
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::FrameSize;
    use crate::source::dump::DumpSource;

    #[test]
    fn the_stream_ends_once_the_flag_is_set() {
        let size = FrameSize::new(4, 2).unwrap();
        let bytes = vec![0u8; size.frame_bytes() * 5];
        let stop = Arc::new(AtomicBool::new(false));
        let mut source = Stoppable::new(DumpSource::new(&bytes[..], size, 30.0), stop.clone());
        assert!(source.next_frame().unwrap().is_some());
        assert!(source.next_frame().unwrap().is_some());
        stop.store(true, Ordering::Relaxed);
        assert!(source.next_frame().unwrap().is_none());
    }

    #[test]
    fn a_wait_given_up_for_the_stop_is_a_clean_end() {
        use crate::source::interruptible::Interruptible;
        use std::os::unix::net::UnixStream;

        let size = FrameSize::new(4, 2).unwrap();
        let (_idle_writer, quiet) = UnixStream::pair().unwrap();
        let stop = Arc::new(AtomicBool::new(false));
        let reader = Interruptible::new(quiet, stop.clone());
        let mut source = Stoppable::new(DumpSource::new(reader, size, 30.0), stop.clone());
        let setter = std::thread::spawn(move || {
            std::thread::sleep(std::time::Duration::from_millis(50));
            stop.store(true, Ordering::Relaxed);
        });
        assert!(source.next_frame().unwrap().is_none());
        setter.join().unwrap();
    }
}
