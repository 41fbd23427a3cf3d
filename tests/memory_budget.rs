//! The memory plan that `--max-memory-mb` is checked against (`glint::budget`) holds to what
//! building the stages really allocates: never less, and not much more, for every detector at
//! sizes from tiny to 4K. If a stage grows a buffer, this fails until the plan counts it.

mod common;

use common::alloc::{bytes_allocated_during, Counting};

use glint::budget;
use glint::detect::aruco::{self, Dictionary};
use glint::detect::streak::StreakModel;
use glint::detect::{DetectorConfig, MaskMethod};
use glint::frame::FrameSize;
use glint::pipeline::{Pipeline, PipelineConfig};
use glint::source::dump::DumpSource;
use glint::track::MarkerTracker;

#[global_allocator]
static GLOBAL: Counting = Counting;

const SIZES: [&str; 5] = ["64x48", "640x480", "1280x720", "1920x1080", "3840x2160"];
/// Slack allowed above the measurement: a quarter, plus the fixed tables' allowance.
const SLACK_FRACTION: u64 = 4;
const SLACK_BYTES: u64 = 128 * 1024;

fn assert_close(what: &str, size: FrameSize, planned: u64, measured: u64) {
    assert!(
        planned >= measured,
        "{what} at {size}: planned {planned} bytes, allocated {measured}"
    );
    assert!(
        planned - measured <= measured / SLACK_FRACTION + SLACK_BYTES,
        "{what} at {size}: planned {planned} bytes, far above the {measured} allocated"
    );
}

fn led(size: FrameSize, method: MaskMethod) -> u64 {
    led_with(size, method, StreakModel::Ramps)
}

fn led_with(size: FrameSize, method: MaskMethod, streak_model: StreakModel) -> u64 {
    let config = PipelineConfig {
        detector: DetectorConfig {
            method,
            streak_model,
            ..DetectorConfig::default()
        },
        ..PipelineConfig::default()
    };
    bytes_allocated_during(|| {
        let source = DumpSource::try_new(std::io::empty(), size, 30.0).unwrap();
        let pipeline = Pipeline::new(size, config).unwrap();
        std::hint::black_box((source, pipeline));
    })
}

#[test]
fn the_led_pipeline_allocates_what_the_plan_says() {
    for size in SIZES {
        let size: FrameSize = size.parse().unwrap();
        let planned = budget::frame_bytes(size) + budget::led_detector_bytes(size);
        assert_close(
            "saturation",
            size,
            planned,
            led(size, MaskMethod::Saturation),
        );
        for frames in [1, 9, 63] {
            let method = MaskMethod::BackgroundDifference {
                diff_luma: 60,
                frames,
            };
            let planned = planned + budget::background_bytes(size, frames);
            assert_close("bgdiff", size, planned, led(size, method));
        }
        let fit_planned = planned + budget::fit_floor_bytes(size);
        for model in [StreakModel::Fit, StreakModel::Auto] {
            let measured = led_with(size, MaskMethod::Saturation, model);
            assert_close("streak fit", size, fit_planned, measured);
        }
    }
}

#[test]
fn the_marker_pipeline_allocates_what_the_plan_says() {
    for size in SIZES {
        let size: FrameSize = size.parse().unwrap();
        let dictionary = Dictionary::Aruco6x6_250;
        let max_perimeter_px = aruco::DetectorConfig::new(dictionary).max_perimeter_px;
        let planned =
            budget::frame_bytes(size) + budget::marker_detector_bytes(size, max_perimeter_px);
        let measured = bytes_allocated_during(|| {
            let source = DumpSource::try_new(std::io::empty(), size, 30.0).unwrap();
            let tracker = MarkerTracker::new(size, dictionary, 7).unwrap();
            std::hint::black_box((source, Pipeline::marker(tracker)));
        });
        assert_close("aruco", size, planned, measured);
    }
}

#[test]
fn the_marker_recheck_allocates_what_the_plan_says() {
    use glint::geometry::recheck::MarkerRecheck;
    use glint::geometry::{MarkerPlacement, Point};
    let map = [MarkerPlacement {
        id: 3,
        size: 18.0,
        origin: Point::new(0.0, 0.0),
    }];
    for size in SIZES {
        let size: FrameSize = size.parse().unwrap();
        let dictionary = Dictionary::Aruco6x6_250;
        let max_perimeter_px = aruco::DetectorConfig::new(dictionary).max_perimeter_px;
        // As `glint track` plans it (src/cli/track.rs).
        let planned = budget::marker_detector_bytes(size, max_perimeter_px)
            + MarkerRecheck::copy_bytes(size) as u64;
        let measured = bytes_allocated_during(|| {
            std::hint::black_box(MarkerRecheck::new(size, dictionary, &map, 0.2).unwrap());
        });
        assert_close("marker re-check", size, planned, measured);
    }
}
