//! A reader that gives up waiting once a stop is requested, so that SIGTERM ends a run over an
//! open but idle pipe, a FIFO or a terminal as promptly as over a file.
//!
//! A blocking `read` on a pipe is restarted by the kernel after the signal handler returns
//! (the handlers are installed with `SA_RESTART`), so the stop flag would only be seen when
//! data or the end of the stream arrived. Here every read first waits in `poll`, which the
//! kernel never restarts, in slices of [`STOP_CHECK_INTERVAL`]: the stop flag is checked when
//! a signal interrupts the wait, and at the end of every slice in case the signal went to
//! another thread. Waiting costs one `poll` call per read and allocates nothing.

use core::fmt;
use std::io::{self, Read};
use std::os::fd::{AsRawFd, RawFd};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

use nix::errno::Errno;
use nix::poll::{poll, PollFd, PollFlags};

/// Longest wait before the stop flag is checked again: about one frame at 30 fps.
pub const STOP_CHECK_INTERVAL: Duration = Duration::from_millis(30);

/// The error a read returns once a stop was requested (wrapped in an [`io::Error`] of kind
/// `Other`); [`super::stoppable::Stoppable`] turns it into the clean end of the stream.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct StopRequested;

impl fmt::Display for StopRequested {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "stopped while waiting for input")
    }
}

impl std::error::Error for StopRequested {}

/// `inner`, whose reads wait for data only until `stop` is set.
#[derive(Debug)]
pub struct Interruptible<R> {
    inner: R,
    fd: RawFd,
    stop: Arc<AtomicBool>,
}

impl<R: Read + AsRawFd> Interruptible<R> {
    /// Wraps `inner`. It may be in non-blocking mode (a FIFO opened with `O_NONBLOCK` so that
    /// opening it does not wait for a writer): a read that would block waits again.
    pub fn new(inner: R, stop: Arc<AtomicBool>) -> Self {
        let fd = inner.as_raw_fd();
        Interruptible { inner, fd, stop }
    }
}

impl<R: Read> Interruptible<R> {
    /// Waits until the descriptor has something to say (data, the end, an error) or a stop
    /// is requested.
    fn wait(&self) -> io::Result<()> {
        let slice_ms = STOP_CHECK_INTERVAL.as_millis() as i32;
        loop {
            if self.stop.load(Ordering::Relaxed) {
                return Err(io::Error::other(StopRequested));
            }
            let mut fds = [PollFd::new(self.fd, PollFlags::POLLIN)];
            match poll(&mut fds, slice_ms) {
                // Readable, hung up or failed: the read says which.
                Ok(n) if n > 0 => return Ok(()),
                Ok(_) | Err(Errno::EINTR) => {}
                Err(e) => return Err(e.into()),
            }
        }
    }
}

impl<R: Read> Read for Interruptible<R> {
    fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
        loop {
            self.wait()?;
            match self.inner.read(buf) {
                Err(e) if e.kind() == io::ErrorKind::WouldBlock => continue,
                other => return other,
            }
        }
    }
}

/// Whether `error` is a reader's answer to a stop request.
pub fn is_stop(error: &io::Error) -> bool {
    error
        .get_ref()
        .is_some_and(|inner| inner.is::<StopRequested>())
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;
    use std::os::unix::net::UnixStream;
    use std::time::Instant;

    #[test]
    fn data_passes_through() {
        let (mut a, b) = UnixStream::pair().unwrap();
        a.write_all(b"abc").unwrap();
        drop(a);
        let mut reader = Interruptible::new(b, Arc::new(AtomicBool::new(false)));
        let mut got = Vec::new();
        reader.read_to_end(&mut got).unwrap();
        assert_eq!(got, b"abc");
    }

    #[test]
    fn a_stop_ends_a_wait_on_a_quiet_stream() {
        // The writer stays open and silent, as an idle pipe does.
        let (_writer, quiet) = UnixStream::pair().unwrap();
        let stop = Arc::new(AtomicBool::new(false));
        let mut reader = Interruptible::new(quiet, Arc::clone(&stop));
        let setter = std::thread::spawn(move || {
            std::thread::sleep(Duration::from_millis(100));
            stop.store(true, Ordering::Relaxed);
        });
        let started = Instant::now();
        let e = reader.read(&mut [0u8; 16]).unwrap_err();
        assert!(is_stop(&e), "{e}");
        assert!(started.elapsed() >= Duration::from_millis(100));
        setter.join().unwrap();
        assert!(!is_stop(&io::Error::other("something else")));
    }
}
