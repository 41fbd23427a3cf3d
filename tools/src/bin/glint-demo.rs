//! `glint-demo`: glint on a built-in synthetic scene, no camera needed.
//!
//! Renders a preset scene frame by frame in memory, runs each frame through the real glint
//! pipeline (exactly as `glint track --exposure-us` would), compares the answers with the scene's exact
//! ground truth, prints a short table and a summary, and writes an overlay PNG of one frame.

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::{Duration, Instant};

use anyhow::{bail, Context, Result};
use clap::Parser;
use glint::frame::{Frame, FrameSize};
use glint::pipeline::{Pipeline, PipelineConfig};
use glint::report::FrameReport;
use glint::source::FrameMeta;
use glint::track::{PositionMethod, TrackerConfig};
use glint_tools::overlay::{Overlay, YuvRange};
use glint_tools::scene::{Range, Scene, Truth, Visibility};
use glint_tools::stats::Spread;

/// The scene shown by default: small fast circles, whose streaks are curved arcs.
const DEFAULT_SCENE: &str = "circles";
/// About this many frames get a line in the table.
const TABLE_ROWS: usize = 10;
const US_PER_S: f64 = 1e6;
const MS_PER_S: f64 = 1e3;

/// Run glint on a built-in synthetic scene and show how close it comes to the truth.
#[derive(Parser, Debug)]
#[command(version, about)]
pub(crate) struct Args {
    /// Preset scene (see `glint-scene --list`).
    #[arg(long, default_value = DEFAULT_SCENE)]
    scene: String,
    /// Where to write the overlay PNG of one frame.
    #[arg(long, default_value = "demo-overlay.png")]
    out: PathBuf,
    /// The frame to draw (default: the middle one).
    #[arg(long)]
    frame: Option<usize>,
    /// Render only this many frames (default: the preset's).
    #[arg(long)]
    frames: Option<usize>,
}

fn main() -> ExitCode {
    match run(Args::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("glint-demo: {e:#}");
            ExitCode::FAILURE
        }
    }
}

/// One frame's outcome.
struct Row {
    truth: Truth,
    report: FrameReport,
    /// Distance from glint's middle to the truth's, and from its position to the truth's.
    mid_error_px: Option<f64>,
    position_error_px: Option<f64>,
}

fn run(args: Args) -> Result<()> {
    let Some(mut config) = Scene::preset_config(&args.scene) else {
        bail!(
            "unknown scene {:?}; known: {}",
            args.scene,
            Scene::names().join(", ")
        );
    };
    if let Some(frames) = args.frames {
        config.frame_count = frames;
    }
    let scene = Scene::new(config).with_context(|| format!("scene {}", args.scene))?;
    let frame_count = scene.frame_count();
    let overlay_frame = args.frame.unwrap_or(frame_count / 2);
    if overlay_frame >= frame_count {
        bail!("--frame {overlay_frame} is past the end: the scene has {frame_count} frames (0..{frame_count})");
    }
    let size = FrameSize::new(scene.width_px(), scene.height_px())?;
    let range = match scene.config().camera.range {
        Range::Full => YuvRange::Full,
        Range::Studio => YuvRange::Studio,
    };
    println!(
        "glint demo: scene {} ({}x{}, {} fps, exposure {} ms, {frame_count} frames)",
        scene.name(),
        size.width(),
        size.height(),
        scene.fps(),
        f64::from(scene.exposure_us()) / 1e3,
    );
    println!("  {}", scene.config().summary);

    // As `glint track --exposure-us`: the scene's exposure is known, as a camera's is.
    let config = PipelineConfig {
        tracker: TrackerConfig {
            exposure_us: Some(scene.exposure_us()),
        },
        ..PipelineConfig::default()
    };
    let mut pipeline = Pipeline::new(size, config)?;
    let mut buffer = vec![0u8; scene.frame_len_bytes()];
    let (mut rows, mut detect_s, mut render_time) = (Vec::new(), Vec::new(), Duration::ZERO);
    for index in 0..frame_count {
        let started = Instant::now();
        let truth = scene.render(index, &mut buffer)?;
        render_time += started.elapsed();
        let frame = Frame::new_checked(&buffer, size, size.row_bytes())?;
        let meta = FrameMeta {
            index: index as u64,
            sequence: index as u64,
            dropped: 0,
            timestamp_us: (index as f64 * US_PER_S / scene.fps()).round() as u64,
            monotonic_us: glint::source::clock::monotonic_now_us(),
        };
        let started = Instant::now();
        let report = pipeline.process(&frame, meta);
        detect_s.push(started.elapsed().as_secs_f64());
        if index == overlay_frame {
            Overlay::from_report(frame, &pipeline, &report, range)
                .with_truth(&truth)
                .with_title(format!("{} (built-in scene)", scene.name()))
                .render()
                .canvas
                .save_png(&args.out)
                .with_context(|| format!("cannot write {}", args.out.display()))?;
        }
        rows.push(compare(truth, report));
    }

    print_table(&rows, overlay_frame);
    print_summary(&rows, &detect_s, render_time);
    println!(
        "wrote {}: frame {overlay_frame} with the mask, skeleton, glint's answers and the truth",
        args.out.display()
    );
    Ok(())
}

/// Pairs a report with the truth of its frame.
fn compare(truth: Truth, report: FrameReport) -> Row {
    let distance = |(x, y): (f32, f32), tx: Option<f64>, ty: Option<f64>| {
        let (tx, ty) = tx.zip(ty)?;
        Some((f64::from(x) - tx).hypot(f64::from(y) - ty))
    };
    let p = report.position;
    Row {
        mid_error_px: p.and_then(|p| distance(p.mid_px, truth.mid_x_px, truth.mid_y_px)),
        position_error_px: p.and_then(|p| distance(p.position_px, truth.x_px, truth.y_px)),
        truth,
        report,
    }
}

fn print_table(rows: &[Row], overlay_frame: usize) {
    let every = rows.len().div_ceil(TABLE_ROWS).max(1);
    println!();
    println!(
        "{:>5}  {:<7}  {:>15}  {:>15}  {:>8}  {:>15}  {:>8}",
        "frame", "truth", "glint mid", "truth mid", "err px", "truth x,y", "err px"
    );
    let pair = |x: Option<f64>, y: Option<f64>| match x.zip(y) {
        Some((x, y)) => format!("{x:7.2} {y:7.2}"),
        None => "-".into(),
    };
    let number = |v: Option<f64>| v.map_or("-".into(), |v| format!("{v:.3}"));
    for (index, row) in rows.iter().enumerate() {
        if index % every != 0 && index != overlay_frame {
            continue;
        }
        let t = &row.truth;
        let visible = match t.visible {
            Visibility::Visible => "visible",
            Visibility::Hidden => "hidden",
            Visibility::Partial => "partial",
        };
        let mid = row.report.position.map(|p| p.mid_px);
        let glint_mid = match mid {
            Some((x, y)) => pair(Some(x.into()), Some(y.into())),
            None => "not found".into(),
        };
        let marker = if index == overlay_frame {
            "  <- overlay"
        } else {
            ""
        };
        println!(
            "{index:>5}  {visible:<7}  {glint_mid:>15}  {:>15}  {:>8}  {:>15}  {:>8}{marker}",
            pair(t.mid_x_px, t.mid_y_px),
            number(row.mid_error_px),
            pair(t.x_px, t.y_px),
            number(row.position_error_px),
        );
    }
}

fn print_summary(rows: &[Row], detect_s: &[f64], render_time: Duration) {
    let visible = |r: &&Row| r.truth.visible == Visibility::Visible;
    let found = |r: &&Row| r.report.position.is_some();
    let n_visible = rows.iter().filter(visible).count();
    let n_found = rows.iter().filter(found).count();
    let missed = rows.iter().filter(visible).filter(|r| !found(r)).count();
    let hidden_found = rows
        .iter()
        .filter(|r| r.truth.visible == Visibility::Hidden)
        .filter(found)
        .count();
    println!();
    println!(
        "summary: {} frames, LED visible in {n_visible}, detected in {n_found} \
         (missed {missed} visible, found {hidden_found} while hidden)",
        rows.len()
    );
    // Accuracy over the frames where the whole LED is in view (as the truth CSV advises).
    let errors = |f: fn(&Row) -> Option<f64>| -> Vec<f64> {
        rows.iter().filter(visible).filter_map(f).collect()
    };
    let spread_line = |what: &str, values: &[f64]| match Spread::of(values) {
        Some(s) => println!(
            "  {what}: median {:.3} px, 95th percentile {:.3} px, max {:.3} px ({} frames)",
            s.median, s.p95, s.max, s.count
        ),
        None => println!("  {what}: no frame to measure"),
    };
    spread_line(
        "streak middle (mid_x, mid_y) error",
        &errors(|r| r.mid_error_px),
    );
    spread_line(
        "position (x, y) error            ",
        &errors(|r| r.position_error_px),
    );
    let from_mid = rows
        .iter()
        .filter_map(|r| r.report.position)
        .filter(|p| p.position_method == PositionMethod::Mid)
        .count();
    if from_mid > 0 {
        println!(
            "  ({from_mid} of the found frames report x, y = the streak's middle: the first \
             frame of a track has no direction of travel yet)"
        );
    }
    if let Some(t) = Spread::of(detect_s) {
        let build = if cfg!(debug_assertions) {
            "; a debug build, use --release for real figures"
        } else {
            ""
        };
        println!(
            "  time per frame: glint {:.3} ms median, {:.3} ms 95th percentile{build}; \
             rendering the scene {:.2} ms",
            t.median * MS_PER_S,
            t.p95 * MS_PER_S,
            render_time.as_secs_f64() * MS_PER_S / rows.len().max(1) as f64
        );
    }
}
