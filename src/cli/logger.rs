//! A minimal `log` backend writing one line per record to standard error, so that logs never
//! mix with the results on standard output. Under systemd (when `JOURNAL_STREAM` is set) each
//! line starts with its syslog priority (`<4>` for a warning), which journald reads as the
//! record's level and strips.
//!
//! A log line that cannot be written (standard error on a full disk, a closed pipe) is dropped
//! and counted, never a panic: the log must not be what stops a tracker. [`write_line`] is the
//! same for the few lines the command writes on standard error itself.

use std::fmt;
use std::io::{self, Write};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};

use log::{Level, LevelFilter, Log, Metadata, Record};

/// Set by systemd when standard error is connected to the journal.
const JOURNAL_STREAM: &str = "JOURNAL_STREAM";

struct StderrLogger {
    journal: AtomicBool,
}

impl Log for StderrLogger {
    fn enabled(&self, metadata: &Metadata<'_>) -> bool {
        metadata.level() <= log::max_level()
    }

    fn log(&self, record: &Record<'_>) {
        if self.enabled(record.metadata()) {
            let priority = if self.journal.load(Ordering::Relaxed) {
                syslog_prefix(record.level())
            } else {
                ""
            };
            write_line(format_args!(
                "{priority}glint: {}: {}",
                record.level().as_str().to_lowercase(),
                record.args()
            ));
        }
    }

    fn flush(&self) {}
}

/// The sd-daemon(3) prefix of a level: err, warning, info, debug.
fn syslog_prefix(level: Level) -> &'static str {
    match level {
        Level::Error => "<3>",
        Level::Warn => "<4>",
        Level::Info => "<6>",
        Level::Debug | Level::Trace => "<7>",
    }
}

/// Lines that could not be written to standard error.
static DROPPED_LINES: AtomicU64 = AtomicU64::new(0);

/// Writes one line on standard error; if that fails, drops it and counts it.
pub fn write_line(line: fmt::Arguments<'_>) {
    let mut stderr = io::stderr().lock();
    if writeln!(stderr, "{line}").is_err() {
        DROPPED_LINES.fetch_add(1, Ordering::Relaxed);
    }
}

/// How many lines could not be written to standard error so far.
pub fn dropped_lines() -> u64 {
    DROPPED_LINES.load(Ordering::Relaxed)
}

static LOGGER: StderrLogger = StderrLogger {
    journal: AtomicBool::new(false),
};

/// Installs the logger: warnings by default, more with each `-v`.
pub fn init(verbosity: u8) {
    let level = match verbosity {
        0 => LevelFilter::Warn,
        1 => LevelFilter::Info,
        _ => LevelFilter::Debug,
    };
    LOGGER.journal.store(
        std::env::var_os(JOURNAL_STREAM).is_some(),
        Ordering::Relaxed,
    );
    if log::set_logger(&LOGGER).is_ok() {
        log::set_max_level(level);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn journald_priorities_follow_the_level() {
        assert_eq!(syslog_prefix(Level::Error), "<3>");
        assert_eq!(syslog_prefix(Level::Warn), "<4>");
        assert_eq!(syslog_prefix(Level::Info), "<6>");
        assert_eq!(syslog_prefix(Level::Debug), "<7>");
    }
}
