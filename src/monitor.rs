//! Watching a run without changing it: per-frame timings for `--stats`, and for live runs a
//! periodic one-line summary on the log (frames, frame rate, drops, how often the LED was found,
//! the period's latency percentiles per stage, and what the sinks say of their state, such as
//! the serial link being up).
//!
//! [`run`] is [`pipeline::run`] with a timing wrapper around the source and a watching wrapper
//! around the sink (the shape of smoltcp's `phy` tracers around a device), so a camera and a
//! replayed dump go through exactly the same per-frame path. The wrappers read the clock a few
//! times per frame and allocate nothing.

use core::cell::Cell;
use core::fmt;
use std::io;
use std::time::{Duration, Instant};

use crate::frame::Frame;
use crate::pipeline::{self, Pipeline, RunError, RunSummary};
use crate::report::FrameReport;
use crate::sink::Sink;
use crate::source::{FrameMeta, FrameSource};
use crate::stats::{FrameTimes, LatencyStats};

/// Percent per unit, for the found ratio.
const PERCENT: f64 = 100.0;

/// What to watch.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct MonitorConfig {
    /// Keep latency histograms of every stage.
    pub stats: bool,
    /// Log a summary this often (live runs); `None` for none.
    pub summary_every: Option<Duration>,
}

/// Frame counts over some span of a run.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Counts {
    /// Frames processed.
    pub frames: u64,
    /// Frames in which the LED was found.
    pub found: u64,
    /// Frames lost upstream (by the sequence numbers).
    pub dropped: u64,
}

impl Counts {
    fn add(&mut self, report: &FrameReport) {
        self.frames += 1;
        self.found += u64::from(report.position.is_some());
        self.dropped += report.meta.dropped;
    }

    /// Percentage of the frames in which the LED was found (0 without frames).
    pub fn found_percent(&self) -> f64 {
        if self.frames == 0 {
            0.0
        } else {
            self.found as f64 * PERCENT / self.frames as f64
        }
    }
}

/// The watcher of one run: counts, latency histograms and the summary clock.
#[derive(Debug)]
pub struct Monitor {
    stats: Option<LatencyStats>,
    /// The current summary period's latencies (with a periodic summary).
    period_stats: Option<LatencyStats>,
    summary_every: Option<Duration>,
    totals: Counts,
    period: Counts,
    period_started: Option<Instant>,
    /// The latest frame's calibration status, when its markers are re-checked.
    calib: Option<crate::geometry::recheck::CalibStatus>,
}

impl Monitor {
    /// A monitor; the histograms (if asked for) are allocated here, once.
    pub fn new(config: MonitorConfig) -> Self {
        let summary_every = config.summary_every.filter(|d| !d.is_zero());
        Monitor {
            stats: config.stats.then(LatencyStats::new),
            period_stats: summary_every.map(|_| LatencyStats::new()),
            summary_every,
            totals: Counts::default(),
            period: Counts::default(),
            period_started: None,
            calib: None,
        }
    }

    /// Counts since the start of the run.
    pub fn totals(&self) -> Counts {
        self.totals
    }

    /// The latency histograms, when `stats` was asked for.
    pub fn stats(&self) -> Option<&LatencyStats> {
        self.stats.as_ref()
    }

    fn on_frame(
        &mut self,
        report: &FrameReport,
        times: &FrameTimes,
        now: Instant,
        sink: &dyn Sink,
    ) {
        self.totals.add(report);
        self.period.add(report);
        if report.calib.is_some() {
            self.calib = report.calib;
        }
        for stats in [&mut self.stats, &mut self.period_stats]
            .into_iter()
            .flatten()
        {
            stats.record(times);
        }
        let Some(every) = self.summary_every else {
            return;
        };
        let started = *self.period_started.get_or_insert(now);
        let elapsed = now.saturating_duration_since(started);
        if elapsed >= every {
            log::info!(
                "{}",
                Status {
                    monitor: self,
                    elapsed,
                    sink
                }
            );
            self.period = Counts::default();
            self.period_started = Some(now);
            if let Some(stats) = self.period_stats.as_mut() {
                stats.reset();
            }
        }
    }
}

/// The periodic summary: one line, so that journald keeps it as one record.
struct Status<'a> {
    monitor: &'a Monitor,
    elapsed: Duration,
    sink: &'a dyn Sink,
}

impl fmt::Display for Status<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let m = self.monitor;
        let p = &m.period;
        write!(
            f,
            "last {:.1} s: {} frames ({:.1} fps), {} dropped ({} in all), LED found in {:.0} %",
            self.elapsed.as_secs_f64(),
            p.frames,
            p.frames as f64 / self.elapsed.as_secs_f64(),
            p.dropped,
            m.totals.dropped,
            p.found_percent()
        )?;
        if let Some(stats) = &m.period_stats {
            write!(f, ", {}", stats.one_line())?;
        }
        match m.calib {
            Some(c) if c.stale => write!(
                f,
                ", no calibration marker seen for {:.0} s: floor numbers are stale",
                c.age_s
            )?,
            Some(c) => write!(
                f,
                ", calibration confirmed {:.1} s ago ({:.2} px)",
                c.age_s, c.residual_px
            )?,
            None => {}
        }
        self.sink.status(f)
    }
}

/// When the source was asked for the current frame and when it lent it out.
#[derive(Debug, Clone, Copy)]
struct Marks {
    asked: Instant,
    lent: Instant,
}

/// A source that notes when each frame was asked for and lent out.
struct Timed<'a, S> {
    inner: &'a mut S,
    marks: &'a Cell<Marks>,
}

impl<S: FrameSource> FrameSource for Timed<'_, S> {
    type Error = S::Error;

    fn next_frame(&mut self) -> Result<Option<(Frame<'_>, FrameMeta)>, S::Error> {
        let asked = Instant::now();
        let next = self.inner.next_frame();
        self.marks.set(Marks {
            asked,
            lent: Instant::now(),
        });
        next
    }
}

/// A sink that hands each report on, then tells the monitor how long the frame took.
struct Watched<'a, K> {
    inner: &'a mut K,
    marks: &'a Cell<Marks>,
    monitor: &'a mut Monitor,
}

impl<K: Sink> Watched<'_, K> {
    /// Times `write` (the inner sink's output of `report`) and tells the monitor.
    fn timed(
        &mut self,
        report: &FrameReport,
        write: impl FnOnce(&mut K) -> io::Result<()>,
    ) -> io::Result<()> {
        let ready = Instant::now();
        write(self.inner)?;
        let written = Instant::now();
        let marks = self.marks.get();
        let times = FrameTimes {
            wait: marks.lent.saturating_duration_since(marks.asked),
            process: ready.saturating_duration_since(marks.lent),
            output: written.saturating_duration_since(ready),
        };
        self.monitor.on_frame(report, &times, written, &*self.inner);
        Ok(())
    }
}

impl<K: Sink> Sink for Watched<'_, K> {
    fn write(&mut self, report: &FrameReport) -> io::Result<()> {
        self.timed(report, |inner| inner.write(report))
    }

    fn write_frame(&mut self, frame: &Frame<'_>, report: &FrameReport) -> io::Result<()> {
        self.timed(report, |inner| inner.write_frame(frame, report))
    }

    fn finish(&mut self) -> io::Result<()> {
        self.inner.finish()
    }

    fn status(&self, out: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.inner.status(out)
    }
}

/// [`pipeline::run`], watched by `monitor`. Camera captures and replays both run through this
/// one function; only the source differs.
pub fn run<S: FrameSource, K: Sink>(
    source: &mut S,
    pipeline: &mut Pipeline,
    sink: &mut K,
    monitor: &mut Monitor,
) -> (RunSummary, Result<(), RunError<S::Error>>) {
    let now = Instant::now();
    let marks = Cell::new(Marks {
        asked: now,
        lent: now,
    });
    let mut source = Timed {
        inner: source,
        marks: &marks,
    };
    let mut sink = Watched {
        inner: sink,
        marks: &marks,
        monitor,
    };
    pipeline::run(&mut source, pipeline, &mut sink)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::FrameSize;
    use crate::pipeline::PipelineConfig;
    use crate::source::dump::DumpSource;

    /// A sink that keeps the frame indices it was given.
    #[derive(Default)]
    struct Indices(Vec<u64>, bool);

    impl Sink for Indices {
        fn write(&mut self, report: &FrameReport) -> io::Result<()> {
            self.0.push(report.meta.index);
            Ok(())
        }
        fn finish(&mut self) -> io::Result<()> {
            self.1 = true;
            Ok(())
        }
    }

    /// 64×48 frames: a saturated 3×3 square moving right in the odd ones (one that stood
    /// still would be a blinking lamp, not the LED), a dark floor in the even ones.
    fn dump(frames: usize) -> (FrameSize, Vec<u8>) {
        let size = FrameSize::new(64, 48).unwrap();
        let mut bytes = vec![40u8; size.frame_bytes() * frames];
        for (i, frame) in bytes.chunks_exact_mut(size.frame_bytes()).enumerate() {
            if i % 2 == 1 {
                for y in 9..12 {
                    for x in (10 + 3 * i)..(13 + 3 * i) {
                        frame[y * size.row_bytes() + 2 * x] = 255;
                    }
                }
            }
        }
        (size, bytes)
    }

    #[test]
    fn every_frame_passes_through_and_is_counted_and_timed() {
        let (size, bytes) = dump(7);
        let mut source = DumpSource::new(&bytes[..], size, 30.0);
        let mut pipeline = Pipeline::new(size, PipelineConfig::default()).unwrap();
        let mut sink = Indices::default();
        let mut monitor = Monitor::new(MonitorConfig {
            stats: true,
            summary_every: None,
        });
        let (summary, result) = run(&mut source, &mut pipeline, &mut sink, &mut monitor);
        assert!(result.is_ok());
        assert_eq!(sink.0, (0..7).collect::<Vec<_>>());
        assert!(sink.1, "the inner sink is finished");
        let totals = monitor.totals();
        assert_eq!(totals.frames, 7);
        assert_eq!(totals.found, summary.found);
        assert_eq!(totals.found, 3, "the three odd frames");
        assert_eq!(monitor.stats().map(LatencyStats::frames), Some(7));
    }

    #[test]
    fn without_stats_no_histograms_are_kept() {
        let monitor = Monitor::new(MonitorConfig::default());
        assert!(monitor.stats().is_none());
    }

    #[test]
    fn found_percent_of_nothing_is_zero() {
        assert_eq!(Counts::default().found_percent(), 0.0);
        let counts = Counts {
            frames: 8,
            found: 6,
            dropped: 0,
        };
        assert_eq!(counts.found_percent(), 75.0);
    }
}
