//! Stamped frames on a stream (`--input - --stamped`): each raw frame is preceded by its capture
//! time, the end of its exposure on the host's monotonic clock (`CLOCK_MONOTONIC`, µs, u64
//! little-endian), as a camera driver stamps its buffers.
//!
//! A pipe's frames otherwise get the moment they were read as their capture time, so the time
//! between the exposure and the read (a camera's sensor readout, USB transfer, driver
//! buffering, 30 to 100 ms for a USB webcam) is missing from every position's age. A grabber
//! that knows when each frame was exposed (the robot-in-the-loop rig of `tools/src/rig`, a
//! gstreamer pipeline passing the driver's timestamps on) writes them with the frames, and the
//! ages glint sends count from the exposure, as with `--device`.
//!
//! Every stamp is checked: one from the future (another clock) or earlier than the one before
//! is refused with a message, never turned into a negative or wrapped age.

use core::fmt;
use std::io::{self, Read};

use super::clock::monotonic_now_us;
use super::dump::{DumpError, DumpSource};
use super::{FrameMeta, FrameSource};
use crate::frame::Frame;

/// Bytes of the stamp before each frame.
pub const STAMP_BYTES: usize = 8;

/// Why stamped frames could not be read.
#[derive(Debug)]
pub enum StampedError {
    /// Reading a frame failed.
    Dump(DumpError),
    /// Reading a stamp failed.
    Io(io::Error),
    /// The stream ended inside the stamp of frame `frame_index`.
    TruncatedStamp { frame_index: u64, bytes: usize },
    /// The stream ended after a stamp, before its frame.
    MissingFrame { frame_index: u64 },
    /// A stamp lies after the moment it was read: not the monotonic clock of this host.
    Future {
        frame_index: u64,
        stamp_us: u64,
        now_us: u64,
    },
    /// A stamp earlier than the previous frame's.
    Backwards {
        frame_index: u64,
        stamp_us: u64,
        previous_us: u64,
    },
}

impl fmt::Display for StampedError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            StampedError::Dump(e) => write!(f, "{e}"),
            StampedError::Io(e) => write!(f, "reading input: {e}"),
            StampedError::TruncatedStamp { frame_index, bytes } => write!(
                f,
                "input ends inside the stamp of frame {frame_index}: {bytes} of {STAMP_BYTES} bytes"
            ),
            StampedError::MissingFrame { frame_index } => {
                write!(
                    f,
                    "input ends after the stamp of frame {frame_index}, before its frame"
                )
            }
            StampedError::Future {
                frame_index,
                stamp_us,
                now_us,
            } => write!(
                f,
                "frame {frame_index} is stamped {stamp_us} µs, {} µs after it was read: --stamped \
                 takes the host's monotonic clock (CLOCK_MONOTONIC), in µs",
                stamp_us - now_us
            ),
            StampedError::Backwards {
                frame_index,
                stamp_us,
                previous_us,
            } => write!(
                f,
                "frame {frame_index} is stamped {stamp_us} µs, before the frame ahead of it \
                 ({previous_us} µs)"
            ),
        }
    }
}

impl std::error::Error for StampedError {}

/// Frames of a raw dump, each after its stamp.
pub struct StampedSource<R> {
    dump: DumpSource<R>,
    first_us: Option<u64>,
    previous_us: Option<u64>,
    next_index: u64,
}

impl<R: Read> StampedSource<R> {
    /// Reads stamped frames through `dump` (whose nominal frame rate is not used).
    pub fn new(dump: DumpSource<R>) -> Self {
        StampedSource {
            dump,
            first_us: None,
            previous_us: None,
            next_index: 0,
        }
    }

    /// The next stamp, or `None` at a clean end of the stream.
    fn read_stamp(&mut self) -> Result<Option<u64>, StampedError> {
        let mut stamp = [0u8; STAMP_BYTES];
        let mut filled = 0;
        while filled < STAMP_BYTES {
            let Some(rest) = stamp.get_mut(filled..) else {
                break;
            };
            match self.dump.reader_mut().read(rest) {
                Ok(0) => break,
                Ok(n) => filled += n,
                Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
                Err(e) => return Err(StampedError::Io(e)),
            }
        }
        match filled {
            0 => Ok(None),
            STAMP_BYTES => Ok(Some(u64::from_le_bytes(stamp))),
            bytes => Err(StampedError::TruncatedStamp {
                frame_index: self.next_index,
                bytes,
            }),
        }
    }
}

impl<R: Read> FrameSource for StampedSource<R> {
    type Error = StampedError;

    fn next_frame(&mut self) -> Result<Option<(Frame<'_>, FrameMeta)>, StampedError> {
        let frame_index = self.next_index;
        let Some(stamp_us) = self.read_stamp()? else {
            if frame_index == 0 {
                return Err(StampedError::Dump(DumpError::Empty));
            }
            return Ok(None);
        };
        let now_us = monotonic_now_us();
        if stamp_us > now_us {
            return Err(StampedError::Future {
                frame_index,
                stamp_us,
                now_us,
            });
        }
        if let Some(previous_us) = self.previous_us.filter(|&p| stamp_us < p) {
            return Err(StampedError::Backwards {
                frame_index,
                stamp_us,
                previous_us,
            });
        }
        let first_us = *self.first_us.get_or_insert(stamp_us);
        self.previous_us = Some(stamp_us);
        self.next_index += 1;
        let (frame, meta) = match self.dump.next_frame() {
            Ok(Some(next)) => next,
            Ok(None) | Err(DumpError::Empty) => {
                return Err(StampedError::MissingFrame { frame_index })
            }
            Err(e) => return Err(StampedError::Dump(e)),
        };
        let meta = FrameMeta {
            // The driver's timestamps since the first frame, as a camera's.
            timestamp_us: stamp_us - first_us,
            monotonic_us: stamp_us,
            ..meta
        };
        Ok(Some((frame, meta)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::FrameSize;

    fn stream(stamps: &[u64], frame_bytes: usize) -> Vec<u8> {
        let mut out = Vec::new();
        for (i, s) in stamps.iter().enumerate() {
            out.extend_from_slice(&s.to_le_bytes());
            out.extend(std::iter::repeat_n(i as u8, frame_bytes));
        }
        out
    }

    fn source(bytes: &[u8]) -> StampedSource<&[u8]> {
        let size = FrameSize::new(2, 1).unwrap();
        StampedSource::new(DumpSource::new(bytes, size, 30.0))
    }

    #[test]
    fn each_frame_takes_its_stamp_as_its_capture_time() {
        let now = monotonic_now_us();
        let stamps = [now - 70_000, now - 36_000, now - 3_000];
        let bytes = stream(&stamps, 4);
        let mut s = source(&bytes);
        for (i, &stamp) in stamps.iter().enumerate() {
            let (frame, meta) = s.next_frame().unwrap().unwrap();
            assert_eq!(frame.luma(0, 0), Some(i as u8));
            assert_eq!(meta.index, i as u64);
            assert_eq!(meta.monotonic_us, stamp);
            assert_eq!(meta.timestamp_us, stamp - stamps[0]);
        }
        assert!(s.next_frame().unwrap().is_none());
    }

    #[test]
    fn hostile_stamps_and_truncations_are_refused_with_a_message() {
        let now = monotonic_now_us();
        let future = stream(&[now + 10_000_000], 4);
        let e = source(&future).next_frame().err().unwrap();
        assert!(e.to_string().contains("CLOCK_MONOTONIC"), "{e}");

        let backwards = stream(&[now - 1_000, now - 2_000], 4);
        let mut s = source(&backwards);
        assert!(s.next_frame().is_ok());
        let e = s.next_frame().err().unwrap();
        assert!(
            matches!(e, StampedError::Backwards { frame_index: 1, .. }),
            "{e}"
        );

        let mut half_stamp = stream(&[now - 1_000], 4);
        half_stamp.extend_from_slice(&[1, 2, 3]);
        let mut s = source(&half_stamp);
        assert!(s.next_frame().is_ok());
        let e = s.next_frame().err().unwrap();
        assert!(e.to_string().contains("3 of 8 bytes"), "{e}");

        let only_stamp = (now - 1_000).to_le_bytes();
        let e = source(&only_stamp).next_frame().err().unwrap();
        assert!(
            matches!(e, StampedError::MissingFrame { frame_index: 0 }),
            "{e}"
        );

        let mut short_frame = stream(&[now - 1_000], 4);
        short_frame.pop();
        let e = source(&short_frame).next_frame().err().unwrap();
        assert!(e.to_string().contains("inside frame 0"), "{e}");

        assert!(matches!(
            source(&[]).next_frame(),
            Err(StampedError::Dump(DumpError::Empty))
        ));
    }
}
