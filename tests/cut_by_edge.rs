//! An LED driving into view and out of it again: a streak whose path runs past the frame's
//! edge is flagged as cut (its middle and length are the visible part's), and a streak wholly
//! in view is not, for a sharp disk, a Gaussian spot and a bloom; and `glint track` says so in
//! its JSON lines (`cut_by_edge`).

mod common;

use glint::detect::{Detector, DetectorConfig};
use glint::frame::{Frame, FrameSize};
use glint_tools::scene::{Point, Scene, Spot, Trajectory, Visibility};

/// A line across the picture at 2400 px/s (60 px streaks at 25 ms), from 70 px left of it to
/// past its right edge, with `spot`.
fn scene(spot: Spot) -> Scene {
    let mut config = Scene::preset_config("fast-line").expect("preset");
    config.led.spot = spot;
    config.frame_count = 12;
    config.trajectory = Trajectory::Line {
        start_px: Point::new(-70.0, 240.0),
        velocity_px_s: Point::new(2400.0, 0.0),
    };
    Scene::new(config).expect("scene")
}

#[test]
fn a_streak_is_cut_exactly_where_its_path_runs_past_the_frame_s_edge() {
    let spots = [
        Spot::Disk,
        Spot::Gaussian { sigma_px: 1.5 },
        Spot::Bloom {
            sigma_px: 1.2,
            glow_sigma_px: 6.0,
            glow_ratio: 0.05,
        },
    ];
    for spot in spots {
        let scene = scene(spot);
        let size = FrameSize::new(scene.width_px(), scene.height_px()).unwrap();
        let width_px = f64::from(scene.width_px());
        let mut detector = Detector::new(size, DetectorConfig::default()).unwrap();
        let mut bytes = vec![0u8; scene.frame_len_bytes()];
        let (mut cut, mut whole) = (0, 0);
        for index in 0..scene.config().frame_count {
            let truth = scene.render(index, &mut bytes).unwrap();
            let frame = Frame::new_checked(&bytes, size, size.row_bytes()).unwrap();
            let Some((_, streak)) = detector.detect(&frame).best else {
                continue;
            };
            match truth.visible {
                Visibility::Visible => {
                    assert!(!streak.cut_by_edge, "{spot:?}, frame {index}: in view, cut");
                    whole += 1;
                }
                Visibility::Partial => {
                    // The path's ends: where the exposure ended, and as far back from the
                    // middle.
                    let end_x = truth.x_px.unwrap();
                    let start_x = 2.0 * truth.path_mid_x_px.unwrap() - end_x;
                    if start_x.min(end_x) < 0.0 || start_x.max(end_x) > width_px - 1.0 {
                        assert!(streak.cut_by_edge, "{spot:?}, frame {index}: past the edge");
                        cut += 1;
                    }
                }
                Visibility::Hidden => {}
            }
        }
        // The LED drives in, across and out: both kinds of frame are seen.
        assert!(cut >= 2 && whole >= 3, "{spot:?}: {cut} cut, {whole} whole");
    }
}

/// `glint track` says which frames are cut: `cut_by_edge` on every found frame whose path
/// runs past the edge, on none wholly in view.
#[test]
fn glint_track_says_which_frames_are_cut_by_the_edge() {
    let rendered = common::render_scene(scene(Spot::Disk));
    let out = common::track(&rendered, &[]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let lines = common::parse_jsonl(&out.stdout);
    let width_px = f64::from(rendered.scene.width_px());
    let (mut cut, mut whole) = (0, 0);
    for (line, truth) in lines.iter().zip(&rendered.truths) {
        if line["found"] != true {
            continue;
        }
        let flagged = line["cut_by_edge"] == true;
        match truth.visible {
            Visibility::Visible => {
                assert!(!flagged, "frame {}: in view, cut", truth.frame);
                whole += 1;
            }
            Visibility::Partial => {
                let end_x = truth.x_px.unwrap();
                let start_x = 2.0 * truth.path_mid_x_px.unwrap() - end_x;
                if start_x.min(end_x) < 0.0 || start_x.max(end_x) > width_px - 1.0 {
                    assert!(flagged, "frame {}: past the edge, not cut", truth.frame);
                    cut += 1;
                }
            }
            Visibility::Hidden => {}
        }
    }
    assert!(cut >= 1 && whole >= 3, "{cut} cut, {whole} whole");
}
