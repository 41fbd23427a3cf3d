//! Streaming capture with mmap buffers: the driver fills buffers in a ring, glint reads one in
//! place while the others are being filled, then hands it back.
//!
//! This is a small replacement for `v4l::io::mmap::Stream`, whose `Drop` panics when STREAMOFF
//! fails with anything but ENODEV and whose single `next()` call cannot be retried after a
//! timeout (the buffer it re-queues first is already queued). Here stopping never panics, a
//! timeout leaves the ring intact, and dequeueing is split from reading (`dequeue` mutates,
//! `bytes` borrows), so a caller can handle errors before it lends out a frame.

use std::io;
use std::os::raw::c_int;

use super::sys::{self, Dequeued, Mapping};

/// How a wait for the next buffer ended without one.
#[derive(Debug)]
pub enum WaitError {
    /// No buffer within the timeout.
    TimedOut,
    /// A signal arrived while waiting (for example Ctrl-C); the ring is intact.
    Interrupted,
    /// The driver reported an error (ENODEV when the device is gone, EIO, ...).
    Driver(&'static str, io::Error),
}

/// A ring of mmap capture buffers on one open node.
#[derive(Debug)]
pub struct MmapStream {
    fd: c_int,
    buffers: Vec<Mapping>,
    /// The buffer lent out to the caller, handed back to the driver at the next dequeue.
    held: Option<u32>,
    streaming: bool,
}

impl MmapStream {
    /// Requests `buffer_count` buffers (the driver may grant more or fewer), maps them, queues
    /// them all and starts streaming. `fd` must stay open for as long as the stream lives.
    pub fn start(fd: c_int, buffer_count: u32) -> Result<Self, WaitError> {
        let granted = sys::request_buffers(fd, buffer_count)
            .map_err(|e| WaitError::Driver("VIDIOC_REQBUFS", e))?;
        let mut stream = MmapStream {
            fd,
            buffers: Vec::with_capacity(granted as usize),
            held: None,
            streaming: false,
        };
        if granted == 0 {
            return Err(WaitError::Driver(
                "VIDIOC_REQBUFS",
                io::Error::new(io::ErrorKind::OutOfMemory, "the driver granted no buffers"),
            ));
        }
        for index in 0..granted {
            let (offset, len) = sys::query_buffer(fd, index)
                .map_err(|e| WaitError::Driver("VIDIOC_QUERYBUF", e))?;
            let mapping =
                Mapping::new(fd, offset, len).map_err(|e| WaitError::Driver("mmap", e))?;
            stream.buffers.push(mapping);
        }
        for index in 0..granted {
            sys::queue_buffer(fd, index).map_err(|e| WaitError::Driver("VIDIOC_QBUF", e))?;
        }
        sys::set_streaming(fd, true).map_err(|e| WaitError::Driver("VIDIOC_STREAMON", e))?;
        stream.streaming = true;
        Ok(stream)
    }

    /// How many buffers the driver granted.
    pub fn buffer_count(&self) -> usize {
        self.buffers.len()
    }

    /// Hands the previously lent buffer back to the driver, then waits up to `timeout_ms` for
    /// the next filled one.
    pub fn dequeue(&mut self, timeout_ms: i32) -> Result<Dequeued, WaitError> {
        if let Some(index) = self.held {
            sys::queue_buffer(self.fd, index).map_err(|e| WaitError::Driver("VIDIOC_QBUF", e))?;
            self.held = None;
        }
        loop {
            match sys::wait_readable(self.fd, timeout_ms) {
                Ok(true) => {}
                Ok(false) => return Err(WaitError::TimedOut),
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {
                    return Err(WaitError::Interrupted)
                }
                Err(e) => return Err(WaitError::Driver("poll", e)),
            }
            match sys::dequeue_buffer(self.fd) {
                Ok(done) if (done.index as usize) < self.buffers.len() => {
                    self.held = Some(done.index);
                    return Ok(done);
                }
                Ok(done) => {
                    return Err(WaitError::Driver(
                        "VIDIOC_DQBUF",
                        io::Error::new(
                            io::ErrorKind::InvalidData,
                            format!("the driver returned unknown buffer {}", done.index),
                        ),
                    ))
                }
                // Readable but nothing to take: another event woke poll. Wait again.
                Err(e) if e.kind() == io::ErrorKind::WouldBlock => continue,
                Err(e) if e.kind() == io::ErrorKind::Interrupted => {
                    return Err(WaitError::Interrupted)
                }
                Err(e) => return Err(WaitError::Driver("VIDIOC_DQBUF", e)),
            }
        }
    }

    /// The whole mapped memory of the buffer last dequeued, or `None` before the first one.
    /// Only its first `bytesused` bytes hold the frame.
    pub fn held_bytes(&self) -> Option<&[u8]> {
        let index = self.held?;
        self.buffers.get(index as usize).map(Mapping::bytes)
    }
}

impl Drop for MmapStream {
    fn drop(&mut self) {
        if self.streaming {
            // Fails with ENODEV when the camera is gone; the buffers are released either way
            // once the mappings and the file are closed.
            if let Err(e) = sys::set_streaming(self.fd, false) {
                log::debug!("VIDIOC_STREAMOFF failed while closing the stream: {e}");
            }
        }
        // Unmap before releasing the buffers: the driver keeps mapped buffers alive.
        self.buffers.clear();
        if let Err(e) = sys::request_buffers(self.fd, 0) {
            log::debug!("freeing the capture buffers failed: {e}");
        }
    }
}
