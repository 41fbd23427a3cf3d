//! Command-line interface: one file per subcommand.

mod calib_args;
mod calibrate;
#[cfg(feature = "v4l2")]
mod camera;
#[cfg(feature = "v4l2")]
mod devices;
mod fuse;
mod fuse_links;
#[cfg(feature = "net")]
mod fuse_live;
mod fuse_net;
mod input;
mod latency;
mod logger;
mod memory;
mod publish;
#[cfg(feature = "v4l2")]
mod record;
mod row_time;
mod run;
// Reached from tests/readme_commands.rs, which splices settings files as `main` does.
pub(crate) mod run_config;
mod serial_ports;
mod signals;
mod track;

use std::ffi::OsString;
use std::process::ExitCode;

use clap::error::{ContextKind, ContextValue, ErrorKind};
use clap::{CommandFactory, Parser, Subcommand};

use glint::options::shortened;

/// Exit code for bad arguments (as clap uses).
const EXIT_USAGE: u8 = 2;

/// Longest argument accepted: a path (PATH_MAX) is the longest thing any option takes.
const MAX_ARGUMENT_BYTES: usize = 4096;

/// glint tracks a saturated LED in YUYV video and reports its position per frame.
#[derive(Debug, Parser)]
#[command(name = "glint", version, about, arg_required_else_help = true)]
pub struct Cli {
    /// More log output on standard error (-v info, -vv debug).
    #[arg(short, long, action = clap::ArgAction::Count, global = true)]
    verbose: u8,

    #[command(subcommand)]
    command: Command,
}

#[derive(Debug, Subcommand)]
enum Command {
    /// Track the LED in a raw YUYV dump (file or `-` for standard input) or from a camera.
    Track(track::TrackArgs),
    /// The long-running mode: track from a camera (or a dump) to the serial link and JSON
    /// lines, with the settings in a file (`--config`), a periodic status in the log, and a
    /// clean stop on SIGTERM.
    Run(run::RunArgs),
    /// Measure the whole loop's latency: ask the robot over --serial to switch its LED off at
    /// random moments, and time the first frame in which it is gone.
    Latency(latency::LatencyArgs),
    /// Measure a rolling shutter's row time (for `track --row-time-us`) from the bands a
    /// flickering lamp draws across the frames.
    RowTime(row_time::RowTimeArgs),
    /// Calibrate screen to floor from ArUco markers at known floor positions in a dump.
    Calibrate(calibrate::CalibrateArgs),
    /// Merge several cameras' reports into one track per robot: weighted where views overlap,
    /// handed over where one ends, one JSON line per fused time step.
    Fuse(fuse::FuseArgs),
    /// List the V4L2 cameras with their formats, sizes, frame intervals and controls.
    #[cfg(feature = "v4l2")]
    Devices,
    /// Record frames from a camera into a raw dump plus a sidecar with their timing.
    #[cfg(feature = "v4l2")]
    Record(record::RecordArgs),
}

/// Parses the arguments, runs the command, and turns any error into one line on standard
/// error and a non-zero exit code.
pub fn main() -> ExitCode {
    let spliced = match run_config::splice(std::env::args_os().collect(), &Cli::command()) {
        Ok(spliced) => spliced,
        Err(message) => {
            logger::write_line(format_args!("glint: {message}"));
            return ExitCode::from(EXIT_USAGE);
        }
    };
    if let Some(message) = oversized_argument(&spliced.argv) {
        logger::write_line(format_args!("glint: {message}"));
        return ExitCode::from(EXIT_USAGE);
    }
    let cli = match Cli::try_parse_from(&spliced.argv) {
        Ok(cli) => cli,
        Err(e) if !e.use_stderr() => {
            // --help and --version go to standard output as usual.
            let _ = e.print();
            return ExitCode::SUCCESS;
        }
        Err(e) if e.kind() == ErrorKind::DisplayHelpOnMissingArgumentOrSubcommand => {
            // `glint` alone: the usage, on standard error since nothing was run.
            let _ = e.print();
            return ExitCode::from(EXIT_USAGE);
        }
        Err(e) => {
            let rendered = e.render().to_string();
            let mut lines = rendered.lines();
            let first = lines.next().unwrap_or("error: invalid arguments");
            // "the following required arguments were not provided:" lists them below.
            let mut message = first.trim_start_matches("error: ").to_string();
            if first.ends_with(':') {
                let listed: Vec<&str> =
                    lines.map(str::trim).take_while(|l| !l.is_empty()).collect();
                message = format!("{message} {}", listed.join(", "));
            }
            // clap quotes the bad value whole; a huge one is cut short.
            if let Some(ContextValue::String(value)) = e.get(ContextKind::InvalidValue) {
                message = message.replace(value.as_str(), &shortened(value));
            }
            logger::write_line(format_args!("glint: {}", spliced.attribute(&e, message)));
            return ExitCode::from(EXIT_USAGE);
        }
    };
    logger::init(cli.verbose);
    let result = match cli.command {
        Command::Track(args) => track::run(args),
        Command::Run(args) => run::run(args),
        Command::Latency(args) => latency::run(args),
        Command::RowTime(args) => row_time::run(args),
        Command::Calibrate(args) => calibrate::run(args),
        Command::Fuse(args) => fuse::run(args),
        #[cfg(feature = "v4l2")]
        Command::Devices => devices::run(),
        #[cfg(feature = "v4l2")]
        Command::Record(args) => record::run(args),
    };
    match result {
        Ok(code) => code,
        Err(e) => {
            logger::write_line(format_args!("glint: {e:#}"));
            ExitCode::FAILURE
        }
    }
}

/// The refusal of an argument longer than any option takes, if there is one, naming its
/// option: a 10 MB value is not worth parsing, nor quoting back whole.
fn oversized_argument(argv: &[OsString]) -> Option<String> {
    let at = argv
        .iter()
        .enumerate()
        .skip(1)
        .find(|(_, a)| a.len() > MAX_ARGUMENT_BYTES)
        .map(|(i, _)| i)?;
    let text = argv.get(at)?.to_string_lossy();
    let option = match text.strip_prefix("--").and_then(|t| t.split_once('=')) {
        Some((name, _)) => Some(format!("--{}", shortened(name))),
        None => argv
            .get(at - 1)
            .map(|a| a.to_string_lossy())
            .filter(|a| a.starts_with("--") && !a.contains('=') && at > 1)
            .map(|a| shortened(&a)),
    };
    let what = option.map_or("an argument".to_string(), |o| format!("the value of {o}"));
    Some(format!(
        "{what} is {} bytes, longer than any option takes (at most {MAX_ARGUMENT_BYTES}): '{}'",
        text.len(),
        shortened(&text)
    ))
}
