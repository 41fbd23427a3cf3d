//! Command-line interface: one file per subcommand.

mod calib_args;
mod calibrate;
#[cfg(feature = "v4l2")]
mod camera;
#[cfg(feature = "v4l2")]
mod devices;
mod input;
mod latency;
mod logger;
#[cfg(feature = "v4l2")]
mod record;
mod run;
mod run_config;
mod signals;
mod track;

use std::process::ExitCode;

use clap::{CommandFactory, Parser, Subcommand};

/// Exit code for bad arguments (as clap uses).
const EXIT_USAGE: u8 = 2;

/// glint tracks a saturated LED in YUYV video and reports its position per frame.
#[derive(Debug, Parser)]
#[command(name = "glint", version, about)]
struct Cli {
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
    /// Calibrate screen to floor from ArUco markers at known floor positions in a dump.
    Calibrate(calibrate::CalibrateArgs),
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
            eprintln!("glint: {message}");
            return ExitCode::from(EXIT_USAGE);
        }
    };
    let cli = match Cli::try_parse_from(&spliced.argv) {
        Ok(cli) => cli,
        Err(e) if !e.use_stderr() => {
            // --help and --version go to standard output as usual.
            let _ = e.print();
            return ExitCode::SUCCESS;
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
            eprintln!("glint: {}", spliced.attribute(&e, message));
            return ExitCode::from(EXIT_USAGE);
        }
    };
    logger::init(cli.verbose);
    let result = match cli.command {
        Command::Track(args) => track::run(args),
        Command::Run(args) => run::run(args),
        Command::Latency(args) => latency::run(args),
        Command::Calibrate(args) => calibrate::run(args),
        #[cfg(feature = "v4l2")]
        Command::Devices => devices::run(),
        #[cfg(feature = "v4l2")]
        Command::Record(args) => record::run(args),
    };
    match result {
        Ok(code) => code,
        Err(e) => {
            eprintln!("glint: {e:#}");
            ExitCode::FAILURE
        }
    }
}
