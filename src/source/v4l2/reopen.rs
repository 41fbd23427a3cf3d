//! A camera source that survives the camera: on a device fault (unplugged, I/O error, stalled
//! stream) it logs, closes the device, retries opening it with backoff, re-applies the controls
//! and resumes, keeping one timeline so frame times and sequence numbers run on across the gap.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

use super::{CaptureConfig, ControlRequest, V4l2Error, V4l2Source};
use crate::frame::Frame;
use crate::source::v4l2::timeline::Timeline;
use crate::source::{FrameMeta, FrameSource};

/// Sleeps between reopen attempts are cut into slices this long to notice a stop request.
const STOP_POLL_INTERVAL: Duration = Duration::from_millis(50);

/// Exponential backoff between reopen attempts.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Backoff {
    pub initial: Duration,
    pub max: Duration,
}

impl Default for Backoff {
    /// 100 ms, doubling up to 5 s: quick to resume after a USB hiccup, quiet while unplugged.
    fn default() -> Self {
        Backoff {
            initial: Duration::from_millis(100),
            max: Duration::from_secs(5),
        }
    }
}

/// A [`V4l2Source`] that reopens its device after faults.
pub struct ReopeningSource {
    config: CaptureConfig,
    controls: ControlRequest,
    backoff: Backoff,
    stop: Arc<AtomicBool>,
    inner: Option<V4l2Source>,
    timeline: Timeline,
    reopens: u64,
}

impl ReopeningSource {
    /// Opens the camera once; errors here (wrong path, unsupported format) are returned, since
    /// retrying would not cure them. Faults after this point are retried.
    pub fn open(config: CaptureConfig, controls: ControlRequest) -> Result<Self, V4l2Error> {
        let inner = V4l2Source::open_with(&config)?;
        log_controls(&config, &inner, &controls);
        Ok(ReopeningSource {
            config,
            controls,
            backoff: Backoff::default(),
            stop: Arc::new(AtomicBool::new(false)),
            inner: Some(inner),
            timeline: Timeline::new(),
            reopens: 0,
        })
    }

    /// Uses `backoff` between reopen attempts.
    pub fn with_backoff(mut self, backoff: Backoff) -> Self {
        self.backoff = backoff;
        self
    }

    /// A flag that, once set (say from a Ctrl-C handler), makes the source end its stream
    /// instead of waiting for a missing camera.
    pub fn stop_flag(&self) -> Arc<AtomicBool> {
        Arc::clone(&self.stop)
    }

    /// How many times the device was reopened after a fault.
    pub fn reopens(&self) -> u64 {
        self.reopens
    }

    /// The open camera, if it is currently open.
    pub fn current(&self) -> Option<&V4l2Source> {
        self.inner.as_ref()
    }

    fn stopping(&self) -> bool {
        self.stop.load(Ordering::Relaxed)
    }

    /// Sleeps `duration` in slices; `false` if a stop was requested meanwhile.
    fn sleep(&self, duration: Duration) -> bool {
        let mut left = duration;
        while !left.is_zero() {
            if self.stopping() {
                return false;
            }
            let slice = left.min(STOP_POLL_INTERVAL);
            std::thread::sleep(slice);
            left -= slice;
        }
        !self.stopping()
    }

    /// Retries opening until it works or a stop is requested.
    fn reopen(&mut self) -> bool {
        let mut delay = self.backoff.initial;
        loop {
            if !self.sleep(delay) {
                return false;
            }
            match V4l2Source::open_with(&self.config) {
                Ok(source) => {
                    log::warn!("{}: reopened, resuming capture", self.config.path.display());
                    log_controls(&self.config, &source, &self.controls);
                    self.inner = Some(source);
                    self.timeline.restart_stream();
                    self.reopens += 1;
                    return true;
                }
                Err(e) => {
                    log::info!("{e}; retrying in {} ms", delay.as_millis());
                    delay = (delay * 2).min(self.backoff.max);
                }
            }
        }
    }
}

fn log_controls(config: &CaptureConfig, source: &V4l2Source, controls: &ControlRequest) {
    if controls.is_empty() {
        return;
    }
    let report = source.apply_controls(controls);
    if report.refused().next().is_some() {
        log::warn!("{}: controls: {report}", config.path.display());
    } else {
        log::info!("{}: controls: {report}", config.path.display());
    }
}

impl FrameSource for ReopeningSource {
    type Error = V4l2Error;

    /// The next frame; `Ok(None)` once a stop was requested. Only errors that reopening cannot
    /// cure are returned; an interrupted wait is retried.
    fn next_frame(&mut self) -> Result<Option<(Frame<'_>, FrameMeta)>, V4l2Error> {
        let raw = loop {
            if self.stopping() {
                return Ok(None);
            }
            let Some(inner) = self.inner.as_mut() else {
                if !self.reopen() {
                    return Ok(None);
                }
                continue;
            };
            match inner.next_raw() {
                Ok(raw) => break raw,
                // A signal woke the wait; if it was Ctrl-C, the stop flag is set by now and the
                // loop ends cleanly at its top, otherwise waiting resumes.
                Err(V4l2Error::Interrupted) => continue,
                Err(e) if e.is_device_fault() => {
                    log::error!("{e}; closing the device and reopening it");
                    // Dropping the source stops the stream and closes the file, so the driver
                    // can let the node go.
                    self.inner = None;
                }
                Err(e) => return Err(e),
            }
        };
        let meta = self
            .timeline
            .on_frame(raw.driver_sequence, raw.monotonic_us);
        match self.inner.as_ref() {
            Some(inner) => Ok(Some((inner.current_frame(&raw)?, meta))),
            None => Ok(None),
        }
    }
}
