//! A minimal `log` backend writing one line per record to standard error, so that logs never
//! mix with the results on standard output. Under systemd (when `JOURNAL_STREAM` is set) each
//! line starts with its syslog priority (`<4>` for a warning), which journald reads as the
//! record's level and strips.

use std::sync::atomic::{AtomicBool, Ordering};

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
            eprintln!(
                "{priority}glint: {}: {}",
                record.level().as_str().to_lowercase(),
                record.args()
            );
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
