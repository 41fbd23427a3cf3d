//! Latency percentiles for `--stats`: how long each frame spends in each part of the per-frame
//! path, and from the moment the source hands it over until its report has been written to the
//! output ("dequeue→results": for a camera the frame is handed over as soon as VIDIOC_DQBUF
//! returns, after a few nanoseconds of bookkeeping and no copy).
//!
//! Samples go into fixed-size HDR histograms (allocated once, at a resolution of 1 % of the
//! value), so recording a frame never allocates and a long capture costs no more memory than a
//! short one.

use core::fmt;
use std::time::Duration;

use hdrhistogram::Histogram;

/// Shortest latency told apart, in nanoseconds.
const LOWEST_NS: u64 = 1;
/// Longest latency recorded; longer samples count as this (a minute-long frame is broken
/// anyway).
const HIGHEST_NS: u64 = 60_000_000_000;
/// Significant decimal digits kept: 2 means within 1 %.
const SIGNIFICANT_DIGITS: u8 = 2;
/// Nanoseconds per microsecond, for printing.
const NS_PER_US: f64 = 1e3;

/// The percentiles printed for each stage.
const QUANTILES: [(f64, &str); 3] = [(0.5, "p50"), (0.9, "p90"), (0.99, "p99")];

/// The timings of one frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct FrameTimes {
    /// Waiting for the source: blocked in the driver for the next buffer, or reading a dump.
    pub wait: Duration,
    /// From the frame being lent out to its report being ready (detection and tracking).
    pub process: Duration,
    /// Writing the report to the output (and flushing it, for live runs).
    pub output: Duration,
}

impl FrameTimes {
    /// From the frame being handed over (dequeued) until its results are available to a reader.
    pub fn end_to_end(&self) -> Duration {
        self.process + self.output
    }
}

/// One stage's histogram.
struct Stage {
    name: &'static str,
    histogram: Histogram<u32>,
}

impl Stage {
    fn new(name: &'static str) -> Self {
        // The bounds are constants; `new_with_bounds` fails only for a zero or inverted range.
        let histogram = Histogram::new_with_bounds(LOWEST_NS, HIGHEST_NS, SIGNIFICANT_DIGITS)
            .unwrap_or_else(|_| unreachable!("constant histogram bounds are valid"));
        Stage { name, histogram }
    }

    fn record(&mut self, d: Duration) {
        let ns = u64::try_from(d.as_nanos()).unwrap_or(u64::MAX);
        self.histogram.saturating_record(ns.max(LOWEST_NS));
    }

    fn quantile_us(&self, q: f64) -> f64 {
        self.histogram.value_at_quantile(q) as f64 / NS_PER_US
    }
}

/// Latency histograms of every stage of a run.
pub struct LatencyStats {
    wait: Stage,
    process: Stage,
    output: Stage,
    end_to_end: Stage,
}

impl fmt::Debug for LatencyStats {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("LatencyStats")
            .field("frames", &self.frames())
            .finish()
    }
}

impl Default for LatencyStats {
    fn default() -> Self {
        Self::new()
    }
}

impl LatencyStats {
    /// Empty histograms for every stage.
    pub fn new() -> Self {
        LatencyStats {
            wait: Stage::new("wait"),
            process: Stage::new("process"),
            output: Stage::new("output"),
            end_to_end: Stage::new("dequeue→results"),
        }
    }

    /// Adds one frame's timings.
    pub fn record(&mut self, times: &FrameTimes) {
        self.wait.record(times.wait);
        self.process.record(times.process);
        self.output.record(times.output);
        self.end_to_end.record(times.end_to_end());
    }

    /// Frames recorded.
    pub fn frames(&self) -> u64 {
        self.end_to_end.histogram.len()
    }

    /// The `q`-quantile (0..=1) of the whole path from the frame being lent out until its
    /// results are available, in microseconds (within 1 %).
    pub fn end_to_end_us(&self, q: f64) -> f64 {
        self.end_to_end.quantile_us(q)
    }

    /// The `q`-quantile of processing alone, in microseconds.
    pub fn process_us(&self, q: f64) -> f64 {
        self.process.quantile_us(q)
    }

    fn stages(&self) -> [&Stage; 4] {
        [&self.wait, &self.process, &self.output, &self.end_to_end]
    }

    /// Forgets every sample (keeping the histograms' memory), to start a new period.
    pub fn reset(&mut self) {
        for stage in [
            &mut self.wait,
            &mut self.process,
            &mut self.output,
            &mut self.end_to_end,
        ] {
            stage.histogram.reset();
        }
    }

    /// The percentiles on one line, for a log that keeps one record per line (journald):
    /// `latency p50/p90/p99 µs: wait 1.0/2.0/3.0, process ...`.
    pub fn one_line(&self) -> OneLine<'_> {
        OneLine(self)
    }
}

/// [`LatencyStats::one_line`].
pub struct OneLine<'a>(&'a LatencyStats);

impl fmt::Display for OneLine<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str("latency ")?;
        for (i, (_, label)) in QUANTILES.iter().enumerate() {
            let sep = if i == 0 { "" } else { "/" };
            write!(f, "{sep}{label}")?;
        }
        f.write_str(" µs:")?;
        for (i, stage) in self.0.stages().into_iter().enumerate() {
            let sep = if i == 0 { " " } else { ", " };
            write!(f, "{sep}{}", stage.name)?;
            for (j, (q, _)) in QUANTILES.iter().enumerate() {
                let sep = if j == 0 { " " } else { "/" };
                write!(f, "{sep}{:.1}", stage.quantile_us(*q))?;
            }
        }
        Ok(())
    }
}

/// One line per stage: `p50 / p90 / p99 / max` in microseconds.
impl fmt::Display for LatencyStats {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "latency over {} frames, in µs (", self.frames())?;
        for (_, label) in QUANTILES {
            write!(f, "{label} / ")?;
        }
        write!(f, "max):")?;
        for stage in self.stages() {
            write!(f, "\n  {:<13}", stage.name)?;
            for (q, _) in QUANTILES {
                write!(f, " {:>9.1}", stage.quantile_us(q))?;
            }
            write!(f, " {:>9.1}", stage.histogram.max() as f64 / NS_PER_US)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn times(wait_us: u64, process_us: u64, output_us: u64) -> FrameTimes {
        FrameTimes {
            wait: Duration::from_micros(wait_us),
            process: Duration::from_micros(process_us),
            output: Duration::from_micros(output_us),
        }
    }

    #[test]
    fn percentiles_follow_the_recorded_samples() {
        let mut stats = LatencyStats::new();
        // 90 fast frames and 10 slow ones.
        for _ in 0..90 {
            stats.record(&times(30_000, 2_000, 10));
        }
        for _ in 0..10 {
            stats.record(&times(30_000, 8_000, 50));
        }
        assert_eq!(stats.frames(), 100);
        let close = |got: f64, want: f64| (got - want).abs() <= want * 0.01;
        assert!(close(stats.process_us(0.5), 2_000.0), "{stats}");
        assert!(close(stats.process_us(0.99), 8_000.0), "{stats}");
        assert!(close(stats.end_to_end_us(0.5), 2_010.0), "{stats}");
        assert!(close(stats.end_to_end_us(0.95), 8_050.0), "{stats}");
    }

    #[test]
    fn one_line_holds_every_stage_on_a_single_line_and_reset_empties() {
        let mut stats = LatencyStats::new();
        stats.record(&times(30_000, 2_000, 10));
        let line = stats.one_line().to_string();
        assert!(!line.contains('\n'), "{line}");
        assert!(
            line.starts_with("latency p50/p90/p99 µs: wait 30"),
            "{line}"
        );
        assert!(line.contains(", process 20"), "{line}");
        assert!(line.contains(", dequeue→results 20"), "{line}");
        stats.reset();
        assert_eq!(stats.frames(), 0);
    }

    #[test]
    fn absurd_samples_saturate_instead_of_failing() {
        let mut stats = LatencyStats::new();
        stats.record(&FrameTimes {
            wait: Duration::from_secs(3_600),
            process: Duration::ZERO,
            output: Duration::ZERO,
        });
        assert_eq!(stats.frames(), 1);
        let text = stats.to_string();
        assert!(text.contains("wait"), "{text}");
        assert!(text.contains("dequeue→results"), "{text}");
    }
}
