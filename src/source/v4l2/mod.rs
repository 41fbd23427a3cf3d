//! Live capture from V4L2 cameras: YUYV, UYVY or GREY frames read in place from the driver's
//! mmap buffers.
//!
//! [`V4l2Source`] negotiates the asked pixel format at a size and frame rate ([`negotiate`]), sets camera controls
//! ([`controls`]), and streams through a ring of mmap buffers ([`stream`]): each frame it lends
//! out borrows the dequeued driver buffer itself, trimmed to the driver's `bytesused` and laid
//! out with the driver's row stride. Nothing is copied or allocated per frame. Frame times are
//! the driver's monotonic buffer timestamps and drops come from its sequence numbers
//! ([`timeline`]). Device faults (unplugged, I/O error, stalled stream) come back as typed
//! errors; [`ReopeningSource`] turns them into a logged pause and resumes when the camera
//! returns. [`devices`] lists cameras for `glint devices`.
//!
//! The `v4l` crate provides the ioctl layer and the kernel bindings; its higher-level calls that
//! can panic on unexpected driver replies (see the `sys` module) are replaced by small local ones.

pub mod controls;
pub mod devices;
pub mod negotiate;
mod reopen;
pub mod stream;
mod sys;
pub mod timeline;

use core::fmt;
use std::io;
use std::path::{Path, PathBuf};
use std::time::Duration;

use v4l::v4l_sys::{
    V4L2_BUF_FLAG_ERROR, V4L2_BUF_FLAG_TIMESTAMP_MASK, V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC,
};
use v4l::Device;

pub use controls::{ControlReport, ControlRequest, NamedControl, PowerLine};
pub use negotiate::{Negotiated, NegotiationError, Offer};
pub use reopen::{Backoff, ReopeningSource};

use crate::frame::{Frame, FrameError, FrameSize, PixelFormat};
use crate::source::{FrameMeta, FrameSource};
use stream::{MmapStream, WaitError};
use timeline::Timeline;

/// Buffers in the ring unless told otherwise: one being read, one being filled, two spare so a
/// slow frame does not make the driver drop the next.
pub const DEFAULT_BUFFER_COUNT: u32 = 4;

/// No frame for this long means the stream has stalled. Webcams drop to a few fps in the dark,
/// so this is well above the longest normal frame interval.
pub const DEFAULT_STALL_TIMEOUT: Duration = Duration::from_secs(2);

/// After this many corrupt buffers in a row the stream is reported broken instead of skipped.
const MAX_CONSECUTIVE_BAD_BUFFERS: u32 = 30;

/// How to open a camera.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CaptureConfig {
    pub path: PathBuf,
    pub size: FrameSize,
    /// Pixel format to ask for (YUYV unless said otherwise).
    pub format: PixelFormat,
    /// Frame rate to ask for; `None` keeps the camera's current one.
    pub fps: Option<u32>,
    /// mmap buffers to ask the driver for (it may grant a different number).
    pub buffer_count: u32,
    /// How long to wait for a frame before reporting [`V4l2Error::Stalled`].
    pub stall_timeout: Duration,
}

impl CaptureConfig {
    /// A configuration with the default buffer count and stall timeout.
    pub fn new(path: impl Into<PathBuf>, size: FrameSize, fps: Option<u32>) -> Self {
        CaptureConfig {
            path: path.into(),
            size,
            format: PixelFormat::Yuyv,
            fps,
            buffer_count: DEFAULT_BUFFER_COUNT,
            stall_timeout: DEFAULT_STALL_TIMEOUT,
        }
    }
}

/// What went wrong with a camera.
#[derive(Debug)]
pub enum V4l2Error {
    /// The path cannot name a device (it contains a NUL byte).
    BadPath(PathBuf),
    /// The device node could not be opened.
    Open { path: PathBuf, source: io::Error },
    /// The node is not a video capture device (for example a metadata or output node).
    NotCapture { path: PathBuf, card: String },
    /// The camera cannot deliver the requested format; the message lists what it offers.
    Negotiation {
        path: PathBuf,
        source: NegotiationError,
    },
    /// The device went away (ENODEV): unplugged, or its driver unbound.
    Disconnected { path: PathBuf },
    /// An ioctl or mapping failed (EIO and the like).
    Io {
        path: PathBuf,
        op: &'static str,
        source: io::Error,
    },
    /// No frame arrived within the stall timeout.
    Stalled { path: PathBuf, timeout: Duration },
    /// A signal interrupted the wait for a frame; the stream is intact.
    Interrupted,
    /// The driver keeps returning buffers too short for the frame or flagged corrupt.
    BadBuffers {
        path: PathBuf,
        source: Option<FrameError>,
    },
}

impl V4l2Error {
    /// Whether this is a fault of the device that reopening it may cure.
    pub fn is_device_fault(&self) -> bool {
        matches!(
            self,
            V4l2Error::Open { .. }
                | V4l2Error::Disconnected { .. }
                | V4l2Error::Io { .. }
                | V4l2Error::Stalled { .. }
                | V4l2Error::BadBuffers { .. }
                | V4l2Error::NotCapture { .. }
                | V4l2Error::Negotiation { .. }
        )
    }

    fn io(path: &Path, op: &'static str, source: io::Error) -> Self {
        if source.raw_os_error() == Some(libc::ENODEV) {
            V4l2Error::Disconnected {
                path: path.to_path_buf(),
            }
        } else {
            V4l2Error::Io {
                path: path.to_path_buf(),
                op,
                source,
            }
        }
    }

    fn from_wait(path: &Path, timeout: Duration, e: WaitError) -> Self {
        match e {
            WaitError::TimedOut => V4l2Error::Stalled {
                path: path.to_path_buf(),
                timeout,
            },
            WaitError::Interrupted => V4l2Error::Interrupted,
            WaitError::Driver(op, source) => V4l2Error::io(path, op, source),
        }
    }
}

impl fmt::Display for V4l2Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            V4l2Error::BadPath(p) => write!(f, "{} is not a usable device path", p.display()),
            V4l2Error::Open { path, source } => {
                write!(f, "cannot open {}: {source}", path.display())
            }
            V4l2Error::NotCapture { path, card } => write!(
                f,
                "{} ({card}) is not a video capture device",
                path.display()
            ),
            V4l2Error::Negotiation { path, source } => write!(f, "{}: {source}", path.display()),
            V4l2Error::Disconnected { path } => {
                write!(
                    f,
                    "{} disappeared (unplugged or driver unbound)",
                    path.display()
                )
            }
            V4l2Error::Io { path, op, source } => {
                write!(f, "{}: {op} failed: {source}", path.display())
            }
            V4l2Error::Stalled { path, timeout } => write!(
                f,
                "{}: no frame for {} ms, the stream has stalled",
                path.display(),
                timeout.as_millis()
            ),
            V4l2Error::Interrupted => write!(f, "interrupted while waiting for a frame"),
            V4l2Error::BadBuffers { path, source } => {
                write!(
                    f,
                    "{}: the driver keeps returning corrupt buffers",
                    path.display()
                )?;
                match source {
                    Some(e) => write!(f, " ({e})"),
                    None => Ok(()),
                }
            }
        }
    }
}

// The messages include their cause's text, so no cause is given as a source as well: an
// error chain printed whole (`{:#}`) would say it twice ("No such file or directory: No such
// file or directory").
impl std::error::Error for V4l2Error {}

/// The driver's account of one dequeued frame, before it is placed on the session's timeline.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RawMeta {
    /// The driver's 32-bit frame counter.
    pub driver_sequence: u32,
    /// When the frame was captured, on the monotonic clock, in microseconds.
    pub monotonic_us: u64,
    /// Bytes of the buffer that hold the frame.
    pub bytes_used: usize,
}

/// A camera streaming YUYV frames from mmap buffers.
pub struct V4l2Source {
    // Field order is drop order: the stream (STREAMOFF, unmap) goes before the device's file.
    stream: MmapStream,
    device: Device,
    config: CaptureConfig,
    negotiated: Negotiated,
    /// Bytes a buffer must hold for a whole frame at the negotiated stride.
    frame_bytes: usize,
    stall_timeout_ms: i32,
    timeline: Timeline,
}

impl fmt::Debug for V4l2Source {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("V4l2Source")
            .field("config", &self.config)
            .field("negotiated", &self.negotiated)
            .field("buffers", &self.stream.buffer_count())
            .finish()
    }
}

impl V4l2Source {
    /// Opens `path`, negotiates YUYV at `size` (and `fps` when given) and starts streaming
    /// with `buffer_count` mmap buffers.
    pub fn open(
        path: impl AsRef<Path>,
        size: FrameSize,
        fps: Option<u32>,
        buffer_count: u32,
    ) -> Result<Self, V4l2Error> {
        let mut config = CaptureConfig::new(path.as_ref(), size, fps);
        config.buffer_count = buffer_count;
        Self::open_with(&config)
    }

    /// Opens a camera as `config` says.
    pub fn open_with(config: &CaptureConfig) -> Result<Self, V4l2Error> {
        let path = config.path.as_path();
        let device = open_device(path)?;
        let fd = device.handle().fd();
        let caps =
            sys::query_capability(fd).map_err(|e| V4l2Error::io(path, "VIDIOC_QUERYCAP", e))?;
        if !caps.is_video_capture() {
            return Err(V4l2Error::NotCapture {
                path: path.to_path_buf(),
                card: caps.card,
            });
        }
        let negotiated = negotiate::negotiate(&device, config.size, config.fps, config.format)
            .map_err(|source| match source {
                NegotiationError::Io(op, e) => V4l2Error::io(path, op, e),
                source => V4l2Error::Negotiation {
                    path: path.to_path_buf(),
                    source,
                },
            })?;
        let stream = MmapStream::start(fd, config.buffer_count.max(1))
            .map_err(|e| V4l2Error::from_wait(path, config.stall_timeout, e))?;
        let frame_bytes = negotiated.stride_bytes * (negotiated.size.height() - 1)
            + negotiated.size.row_bytes_as(negotiated.format);
        Ok(V4l2Source {
            stream,
            device,
            config: config.clone(),
            negotiated,
            frame_bytes,
            stall_timeout_ms: i32::try_from(config.stall_timeout.as_millis()).unwrap_or(i32::MAX),
            timeline: Timeline::new(),
        })
    }

    /// The format agreed with the camera.
    pub fn negotiated(&self) -> &Negotiated {
        &self.negotiated
    }

    /// How many mmap buffers the driver granted.
    pub fn buffer_count(&self) -> usize {
        self.stream.buffer_count()
    }

    /// The configuration this source was opened with.
    pub fn config(&self) -> &CaptureConfig {
        &self.config
    }

    /// Sets camera controls and reports which the camera took.
    pub fn apply_controls(&self, request: &ControlRequest) -> ControlReport {
        controls::apply_controls(self.device.handle().fd(), request)
    }

    /// Waits for the next good frame and returns the driver's account of it. Buffers flagged
    /// corrupt or too short are handed straight back; the gap shows up as dropped frames.
    pub fn next_raw(&mut self) -> Result<RawMeta, V4l2Error> {
        let mut bad = 0u32;
        loop {
            let done = self.stream.dequeue(self.stall_timeout_ms).map_err(|e| {
                V4l2Error::from_wait(&self.config.path, self.config.stall_timeout, e)
            })?;
            let bytes_used = done.bytes_used as usize;
            if done.flags & V4L2_BUF_FLAG_ERROR != 0 || bytes_used < self.frame_bytes {
                bad += 1;
                log::debug!(
                    "{}: skipping buffer {} (flags {:#x}, {bytes_used} of {} bytes)",
                    self.config.path.display(),
                    done.sequence,
                    done.flags,
                    self.frame_bytes
                );
                if bad >= MAX_CONSECUTIVE_BAD_BUFFERS {
                    return Err(V4l2Error::BadBuffers {
                        path: self.config.path.clone(),
                        source: None,
                    });
                }
                continue;
            }
            let monotonic_us =
                if done.flags & V4L2_BUF_FLAG_TIMESTAMP_MASK == V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC {
                    sys::timeval_us(done.timestamp_sec, done.timestamp_usec)
                } else {
                    sys::monotonic_now_us()
                };
            return Ok(RawMeta {
                driver_sequence: done.sequence,
                monotonic_us,
                bytes_used,
            });
        }
    }

    /// The frame [`next_raw`](Self::next_raw) dequeued, read in place.
    pub fn current_frame(&self, raw: &RawMeta) -> Result<Frame<'_>, V4l2Error> {
        let bad = |source| V4l2Error::BadBuffers {
            path: self.config.path.clone(),
            source,
        };
        let bytes = self
            .stream
            .held_bytes()
            .and_then(|b| b.get(..raw.bytes_used))
            .ok_or_else(|| bad(None))?;
        let n = &self.negotiated;
        Frame::new_checked_as(bytes, n.size, n.stride_bytes, n.format).map_err(|e| bad(Some(e)))
    }
}

impl FrameSource for V4l2Source {
    type Error = V4l2Error;

    fn next_frame(&mut self) -> Result<Option<(Frame<'_>, FrameMeta)>, V4l2Error> {
        let raw = self.next_raw()?;
        let meta = self
            .timeline
            .on_frame(raw.driver_sequence, raw.monotonic_us);
        Ok(Some((self.current_frame(&raw)?, meta)))
    }
}

/// Opens a device node, refusing paths `v4l` would panic on.
fn open_device(path: &Path) -> Result<Device, V4l2Error> {
    use std::os::unix::ffi::OsStrExt;
    if path.as_os_str().as_bytes().contains(&0) {
        return Err(V4l2Error::BadPath(path.to_path_buf()));
    }
    Device::with_path(path).map_err(|source| V4l2Error::Open {
        path: path.to_path_buf(),
        source,
    })
}
