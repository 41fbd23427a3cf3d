//! A sink whose failure must not stop the run: in `glint run` the JSON lines are a side output
//! (a file on a full disk, a reader that went away), while the serial link keeps the robot fed.
//! The first error is logged with its cause and the sink is dropped; tracking goes on.

use core::fmt;
use std::io;

use super::Sink;
use crate::frame::Frame;
use crate::report::FrameReport;

/// `inner` until its first error, then nothing.
pub struct BestEffort<S> {
    name: &'static str,
    inner: Option<S>,
}

impl<S: Sink> BestEffort<S> {
    /// Wraps `inner`, called `name` in the log.
    pub fn new(name: &'static str, inner: S) -> Self {
        BestEffort {
            name,
            inner: Some(inner),
        }
    }

    fn give_up(&mut self, e: &io::Error) {
        log::error!("{}: {e}; tracking goes on without it", self.name);
        self.inner = None;
    }
}

impl<S: Sink> Sink for BestEffort<S> {
    fn write(&mut self, report: &FrameReport) -> io::Result<()> {
        if let Some(Err(e)) = self.inner.as_mut().map(|s| s.write(report)) {
            self.give_up(&e);
        }
        Ok(())
    }

    fn write_frame(&mut self, frame: &Frame<'_>, report: &FrameReport) -> io::Result<()> {
        if let Some(Err(e)) = self.inner.as_mut().map(|s| s.write_frame(frame, report)) {
            self.give_up(&e);
        }
        Ok(())
    }

    fn finish(&mut self) -> io::Result<()> {
        if let Some(Err(e)) = self.inner.as_mut().map(Sink::finish) {
            self.give_up(&e);
        }
        Ok(())
    }

    fn status(&self, out: &mut fmt::Formatter<'_>) -> fmt::Result {
        match &self.inner {
            Some(sink) => sink.status(out),
            None => write!(out, ", {} failed", self.name),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::FrameSize;
    use crate::pipeline::{self, Pipeline, PipelineConfig};
    use crate::sink::JsonLinesSink;
    use crate::source::dump::DumpSource;

    /// Accepts `room` bytes, then fails like a full disk.
    struct Full {
        room: usize,
        taken: usize,
    }

    impl io::Write for Full {
        fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
            if self.taken + buf.len() > self.room {
                return Err(io::Error::other("disk full"));
            }
            self.taken += buf.len();
            Ok(buf.len())
        }
        fn flush(&mut self) -> io::Result<()> {
            Ok(())
        }
    }

    #[test]
    fn a_failing_sink_does_not_end_the_run() {
        let size = FrameSize::new(8, 4).unwrap();
        let bytes = vec![0u8; size.frame_bytes() * 6];
        let mut source = DumpSource::new(&bytes[..], size, 30.0);
        let mut pipeline = Pipeline::new(size, PipelineConfig::default()).unwrap();
        // Room for about two lines, written one by one (live).
        let full = Full {
            room: 200,
            taken: 0,
        };
        let mut sink = BestEffort::new("jsonl", JsonLinesSink::new(full, true));
        let (summary, result) = pipeline::run(&mut source, &mut pipeline, &mut sink);
        assert!(result.is_ok());
        assert_eq!(summary.frames, 6, "every frame was processed");
        assert!(sink.inner.is_none(), "the failing sink was dropped");
        // Without the wrapper the same output ends the run early.
        let mut source = DumpSource::new(&bytes[..], size, 30.0);
        let full = Full {
            room: 200,
            taken: 0,
        };
        let (summary, result) = pipeline::run(
            &mut source,
            &mut pipeline,
            &mut JsonLinesSink::new(full, true),
        );
        assert!(result.is_err());
        assert!(summary.frames < 6);
    }
}
