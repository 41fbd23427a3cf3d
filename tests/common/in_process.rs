//! The tracker run in process on a rendered scene: its pipeline, and each frame's metadata as
//! a camera delivering the scene at its rate would give it.

use glint::detect::streak::StreakModel;
use glint::detect::DetectorConfig;
use glint::frame::FrameSize;
use glint::pipeline::{Pipeline, PipelineConfig};
use glint::source::FrameMeta;
use glint::track::TrackerConfig;
use glint_tools::scene::Scene;

/// A pipeline for `scene`'s frames, its exposure known, measuring streaks with `model`.
pub fn pipeline(scene: &Scene, model: StreakModel) -> Pipeline {
    let size = FrameSize::new(scene.width_px(), scene.height_px()).unwrap();
    let config = PipelineConfig {
        tracker: TrackerConfig {
            exposure_us: Some(scene.exposure_us()),
        },
        detector: DetectorConfig {
            streak_model: model,
            ..DetectorConfig::default()
        },
    };
    Pipeline::new(size, config).unwrap()
}

/// Frame `index` of `scene`, none dropped, stamped at the scene's frame rate.
pub fn meta(scene: &Scene, index: usize) -> FrameMeta {
    let t_us = (index as f64 * 1e6 / scene.fps()) as u64;
    FrameMeta {
        index: index as u64,
        sequence: index as u64,
        dropped: 0,
        timestamp_us: t_us,
        monotonic_us: t_us,
    }
}
