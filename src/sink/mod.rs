//! Where reports go: JSON lines or CSV on a writer (standard output by default), and position
//! packets to the robot over a serial port ([`serial`]) or vision positions to an autopilot
//! ([`mavlink`]), side by side through a [`Tee`], and a
//! live web page for aiming the camera ([`preview`]).
//!
//! Both text formats are written straight into the writer with `write!`, which formats numbers
//! on the stack: no per-frame allocation, and the writer's buffer is allocated once.

mod best_effort;
mod csv;
mod jsonl;
pub mod mavlink;
pub mod predict;
pub mod preview;
pub mod serial;
mod tee;

use core::fmt;
use std::io;

pub use best_effort::BestEffort;
pub use csv::CsvSink;
pub use jsonl::JsonLinesSink;
pub use mavlink::MavlinkSink;
pub use preview::PreviewSink;
pub use serial::SerialSink;
pub use tee::Tee;

use crate::frame::Frame;
use crate::report::FrameReport;

/// A consumer of per-frame reports.
pub trait Sink {
    /// Writes one report.
    fn write(&mut self, report: &FrameReport) -> io::Result<()>;

    /// Writes one report with the frame it came from. Only a sink that looks at the pixels
    /// (the [`preview`]) needs more than the report; the others take the default.
    fn write_frame(&mut self, _frame: &Frame<'_>, report: &FrameReport) -> io::Result<()> {
        self.write(report)
    }

    /// Flushes whatever is buffered at the end of a run.
    fn finish(&mut self) -> io::Result<()>;

    /// Appends this sink's state (say, whether its link is up) to the periodic status line,
    /// as `, name state` clauses; nothing by default.
    fn status(&self, _out: &mut fmt::Formatter<'_>) -> fmt::Result {
        Ok(())
    }
}
