//! The middle of a long, bent streak of a sharp disk: a 60 px arc on circles of 60–200 px, the
//! disk 1.5–3 px in radius, at the brightness, gamma, noise and range of a handful of sweep
//! points (glint's own sweep draws arcs of at most 40 px, and its 60 px streaks are straight).
//!
//! Asserted with `--streak-model auto`: the middle within the middle's bounds
//! (`tests/streak_sweep.rs`). `auto` left a sharp disk to the ramps, whose middle is read for a
//! straight streak: here 0.507 / 1.700 px (median / p95), and 0.245 / 1.667 px once its lines
//! were moved towards the chord; it now fits a bent streak, whose model is an arc.

mod common;

use common::{in_process, quantile};
use glint::detect::streak::StreakModel;
use glint::frame::{Frame, FrameSize};
use glint_tools::scene::{Scene, SpotKind, Squeeze, SweepPath, SweepPoint, Visibility};

const MID_MEDIAN_MAX_PX: f64 = 0.2;
const MID_P95_MAX_PX: f64 = 0.5;
const ARC_PX: f64 = 60.0;

/// The middle's error in every visible frame in which the LED was found.
fn middles(scene: &Scene) -> Vec<f64> {
    let size = FrameSize::new(scene.width_px(), scene.height_px()).unwrap();
    let mut pipeline = in_process::pipeline(scene, StreakModel::Auto);
    let mut bytes = vec![0u8; scene.frame_len_bytes()];
    let mut out = Vec::new();
    for index in 0..scene.frame_count() {
        let truth = scene.render(index, &mut bytes).unwrap();
        let frame = Frame::new_checked(&bytes, size, size.row_bytes()).unwrap();
        let report = pipeline.process(&frame, in_process::meta(scene, index));
        let (Some(e), Visibility::Visible) = (report.position, truth.visible) else {
            continue;
        };
        let (mx, my) = (truth.path_mid_x_px.unwrap(), truth.path_mid_y_px.unwrap());
        out.push((f64::from(e.mid_px.0) - mx).hypot(f64::from(e.mid_px.1) - my));
    }
    out
}

#[test]
fn a_long_bent_streak_s_middle_is_where_the_arc_s_middle_is() {
    let mut all = Vec::new();
    for (n, radius_px) in [60.0, 115.0, 200.0].into_iter().enumerate() {
        for (k, disk_px) in [1.5, 2.3, 3.0].into_iter().enumerate() {
            let mut point = SweepPoint::new(11, 3 * n + k);
            point.spot = SpotKind::Disk;
            point.width_px = disk_px;
            point.path = SweepPath::Arc {
                radius_px,
                length_px: ARC_PX,
            };
            point.lens = Squeeze::NONE;
            let errors = middles(&Scene::new(point.config()).unwrap());
            eprintln!(
                "{point}: middle {:.2} / {:.2} px over {} frames",
                quantile(&errors, 0.5),
                quantile(&errors, 0.95),
                errors.len()
            );
            assert!(
                errors.len() >= 3,
                "{point}: found in {} frames",
                errors.len()
            );
            all.extend(errors);
        }
    }
    let (median, p95) = (quantile(&all, 0.5), quantile(&all, 0.95));
    eprintln!(
        "all: middle {median:.3} / {p95:.3} px over {} frames",
        all.len()
    );
    assert!(median <= MID_MEDIAN_MAX_PX, "middle median {median:.3} px");
    assert!(p95 <= MID_P95_MAX_PX, "middle p95 {p95:.3} px");
}
