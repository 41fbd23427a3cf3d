//! `glint devices`: the cameras present, with their formats, sizes, frame intervals and
//! controls.

use std::io::{self, Write};
use std::process::ExitCode;

use anyhow::{Context, Result};

use glint::source::v4l2::devices;

pub fn run() -> Result<ExitCode> {
    let found = devices::list_devices().context("cannot list /dev")?;
    if found.is_empty() {
        super::logger::write_line(format_args!("glint: no V4L2 capture devices found"));
    }
    let mut stdout = io::stdout().lock();
    for device in found {
        match device {
            Ok(info) => writeln!(stdout, "{info}\n"),
            // A node that is busy or not readable is listed with the reason, not hidden.
            Err(e) => writeln!(stdout, "{e}\n"),
        }
        .context("writing to standard output")?;
    }
    Ok(ExitCode::SUCCESS)
}
