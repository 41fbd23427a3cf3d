//! Where frames come from: raw dumps (files or standard input) and, later, V4L2 cameras.
//!
//! A source lends out one frame at a time from a buffer it owns (a read buffer sized once, or a
//! driver's mmap buffer); the frame borrows the source until the next call, so nothing is copied.

pub mod clock;
pub mod dump;
pub mod interruptible;
pub mod record;
pub mod sidecar;
pub mod stamped;
pub mod stoppable;

use crate::frame::Frame;

/// What a source knows about a frame besides its pixels.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrameMeta {
    /// 0-based index of the frame as delivered by this source.
    pub index: u64,
    /// The driver's sequence number; differs from `index` when frames were dropped upstream.
    pub sequence: u64,
    /// Frames lost just before this one, as told by the sequence numbers.
    pub dropped: u64,
    /// Time of the end of the exposure, in microseconds since the first frame.
    pub timestamp_us: u64,
    /// The same moment on the host's monotonic clock ([`clock::monotonic_now_us`]), which the
    /// serial link's writer reads to tell the robot how old a position is: the driver's
    /// timestamp for a camera; for a file or a pipe, whose capture time the host cannot know,
    /// the moment the frame had been read.
    pub monotonic_us: u64,
}

/// A stream of frames that lends each one out until the next call.
pub trait FrameSource {
    /// The error a source reports; it says what went wrong in one line.
    type Error: std::error::Error + Send + Sync + 'static;

    /// The next frame, or `Ok(None)` at a clean end of the stream.
    fn next_frame(&mut self) -> Result<Option<(Frame<'_>, FrameMeta)>, Self::Error>;
}

#[cfg(feature = "v4l2")]
pub mod v4l2;
