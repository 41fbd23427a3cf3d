//! Raw YUYV dumps: frames back to back with no header, as `v4l2-ctl --stream-to=FILE` and
//! `ffmpeg -f rawvideo -pix_fmt yuyv422` write them, from a file or standard input.
//!
//! One frame buffer is allocated when the source opens and every frame is read into it. A
//! stream that ends inside a frame is an error that says how many bytes were left over, after
//! the whole frames before it were delivered.

use core::fmt;
use std::io::{self, Read};

use super::clock::monotonic_now_us;
use super::{FrameMeta, FrameSource};
use crate::frame::{Frame, FrameError, FrameSize, PixelFormat};

/// Microseconds per second.
const US_PER_S: f64 = 1e6;

/// Why a dump could not be read.
#[derive(Debug)]
pub enum DumpError {
    /// The stream ended before its first byte: an empty file or standard input, which is
    /// almost always a mistake upstream (a wrong path, a capture that never started).
    Empty,
    /// The stream ended inside frame `frame_index`.
    Truncated {
        frame_index: u64,
        trailing_bytes: usize,
        frame_bytes: usize,
    },
    /// Reading failed.
    Io(io::Error),
    /// The frame buffer does not fit in memory.
    Memory { frame_bytes: usize },
    /// The buffer is not a frame of the stated size (cannot happen for an unpadded dump; kept
    /// so a bug shows up as a message, not a panic).
    Frame(FrameError),
}

impl fmt::Display for DumpError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            DumpError::Empty => write!(f, "no frames: the input is empty"),
            DumpError::Truncated {
                frame_index,
                trailing_bytes,
                frame_bytes,
            } => write!(
                f,
                "input ends inside frame {frame_index}: {trailing_bytes} trailing bytes of a \
                 {frame_bytes}-byte frame (is --size right?)"
            ),
            DumpError::Io(e) => write!(f, "reading input: {e}"),
            DumpError::Memory { frame_bytes } => {
                write!(f, "cannot allocate a frame buffer of {frame_bytes} bytes")
            }
            DumpError::Frame(e) => write!(f, "{e}"),
        }
    }
}

impl std::error::Error for DumpError {}

/// Frames from a reader of a raw dump, at a nominal frame rate.
pub struct DumpSource<R> {
    reader: R,
    buffer: Vec<u8>,
    size: FrameSize,
    format: PixelFormat,
    frame_period_us: f64,
    next_index: u64,
    finished: bool,
}

impl<R: Read> DumpSource<R> {
    /// A source of `size` YUYV frames at `fps` frames per second (for timestamps only). Aborts
    /// like `vec!` if the frame buffer does not fit in memory; [`DumpSource::try_new`] says so
    /// instead.
    pub fn new(reader: R, size: FrameSize, fps: f64) -> Self {
        Self::with_format(reader, size, fps, PixelFormat::Yuyv)
    }

    /// A source of unpadded `size` frames of `format` at `fps` frames per second.
    pub fn with_format(reader: R, size: FrameSize, fps: f64, format: PixelFormat) -> Self {
        let buffer = vec![0; size.frame_bytes_as(format)];
        Self::with_buffer(reader, size, fps, format, buffer)
    }

    /// [`DumpSource::new`], with an error instead of an abort when the frame buffer, whose
    /// size comes from the command line, does not fit in memory.
    pub fn try_new(reader: R, size: FrameSize, fps: f64) -> Result<Self, DumpError> {
        Self::try_with_format(reader, size, fps, PixelFormat::Yuyv)
    }

    /// [`DumpSource::with_format`], with an error instead of an abort when the frame buffer
    /// does not fit in memory.
    pub fn try_with_format(
        reader: R,
        size: FrameSize,
        fps: f64,
        format: PixelFormat,
    ) -> Result<Self, DumpError> {
        let frame_bytes = size.frame_bytes_as(format);
        let mut buffer = Vec::new();
        buffer
            .try_reserve_exact(frame_bytes)
            .map_err(|_| DumpError::Memory { frame_bytes })?;
        buffer.resize(frame_bytes, 0);
        Ok(Self::with_buffer(reader, size, fps, format, buffer))
    }

    fn with_buffer(
        reader: R,
        size: FrameSize,
        fps: f64,
        format: PixelFormat,
        buffer: Vec<u8>,
    ) -> Self {
        DumpSource {
            reader,
            buffer,
            size,
            format,
            frame_period_us: US_PER_S / fps,
            next_index: 0,
            finished: false,
        }
    }

    /// The reader, for what a stream carries between its frames (the stamps of
    /// [`StampedSource`](super::stamped::StampedSource)).
    pub fn reader_mut(&mut self) -> &mut R {
        &mut self.reader
    }

    /// Reads until the buffer is full or the stream ends; returns the bytes read.
    fn fill(&mut self) -> io::Result<usize> {
        let mut filled = 0;
        while filled < self.buffer.len() {
            let Some(rest) = self.buffer.get_mut(filled..) else {
                break;
            };
            match self.reader.read(rest) {
                Ok(0) => break,
                Ok(n) => filled += n,
                Err(e) if e.kind() == io::ErrorKind::Interrupted => continue,
                Err(e) => return Err(e),
            }
        }
        Ok(filled)
    }
}

impl<R: Read> FrameSource for DumpSource<R> {
    type Error = DumpError;

    fn next_frame(&mut self) -> Result<Option<(Frame<'_>, FrameMeta)>, DumpError> {
        if self.finished {
            return Ok(None);
        }
        let filled = self.fill().map_err(DumpError::Io)?;
        if filled == 0 {
            self.finished = true;
            if self.next_index == 0 {
                return Err(DumpError::Empty);
            }
            return Ok(None);
        }
        if filled < self.buffer.len() {
            self.finished = true;
            return Err(DumpError::Truncated {
                frame_index: self.next_index,
                trailing_bytes: filled,
                frame_bytes: self.buffer.len(),
            });
        }
        let index = self.next_index;
        self.next_index += 1;
        let meta = FrameMeta {
            index,
            sequence: index,
            dropped: 0,
            timestamp_us: (index as f64 * self.frame_period_us).round() as u64,
            monotonic_us: monotonic_now_us(),
        };
        let stride_bytes = self.size.row_bytes_as(self.format);
        let frame = Frame::new_checked_as(&self.buffer, self.size, stride_bytes, self.format)
            .map_err(DumpError::Frame)?;
        Ok(Some((frame, meta)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn whole_frames_then_the_trailing_bytes() {
        let size = FrameSize::new(2, 1).unwrap();
        let bytes = [1u8, 2, 3, 4, 5, 6, 7, 8, 9];
        let mut source = DumpSource::new(&bytes[..], size, 10.0);
        let (frame, meta) = source.next_frame().unwrap().unwrap();
        assert_eq!(frame.luma(1, 0), Some(3));
        assert_eq!((meta.index, meta.timestamp_us), (0, 0));
        let (frame, meta) = source.next_frame().unwrap().unwrap();
        assert_eq!(frame.luma(0, 0), Some(5));
        assert_eq!(meta.timestamp_us, 100_000);
        match source.next_frame() {
            Err(DumpError::Truncated {
                frame_index: 2,
                trailing_bytes: 1,
                frame_bytes: 4,
            }) => {}
            other => panic!("expected truncation, got {other:?}"),
        }
        assert!(source.next_frame().unwrap().is_none());
    }

    #[test]
    fn an_empty_stream_is_an_error_not_a_quiet_end() {
        let size = FrameSize::new(2, 1).unwrap();
        let mut source = DumpSource::new(&[][..], size, 10.0);
        assert!(matches!(source.next_frame(), Err(DumpError::Empty)));
        assert!(source.next_frame().unwrap().is_none());
    }

    /// A reader that hands out one byte per call, like a slow pipe.
    struct Trickle<'a>(&'a [u8]);

    impl Read for Trickle<'_> {
        fn read(&mut self, buf: &mut [u8]) -> io::Result<usize> {
            match (self.0.split_first(), buf.first_mut()) {
                (Some((&b, rest)), Some(slot)) => {
                    *slot = b;
                    self.0 = rest;
                    Ok(1)
                }
                _ => Ok(0),
            }
        }
    }

    #[test]
    fn short_reads_from_a_pipe_still_make_whole_frames() {
        let size = FrameSize::new(2, 2).unwrap();
        let bytes: Vec<u8> = (0..16).collect();
        let mut source = DumpSource::new(Trickle(&bytes), size, 30.0);
        let mut lumas = vec![];
        while let Some((frame, _)) = source.next_frame().unwrap() {
            lumas.push(frame.luma(0, 1).unwrap());
        }
        assert_eq!(lumas, vec![4, 12]);
    }
}
