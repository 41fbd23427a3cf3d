//! `glint-plot`: a JSON-lines track as a PNG of the trajectory and the speed over time.
//!
//! ```sh
//! glint track --input run.yuyv --size 640x480 > track.jsonl
//! glint-plot --input track.jsonl --out track.png
//! ```

use std::fs::File;
use std::io::{self, BufRead, BufReader};
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{Context, Result};
use clap::Parser;
use glint_tools::plot::{render, Track, Units, MAX_SIDE_PX, MIN_SIDE_PX};

/// Plot a glint track: trajectory (floor units when calibrated, else pixels) and speed.
#[derive(Parser, Debug)]
#[command(version, about)]
pub(crate) struct Args {
    /// A JSON-lines track from `glint track`, or `-` for standard input.
    #[arg(long, value_name = "PATH|-")]
    input: String,
    /// Where to write the PNG.
    #[arg(long, value_name = "FILE.png")]
    out: PathBuf,
    /// Width of the image in pixels.
    #[arg(long, default_value_t = 800, value_parser = parse_side)]
    width: usize,
    /// Height of the image in pixels.
    #[arg(long, default_value_t = 900, value_parser = parse_side)]
    height: usize,
    /// Title drawn at the top (default: the input's name and counts).
    #[arg(long)]
    title: Option<String>,
}

fn parse_side(s: &str) -> Result<usize, String> {
    let side: usize = s
        .parse()
        .map_err(|_| format!("{s:?} is not a whole number"))?;
    if (MIN_SIDE_PX..=MAX_SIDE_PX).contains(&side) {
        Ok(side)
    } else {
        Err(format!("{side} is outside {MIN_SIDE_PX}..={MAX_SIDE_PX}"))
    }
}

fn main() -> ExitCode {
    match run(Args::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("glint-plot: {e:#}");
            ExitCode::FAILURE
        }
    }
}

fn run(args: Args) -> Result<()> {
    let input: Box<dyn BufRead> = if args.input == "-" {
        Box::new(BufReader::new(io::stdin().lock()))
    } else {
        let file =
            File::open(&args.input).with_context(|| format!("cannot open {}", args.input))?;
        Box::new(BufReader::new(file))
    };
    let track = Track::from_jsonl(input).with_context(|| format!("in {}", args.input))?;
    let units = match track.units {
        Units::Pixels => "image pixels".to_string(),
        Units::Floor => format!("floor {}", track.length_name()),
    };
    let title = args.title.clone().unwrap_or_else(|| {
        format!(
            "{}: {} frames, {} with a position, in {units}",
            args.input,
            track.samples.len(),
            track.found_count()
        )
    });
    let canvas = render(&track, args.width, args.height, &title);
    canvas
        .save_png(&args.out)
        .with_context(|| format!("cannot write {}", args.out.display()))?;
    eprintln!(
        "glint-plot: {} frames ({} with a position, {units}) -> {}",
        track.samples.len(),
        track.found_count(),
        args.out.display()
    );
    Ok(())
}
