//! Recording frames as a raw dump plus the timing for its [sidecar](super::sidecar).
//!
//! Rows are written without the driver's padding, so the dump has exactly the layout that
//! [`DumpSource`](super::dump::DumpSource) replays, whatever stride the camera used. The
//! timing list is reserved for the whole recording up front: recording a frame writes into the
//! caller's buffered writer and allocates nothing.

use core::fmt;
use std::collections::TryReserveError;
use std::io::{self, Write};

use super::sidecar::FrameTiming;
use super::FrameMeta;
use crate::frame::{Frame, FrameSize};

/// Why a frame could not be recorded.
#[derive(Debug)]
pub enum RecordError {
    /// Writing the dump failed (a full disk, a closed pipe).
    Io(io::Error),
    /// The timing of that many frames does not fit in memory.
    Memory {
        frames: usize,
        source: TryReserveError,
    },
    /// A frame of another size than the recording's.
    SizeChanged { expected: FrameSize, got: FrameSize },
    /// More frames than the recording was set up for.
    Full { frames: usize },
}

impl fmt::Display for RecordError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            RecordError::Io(e) => write!(f, "writing the dump: {e}"),
            RecordError::Memory { frames, source } => {
                write!(f, "cannot keep the timing of {frames} frames: {source}")
            }
            RecordError::SizeChanged { expected, got } => {
                write!(f, "a {got} frame in a recording of {expected} frames")
            }
            RecordError::Full { frames } => {
                write!(f, "the recording was set up for {frames} frames")
            }
        }
    }
}

// The messages include their cause's text, so no cause is given as a source as well.
impl std::error::Error for RecordError {}

/// Writes frames of one size to `out`, unpadded, and keeps their timing.
pub struct DumpRecorder<W: Write> {
    out: W,
    size: FrameSize,
    timings: Vec<FrameTiming>,
    capacity: usize,
}

impl<W: Write> DumpRecorder<W> {
    /// A recorder of at most `frames` frames of `size`.
    pub fn new(out: W, size: FrameSize, frames: usize) -> Result<Self, RecordError> {
        let mut timings = Vec::new();
        timings
            .try_reserve_exact(frames)
            .map_err(|source| RecordError::Memory { frames, source })?;
        Ok(DumpRecorder {
            out,
            size,
            timings,
            capacity: frames,
        })
    }

    /// Frames recorded so far.
    pub fn frames(&self) -> usize {
        self.timings.len()
    }

    /// Appends one frame, row by row without padding, and notes its sequence and time.
    pub fn record(&mut self, frame: &Frame<'_>, meta: &FrameMeta) -> Result<(), RecordError> {
        if frame.size() != self.size {
            return Err(RecordError::SizeChanged {
                expected: self.size,
                got: frame.size(),
            });
        }
        if self.timings.len() >= self.capacity {
            return Err(RecordError::Full {
                frames: self.capacity,
            });
        }
        for row in frame.rows() {
            self.out.write_all(row).map_err(RecordError::Io)?;
        }
        self.timings.push(FrameTiming {
            seq: meta.sequence,
            t_us: meta.timestamp_us,
        });
        Ok(())
    }

    /// Flushes the dump and hands back the writer and the frames' timing.
    pub fn finish(mut self) -> Result<(W, Vec<FrameTiming>), RecordError> {
        self.out.flush().map_err(RecordError::Io)?;
        Ok((self.out, self.timings))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn meta(index: u64, sequence: u64, timestamp_us: u64) -> FrameMeta {
        FrameMeta {
            index,
            sequence,
            dropped: 0,
            timestamp_us,
            monotonic_us: timestamp_us,
        }
    }

    #[test]
    fn padded_rows_are_written_unpadded_with_their_timing() {
        let size = FrameSize::new(2, 2).unwrap();
        // Stride 6: two bytes of padding after each 4-byte row.
        let a = [1, 2, 3, 4, 0xEE, 0xEE, 5, 6, 7, 8, 0xEE, 0xEE];
        let b = [9, 10, 11, 12, 0xEE, 0xEE, 13, 14, 15, 16];
        let mut recorder = DumpRecorder::new(Vec::new(), size, 2).unwrap();
        for (bytes, m) in [(&a[..], meta(0, 7, 0)), (&b[..], meta(1, 9, 66_000))] {
            let frame = Frame::new_checked(bytes, size, 6).unwrap();
            recorder.record(&frame, &m).unwrap();
        }
        assert_eq!(recorder.frames(), 2);
        let (dump, timings) = recorder.finish().unwrap();
        assert_eq!(dump, (1..=16).collect::<Vec<u8>>());
        assert_eq!(
            timings,
            vec![
                FrameTiming { seq: 7, t_us: 0 },
                FrameTiming {
                    seq: 9,
                    t_us: 66_000
                }
            ]
        );
    }

    #[test]
    fn frames_of_another_size_or_past_the_capacity_are_refused() {
        let size = FrameSize::new(2, 1).unwrap();
        let mut recorder = DumpRecorder::new(Vec::new(), size, 1).unwrap();
        let bytes = [0u8; 8];
        let wide = Frame::new_checked(&bytes, FrameSize::new(4, 1).unwrap(), 8).unwrap();
        assert!(matches!(
            recorder.record(&wide, &meta(0, 0, 0)),
            Err(RecordError::SizeChanged { .. })
        ));
        let frame = Frame::new_checked(&bytes, size, 4).unwrap();
        recorder.record(&frame, &meta(0, 0, 0)).unwrap();
        assert!(matches!(
            recorder.record(&frame, &meta(1, 1, 10)),
            Err(RecordError::Full { frames: 1 })
        ));
        assert_eq!(recorder.finish().unwrap().0.len(), 4);
    }
}
