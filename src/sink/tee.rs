//! Two sinks fed the same reports: the usual output on standard output and the serial link.

use core::fmt;
use std::io;

use super::Sink;
use crate::frame::Frame;
use crate::report::FrameReport;

/// Forwards every report to `first`, then to `second`.
#[derive(Debug)]
pub struct Tee<A, B> {
    first: A,
    second: B,
}

impl<A: Sink, B: Sink> Tee<A, B> {
    /// Feeds `first` and `second`.
    pub fn new(first: A, second: B) -> Self {
        Tee { first, second }
    }

    /// The two sinks again, for a caller that needs one of them by itself.
    pub fn into_parts(self) -> (A, B) {
        (self.first, self.second)
    }
}

impl<A: Sink, B: Sink> Sink for Tee<A, B> {
    fn write(&mut self, report: &FrameReport) -> io::Result<()> {
        self.first.write(report)?;
        self.second.write(report)
    }

    fn write_frame(&mut self, frame: &Frame<'_>, report: &FrameReport) -> io::Result<()> {
        self.first.write_frame(frame, report)?;
        self.second.write_frame(frame, report)
    }

    /// Finishes both, even when the first fails, and reports the first error.
    fn finish(&mut self) -> io::Result<()> {
        let first = self.first.finish();
        let second = self.second.finish();
        first.and(second)
    }

    fn status(&self, out: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.first.status(out)?;
        self.second.status(out)
    }
}

/// An optional sink: `None` takes reports and does nothing, so an output that is switched on by
/// a flag (`--serial`) needs no second code path.
impl<S: Sink> Sink for Option<S> {
    fn write(&mut self, report: &FrameReport) -> io::Result<()> {
        match self {
            Some(sink) => sink.write(report),
            None => Ok(()),
        }
    }

    fn write_frame(&mut self, frame: &Frame<'_>, report: &FrameReport) -> io::Result<()> {
        match self {
            Some(sink) => sink.write_frame(frame, report),
            None => Ok(()),
        }
    }

    fn finish(&mut self) -> io::Result<()> {
        match self {
            Some(sink) => sink.finish(),
            None => Ok(()),
        }
    }

    fn status(&self, out: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Some(sink) => sink.status(out),
            None => Ok(()),
        }
    }
}
