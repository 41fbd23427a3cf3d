//! Ctrl-C and SIGTERM as a stop request: a flag the frame source checks, so a run ends after
//! the current frame with its outputs flushed.

use std::sync::atomic::AtomicBool;
use std::sync::Arc;

use anyhow::{Context, Result};
use signal_hook::consts::{SIGINT, SIGTERM};

/// Exit status when a second Ctrl-C cuts a stop short (128 + SIGINT, as shells report it).
const EXIT_SECOND_SIGNAL: i32 = 130;

/// Ctrl-C and SIGTERM set `stop`, which ends the stream after the current frame; a second one
/// while stopping ends the process at once, in case stopping hangs.
pub fn stop_on_signals(stop: &Arc<AtomicBool>) -> Result<()> {
    for signal in [SIGINT, SIGTERM] {
        // The shutdown must be registered first, so that it sees the flag before this signal
        // sets it.
        signal_hook::flag::register_conditional_shutdown(
            signal,
            EXIT_SECOND_SIGNAL,
            Arc::clone(stop),
        )
        .and_then(|_| signal_hook::flag::register(signal, Arc::clone(stop)))
        .context("installing the Ctrl-C handler")?;
    }
    Ok(())
}
