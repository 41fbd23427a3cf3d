//! The marker re-check allocates nothing per frame on any thread: the tracking thread's copy
//! and verdicts, and the worker thread's checks (markers steady, a knock refitted while a
//! marker moved on the floor is left out, and frames without any marker searched whole). The
//! counting allocator counts every thread here, so this file holds this one test.

mod common;

use common::alloc::{allocations_on_every_thread_during, Counting};
use common::view::{fit_first_frame, meta_at_30_fps, rendered};

use glint::detect::aruco::Dictionary;
use glint::frame::{Frame, FrameSize};
use glint::geometry::recheck::{MarkerRecheck, RECHECK_PERIOD_FRAMES, VERDICT_LAG_FRAMES};
use glint::geometry::{FloorStage, FloorUnit};
use glint::pipeline::{Pipeline, PipelineConfig};
use glint_tools::scene::{Bump, Scene};

#[global_allocator]
static GLOBAL: Counting = Counting;

#[test]
fn the_recheck_worker_and_the_tracking_thread_allocate_nothing_per_frame() {
    let mut config = Scene::preset_config("knocked").unwrap();
    let view = config.view.clone().unwrap();
    let knock = view.knock.unwrap().frame;
    config.view.as_mut().unwrap().bump = Some(Bump {
        frame: knock,
        marker: 3,
        dx_cm: 2.5,
        dy_cm: 1.0,
        turn_deg: 0.0,
    });
    let scene = Scene::new(config).unwrap();
    let size = FrameSize::new(scene.width_px(), scene.height_px()).unwrap();
    // The camera as glint fits it to the first frame's six markers.
    let (map, fit) = fit_first_frame(&scene, &view);
    let recheck =
        MarkerRecheck::new(size, Dictionary::Aruco6x6_250, &map, fit.rms_residual_px).unwrap();
    let mut pipeline = Pipeline::new(size, PipelineConfig::default())
        .unwrap()
        .with_floor(FloorStage::from_camera(fit.camera, FloorUnit::Cm))
        .with_recheck(recheck);

    // Two checks before the knock (the first refines every marker, the second finds them
    // steady), the check of the knocked frame and its verdict, then two periods of black
    // frames (a check finds no marker around where the pose puts them, nor in the whole frame).
    let (period, lag) = (RECHECK_PERIOD_FRAMES as usize, VERDICT_LAG_FRAMES as usize);
    let start = knock - 2 * period;
    let mut frames: Vec<(usize, Vec<u8>)> = (start..=knock + lag)
        .map(|i| (i, rendered(&scene, i)))
        .collect();
    let end = frames.len() + start;
    frames.extend((end..end + 2 * period).map(|i| (i, vec![0u8; scene.frame_len_bytes()])));
    let mut found = 0usize;
    let allocations = allocations_on_every_thread_during(|| {
        for (i, bytes) in &frames {
            let frame = Frame::new_checked(bytes, size, size.row_bytes()).unwrap();
            let meta = meta_at_30_fps(*i);
            let report = pipeline.process(&frame, meta);
            found += usize::from(report.floor.is_some());
        }
    });
    assert_eq!(allocations, 0, "allocations on any thread");
    assert!(found > 0, "the LED was mapped to the floor");
    let camera = pipeline.floor().unwrap().camera().unwrap();
    assert_ne!(camera.pose, fit.camera.pose, "the knock was refitted");
    assert_eq!(camera.lens, fit.camera.lens);
}
