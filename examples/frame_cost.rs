//! A fixed per-frame workload for counting instructions (not for timing): `tools/pi-cost.sh`
//! runs it under callgrind (x86_64) and under `qemu-aarch64` with an instruction-counting
//! plugin, twice with different frame counts, and divides the difference by the extra frames,
//! so set-up (rendering the frames, allocation, process start) cancels out.
//!
//! `cargo run --release --example frame_cost -- STAGE FRAMES [SCENE [SPOT]]`
//!
//! STAGE is `pipeline` (the whole `Pipeline::process` on each frame of the scene, by default
//! `fast-line`, a 60 px streak at 640×480, in order so the tracker follows it), `pipeline-fit`
//! (the same with `--streak-model fit`), `pipeline-auto` (with `--streak-model auto`),
//! `threshold` (the automatic threshold alone, on YUYV frames), `threshold-uyvy` and
//! `threshold-grey` (the same frames repacked as UYVY and as GREY), or `none` (set-up only).
//! SCENE is any preset (`hd-720` for 1280×720). SPOT, `gaussian`, renders the LED as a
//! Gaussian spot of the preset's radius instead of its own (as `glint-scene --spot gaussian`:
//! a spot `--streak-model auto` fits on every frame). The pipeline stages print how many
//! frames had their streak fitted.

use std::hint::black_box;

use glint::detect::bitimage::BitImage;
use glint::detect::streak::StreakModel;
use glint::detect::threshold::{self, Threshold};
use glint::detect::DetectorConfig;
use glint::frame::{Frame, FrameSize, PixelFormat};
use glint::pipeline::{Pipeline, PipelineConfig};
use glint::source::FrameMeta;
use glint::track::TrackerConfig;
use glint_tools::scene::{Scene, Spot};

/// Frames rendered up front (and cycled through): the same set whatever FRAMES is, so the
/// rendering cost is the same in every run and cancels out of the difference.
const RENDERED_FRAMES: usize = 16;
const SCENE: &str = "fast-line";
const USAGE: &str = "usage: frame_cost pipeline|pipeline-fit|pipeline-auto|threshold|threshold-uyvy|threshold-grey|none FRAMES [SCENE [gaussian]]";

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let stage = args.next().ok_or(USAGE)?;
    let frames: usize = args.next().ok_or(USAGE)?.parse()?;
    let scene_name = args.next().unwrap_or_else(|| SCENE.to_string());

    let mut config = Scene::preset_config(&scene_name).ok_or("unknown scene")?;
    match args.next().as_deref() {
        None => {}
        Some("gaussian") => {
            config.led.spot = Spot::Gaussian {
                sigma_px: config.led.radius_px,
            };
            // The old lens glow is the spot's job now (as `glint-scene --spot`).
            config.led.glow_peak = 0.0;
        }
        Some(_) => return Err(USAGE.into()),
    }
    // Frames from the middle of the scene, where the LED is in view and streaked.
    let first = config.frame_count / 2;
    config.frame_count = first + RENDERED_FRAMES;
    let scene = Scene::new(config)?;
    let size = FrameSize::new(scene.width_px(), scene.height_px())?;
    let mut rendered = vec![vec![0u8; size.frame_bytes()]; RENDERED_FRAMES];
    for (k, bytes) in rendered.iter_mut().enumerate() {
        scene.render(first + k, bytes)?;
    }
    let frame_of =
        |k: usize| Frame::new_checked(&rendered[k % RENDERED_FRAMES], size, size.row_bytes());
    let format = match stage.as_str() {
        "threshold-uyvy" => PixelFormat::Uyvy,
        "threshold-grey" => PixelFormat::Grey,
        _ => PixelFormat::Yuyv,
    };
    let repacked: Vec<Vec<u8>> = rendered
        .iter()
        .map(|yuyv| match format {
            PixelFormat::Yuyv => yuyv.clone(),
            PixelFormat::Uyvy => yuyv.chunks_exact(2).flat_map(|p| [p[1], p[0]]).collect(),
            PixelFormat::Grey => yuyv.iter().step_by(2).copied().collect(),
        })
        .collect();
    let repacked_of = |k: usize| {
        let stride = size.row_bytes_as(format);
        Frame::new_checked_as(&repacked[k % RENDERED_FRAMES], size, stride, format)
    };

    let tracker = TrackerConfig {
        exposure_us: Some(scene.exposure_us()),
    };
    let streak_model = match stage.as_str() {
        "pipeline-fit" => StreakModel::Fit,
        "pipeline-auto" => StreakModel::Auto,
        _ => StreakModel::Ramps,
    };
    let mut pipeline = Pipeline::new(
        size,
        PipelineConfig {
            tracker,
            detector: DetectorConfig {
                streak_model,
                ..DetectorConfig::default()
            },
        },
    )?;
    let mut mask = BitImage::new(size);
    let mut found = 0usize;
    // Frames whose streak was fitted (`pipeline-fit`: every analysed one; `pipeline-auto`:
    // those the cascade found doubtful).
    let mut fitted = 0usize;
    for k in 0..frames {
        let frame = frame_of(k)?;
        match stage.as_str() {
            "pipeline" | "pipeline-fit" | "pipeline-auto" => {
                let meta = FrameMeta {
                    index: k as u64,
                    sequence: k as u64,
                    dropped: 0,
                    timestamp_us: (k as f64 * 1e6 / scene.fps()) as u64,
                    monotonic_us: 0,
                };
                let report = pipeline.process(black_box(&frame), meta);
                found += usize::from(report.position.is_some());
                fitted += usize::from(report.detection.best.is_some_and(|(_, s)| s.fitted()));
            }
            "threshold" => {
                found += threshold::apply(black_box(&frame), Threshold::Auto, &mut mask).1;
            }
            "threshold-uyvy" | "threshold-grey" => {
                let frame = repacked_of(k)?;
                found += threshold::apply(black_box(&frame), Threshold::Auto, &mut mask).1;
            }
            "none" => {}
            _ => return Err(USAGE.into()),
        }
    }
    println!("{stage}: {frames} frames of {scene_name} at {size}, result {found}, fitted {fitted}");
    Ok(())
}
