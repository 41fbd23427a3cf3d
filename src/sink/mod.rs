//! Where reports go: JSON lines or CSV on a writer (standard output by default).
//!
//! Both formats are written straight into the writer with `write!`, which formats numbers on
//! the stack: no per-frame allocation, and the writer's buffer is allocated once.

mod csv;
mod jsonl;

use std::io;

pub use csv::CsvSink;
pub use jsonl::JsonLinesSink;

use crate::pipeline::FrameReport;

/// A consumer of per-frame reports.
pub trait Sink {
    /// Writes one report.
    fn write(&mut self, report: &FrameReport) -> io::Result<()>;

    /// Flushes whatever is buffered at the end of a run.
    fn finish(&mut self) -> io::Result<()>;
}
