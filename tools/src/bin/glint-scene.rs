//! `glint-scene`: renders a preset scene to a raw YUYV dump plus its ground-truth CSV.
//!
//! The dump has exactly the layout of `v4l2-ctl --stream-mmap --stream-to=FILE` or
//! `ffmpeg -f rawvideo -pix_fmt yuyv422`: headerless frames back to back.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use anyhow::{bail, Context, Result};
use clap::Parser;
use glint_tools::scene::{write_truth_csv, Scene, Truth, Visibility};

/// Render a synthetic glint scene with ground truth.
#[derive(Parser, Debug)]
#[command(version, about)]
pub(crate) struct Args {
    /// List the presets and exit.
    #[arg(long)]
    list: bool,
    /// Preset name (see --list).
    #[arg(long, required_unless_present = "list")]
    scene: Option<String>,
    /// Directory for NAME.yuv and NAME.truth.csv (created if missing).
    #[arg(long, required_unless_present = "list")]
    out_dir: Option<PathBuf>,
    /// Number of frames (default: the preset's).
    #[arg(long)]
    frames: Option<usize>,
    /// Seed of the floor texture and noise (default: the preset's).
    #[arg(long)]
    seed: Option<u64>,
}

fn main() -> ExitCode {
    match run(Args::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("glint-scene: {e:#}");
            ExitCode::FAILURE
        }
    }
}

fn run(args: Args) -> Result<()> {
    if args.list {
        for &name in Scene::names() {
            if let Some(config) = Scene::preset_config(name) {
                println!("{name:<14} {}", config.summary);
            }
        }
        return Ok(());
    }
    let (Some(name), Some(out_dir)) = (args.scene, args.out_dir) else {
        bail!("--scene and --out-dir are required (or --list)");
    };
    let Some(mut config) = Scene::preset_config(&name) else {
        bail!(
            "unknown scene {name:?}; known: {}",
            Scene::names().join(", ")
        );
    };
    if let Some(frames) = args.frames {
        config.frame_count = frames;
    }
    if let Some(seed) = args.seed {
        config.seed = seed;
    }
    let scene = Scene::new(config).with_context(|| format!("scene {name}"))?;

    std::fs::create_dir_all(&out_dir)
        .with_context(|| format!("cannot create {}", out_dir.display()))?;
    let dump_path = out_dir.join(format!("{name}.yuv"));
    let truth_path = out_dir.join(format!("{name}.truth.csv"));

    let started = Instant::now();
    let truths = write_dump(&scene, &dump_path)?;
    let elapsed = started.elapsed();
    let truth_file = File::create(&truth_path)
        .with_context(|| format!("cannot create {}", truth_path.display()))?;
    write_truth_csv(BufWriter::new(truth_file), &truths)
        .with_context(|| format!("cannot write {}", truth_path.display()))?;

    let visible = truths
        .iter()
        .filter(|t| t.visible == Visibility::Visible)
        .count();
    println!(
        "{name}: {}x{} YUYV, {} fps, exposure {} us, {} frames ({visible} visible)",
        scene.width_px(),
        scene.height_px(),
        scene.fps(),
        scene.exposure_us(),
        truths.len()
    );
    println!("wrote {} and {}", dump_path.display(), truth_path.display());
    eprintln!(
        "rendered in {:.1} ms ({:.2} ms/frame)",
        elapsed.as_secs_f64() * 1e3,
        elapsed.as_secs_f64() * 1e3 / truths.len().max(1) as f64
    );
    Ok(())
}

/// Streams the frames to `path` one at a time (an HD dump would not fit comfortably in memory).
fn write_dump(scene: &Scene, path: &PathBuf) -> Result<Vec<Truth>> {
    let file = File::create(path).with_context(|| format!("cannot create {}", path.display()))?;
    let mut out = BufWriter::new(file);
    let mut frame = vec![0u8; scene.frame_len_bytes()];
    let mut truths = Vec::new();
    for index in 0..scene.frame_count() {
        truths.push(scene.render(index, &mut frame)?);
        out.write_all(&frame)
            .with_context(|| format!("cannot write {}", path.display()))?;
    }
    out.flush()
        .with_context(|| format!("cannot write {}", path.display()))?;
    Ok(truths)
}
