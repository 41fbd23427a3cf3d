//! `glint devices`: the cameras present, with their formats, sizes, frame intervals and
//! controls.

use std::process::ExitCode;

use anyhow::{Context, Result};

use glint::source::v4l2::devices;

pub fn run() -> Result<ExitCode> {
    let found = devices::list_devices().context("cannot list /dev")?;
    if found.is_empty() {
        eprintln!("glint: no V4L2 capture devices found");
    }
    for device in found {
        match device {
            Ok(info) => println!("{info}\n"),
            // A node that is busy or not readable is listed with the reason, not hidden.
            Err(e) => println!("{e}\n"),
        }
    }
    Ok(ExitCode::SUCCESS)
}
