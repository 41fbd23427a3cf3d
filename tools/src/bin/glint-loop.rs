//! `glint-loop`: closes the whole loop on this machine and measures how well it steers.
//!
//! A simulated differential-drive robot (1 kHz physics) carries an LED; glint's renderer films
//! it at 30 fps (4 ms exposure, 640×480, about 1.5 m away, four calibration markers); `glint
//! run` tracks the frames from its standard input and sends floor positions over a
//! pseudo-terminal, at the line's baud, to the example firmware running in
//! `qemu-system-arm -M mps2-an386`; the firmware's pure-pursuit controller drives the
//! figure-eight (1.2 m × 0.6 m at 0.5 m/s) and its wheel commands come back over the board's
//! second UART.
//!
//! ```sh
//! cargo run --release -p glint-tools --bin glint-loop -- --seconds 20 [--camera-delay-ms 70] [--no-compensation]
//! cargo run --release -p glint-tools --bin glint-loop -- --seconds 60 --latency 30
//! ```
//!
//! The frames reach glint `--camera-delay-ms` after their exposure (a USB webcam's 30 to 100 ms),
//! stamped with the exposure's end. `--latency N` runs `glint latency` in the loop instead and
//! prints what it found beside the rig's truth.
//!
//! Without `--glint` and `--firmware` it builds both first (release; the firmware for
//! thumbv7em-none-eabihf with the `mps2-an386` feature). The last line on standard output is
//! `loop: path error p50 A mm p95 B mm, age on arrival p50 C ms p95 D ms, updates E, lost F`.

use std::path::{Path, PathBuf};
use std::process::{Command, ExitCode};

use anyhow::{bail, Context, Result};
use clap::Parser;
use glint_tools::overlay::Canvas;
use glint_tools::rig::path::FigureEight;
use glint_tools::rig::run::{tail, DEFAULT_CAMERA_DELAY_MS};
use glint_tools::rig::{run_loop, LoopConfig, LoopReport};

/// Run the robot-in-the-loop rig: renderer → glint run → firmware in qemu → robot.
#[derive(Parser, Debug)]
#[command(version, about)]
pub(crate) struct Args {
    /// Seconds of frames (at 30 fps).
    #[arg(long, default_value_t = 20.0, value_parser = parse_seconds)]
    seconds: f64,
    /// The firmware steers from positions as they come, not moved on by their age.
    #[arg(long)]
    no_compensation: bool,
    /// Baud rate of the serial line between glint and the board.
    #[arg(long, default_value_t = 115_200, value_parser = clap::value_parser!(u32).range(9_600..=4_000_000))]
    baud: u32,
    /// From the end of each exposure to the frame in glint's hands, ms: a USB webcam's sensor
    /// readout, USB transfer and driver buffering take 30 to 100 ms (the default is a typical
    /// one). The frames carry their exposure's end as their capture time, as V4L2 stamps them.
    #[arg(long, default_value_t = DEFAULT_CAMERA_DELAY_MS,
          value_parser = clap::value_parser!(u32).range(0..=250))]
    camera_delay_ms: u32,
    /// Run `glint latency --trials N` in the loop instead of `glint run`, and print what it
    /// measured beside the rig's truth (the robot drives until its LED first goes dark).
    #[arg(long, value_name = "TRIALS", value_parser = clap::value_parser!(u32).range(1..=200))]
    latency: Option<u32>,
    /// Seed of the sensor noise.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// The glint binary (default: build it with cargo, release).
    #[arg(long)]
    glint: Option<PathBuf>,
    /// The firmware's ELF for mps2-an386 (default: build it with cargo).
    #[arg(long)]
    firmware: Option<PathBuf>,
    /// qemu-system-arm.
    #[arg(long, default_value = "qemu-system-arm")]
    qemu: PathBuf,
    /// Also draw the driven path over the planned one, as a PNG.
    #[arg(long, value_name = "FILE.png")]
    plot: Option<PathBuf>,
}

fn parse_seconds(s: &str) -> Result<f64, String> {
    match s.parse::<f64>() {
        Ok(v) if v.is_finite() && (1.0..=1_800.0).contains(&v) => Ok(v),
        _ => Err("not a number of seconds from 1 to 1800".to_string()),
    }
}

/// The repository's root (tools/..).
fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .map_or_else(|| PathBuf::from("."), Path::to_path_buf)
}

fn cargo() -> PathBuf {
    std::env::var_os("CARGO").map_or_else(|| PathBuf::from("cargo"), PathBuf::from)
}

fn build(dir: &Path, args: &[&str]) -> Result<()> {
    let status = Command::new(cargo())
        .current_dir(dir)
        .args(["build", "--release", "--quiet"])
        .args(args)
        .status()
        .context("cannot run cargo")?;
    if !status.success() {
        bail!("cargo build {} failed in {}", args.join(" "), dir.display());
    }
    Ok(())
}

fn main() -> ExitCode {
    match run(Args::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("glint-loop: {e:#}");
            ExitCode::FAILURE
        }
    }
}

fn run(args: Args) -> Result<()> {
    let root = repo_root();
    let glint = match args.glint {
        Some(p) => p,
        None => {
            build(&root, &["--bin", "glint"])?;
            root.join("target/release/glint")
        }
    };
    let firmware = match args.firmware {
        Some(p) => p,
        None => {
            let dir = root.join("board/firmware");
            build(
                &dir,
                &[
                    "--target",
                    "thumbv7em-none-eabihf",
                    "--features",
                    "mps2-an386",
                    "--bin",
                    "glint-firmware-mps2",
                ],
            )?;
            dir.join("target/thumbv7em-none-eabihf/release/glint-firmware-mps2")
        }
    };
    let work = tempfile::tempdir().context("cannot make a work directory")?;
    let config = LoopConfig {
        seconds: args.seconds,
        compensate: !args.no_compensation,
        glint,
        firmware,
        qemu: args.qemu,
        baud: args.baud,
        camera_delay_us: u64::from(args.camera_delay_ms) * 1_000,
        seed: args.seed,
        work_dir: work.path().to_path_buf(),
        latency_trials: args.latency,
    };
    let report = match run_loop(&config) {
        Ok(r) => r,
        Err(e) => {
            let log = tail(&work.path().join("glint.log"), 10);
            bail!("{e:#}\nglint's log ends:\n{log}");
        }
    };
    print_details(&report);
    if args.latency.is_some() {
        print_latency(&report);
    }
    if let Some(out) = &args.plot {
        plot(&report)
            .save_png(out)
            .with_context(|| format!("cannot write {}", out.display()))?;
    }
    println!("{}", report.summary_line());
    Ok(())
}

/// What `glint latency` printed, and the truth beside it.
fn print_latency(r: &LoopReport) {
    print!("{}", r.glint_stdout);
    let mut truth = r.led_dark_after_request_ms.clone();
    truth.sort_by(f64::total_cmp);
    let at = |q: f64| glint_tools::stats::percentile(&truth, q);
    match (at(5.0), at(50.0), at(95.0)) {
        (Some(lo), Some(median), Some(hi)) => println!(
            "loop: truth: request written to the simulator's LED dark p5 {lo:.2} ms p50 \
             {median:.2} ms p95 {hi:.2} ms over {} requests; the camera's delay {:.0} ms",
            truth.len(),
            r.camera_delay_ms
        ),
        _ => println!("loop: truth: no LED request went out"),
    }
    if r.led_switches_late > 0 {
        println!(
            "loop: {} LED switches arrived after their frames were drawn: those frames show the \
             LED as it had been",
            r.led_switches_late
        );
    }
}

fn print_details(r: &LoopReport) {
    println!(
        "loop: {} frames; end of exposure to glint p50 {:.1} ms p95 {:.1} ms (camera delay {:.0} \
         ms; handed late p95 {:.1} ms; rendering p50 {:.1} ms p95 {:.1} ms)",
        r.frames,
        r.delivery_ms.median,
        r.delivery_ms.p95,
        r.camera_delay_ms,
        r.late_ms.p95,
        r.render_ms.median,
        r.render_ms.p95
    );
    let mut signed = r.age_error_ms.clone();
    signed.sort_by(f64::total_cmp);
    if let (Some(lo), Some(mid), Some(hi)) = (
        glint_tools::stats::percentile(&signed, 5.0),
        glint_tools::stats::percentile(&signed, 50.0),
        glint_tools::stats::percentile(&signed, 95.0),
    ) {
        println!("loop: the firmware's age minus the truth: p5 {lo:.2} ms p50 {mid:.2} ms p95 {hi:.2} ms");
    }
    let mut own = r.age_error_from_receipt_ms.clone();
    own.sort_by(f64::total_cmp);
    if let (Some(lo), Some(mid), Some(hi)) = (
        glint_tools::stats::percentile(&own, 5.0),
        glint_tools::stats::percentile(&own, 50.0),
        glint_tools::stats::percentile(&own, 95.0),
    ) {
        println!(
            "loop: the same from the firmware's read of the bytes on (qemu's lateness taken \
             out): p5 {lo:.2} ms p50 {mid:.2} ms p95 {hi:.2} ms"
        );
    }
    let spread = |v: &[f64]| {
        let mut v = v.to_vec();
        v.sort_by(f64::total_cmp);
        glint_tools::stats::percentile(&v, 50.0).zip(glint_tools::stats::percentile(&v, 95.0))
    };
    if let (Some((w50, w95)), Some((q50, q95))) = (
        spread(&r.short_before_board_ms),
        spread(&r.short_after_wire_ms),
    ) {
        println!(
            "loop: the firmware's age short of the truth: by the wire's lateness p50 {w50:.2} ms \
             p95 {w95:.2} ms, after the wire (qemu, the firmware) p50 {q50:.2} ms p95 {q95:.2} ms"
        );
    }
    match r.age_disagreement_ms() {
        Some(d) => println!(
            "loop: the firmware's age against the truth since the exposure: |error| p50 \
             {:.2} ms p95 {:.2} ms max {:.2} ms over {} updates",
            d.median, d.p95, d.max, d.count
        ),
        None => println!("loop: no update carried an age"),
    }
    if !r.kept_real_time() {
        println!(
            "loop: this machine did not keep the loop in real time: the figures measure its load"
        );
    }
    if r.garbled > 0 {
        println!("loop: {} garbled lines from the firmware", r.garbled);
    }
}

/// Pixels per metre of the plot: 1 px = 2 mm.
const PLOT_PX_PER_M: f64 = 500.0;
/// Room around the figure, and for the caption, px.
const PLOT_MARGIN_PX: f64 = 24.0;
/// Half the width of the planned path's band, px (5 mm).
const PLANNED_HALF_WIDTH_PX: i64 = 2;

/// The driven path (red) over the planned one (a grey band 10 mm wide), drawn with the
/// overlay's canvas and font as `glint-plot` draws its tracks.
fn plot(r: &LoopReport) -> Canvas {
    let (w, h) = (
        1.2 * PLOT_PX_PER_M + 2.0 * PLOT_MARGIN_PX,
        0.6 * PLOT_PX_PER_M + 3.0 * PLOT_MARGIN_PX,
    );
    let mut canvas = Canvas::new(w as usize, h as usize, [255, 255, 255]);
    let px = |(x, y): (f64, f64)| {
        (
            (w / 2.0 + x * PLOT_PX_PER_M).round() as i64,
            (PLOT_MARGIN_PX + (h - PLOT_MARGIN_PX) / 2.0 - y * PLOT_PX_PER_M).round() as i64,
        )
    };
    for p in FigureEight::RIG.polyline() {
        let (x, y) = px(p);
        canvas.disk(x, y, PLANNED_HALF_WIDTH_PX, [190, 190, 190]);
    }
    for pair in r.driven_m.windows(2) {
        let ((x0, y0), (x1, y1)) = (px(pair[0]), px(pair[1]));
        canvas.line(x0, y0, x1, y1, [200, 30, 30]);
    }
    canvas.text(
        6,
        4,
        "planned (grey, 10 mm wide) and driven (red)",
        1,
        [0, 0, 0],
    );
    let figures = format!(
        "path error p50 {:.1} p95 {:.1} mm; age p50 {:.1} p95 {:.1} ms",
        r.path_error_mm.median,
        r.path_error_mm.p95,
        r.age_on_arrival_ms.median,
        r.age_on_arrival_ms.p95
    );
    canvas.text(6, 14, &figures, 1, [0, 0, 0]);
    canvas
}
