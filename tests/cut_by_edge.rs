//! An LED driving into view and out of it again: a streak whose path runs past the frame's
//! edge is flagged as cut at the end that runs out (its middle and length are the visible
//! part's), and a streak wholly in view is not, for a sharp disk, a Gaussian spot and a bloom;
//! `glint track` says so in its JSON lines (`cut_by_edge`), and an LED driving out of view on
//! a track is placed and timed by the track.

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

/// A sharp disk, a Gaussian spot and a bloom.
const SPOTS: [Spot; 3] = [
    Spot::Disk,
    Spot::Gaussian { sigma_px: 1.5 },
    Spot::Bloom {
        sigma_px: 1.2,
        glow_sigma_px: 6.0,
        glow_ratio: 0.05,
    },
];

#[test]
fn a_streak_is_cut_exactly_where_its_path_runs_past_the_frame_s_edge() {
    for spot in SPOTS {
        let scene = scene(spot);
        let size = FrameSize::new(scene.width_px(), scene.height_px()).unwrap();
        let width_px = f64::from(scene.width_px());
        let mut detector = Detector::new(size, DetectorConfig::default()).unwrap();
        let mut bytes = vec![0u8; scene.frame_len_bytes()];
        let (mut cut, mut whole, mut ends) = (0, 0, 0);
        for index in 0..scene.config().frame_count {
            let truth = scene.render(index, &mut bytes).unwrap();
            let frame = Frame::new_checked(&bytes, size, size.row_bytes()).unwrap();
            let Some((_, streak)) = detector.detect(&frame).best else {
                continue;
            };
            match truth.visible {
                Visibility::Visible => {
                    assert!(
                        !streak.cut_by_edge(),
                        "{spot:?}, frame {index}: in view, cut"
                    );
                    whole += 1;
                }
                Visibility::Partial => {
                    // The path's ends: where the exposure ended, and as far back from the
                    // middle.
                    let end_x = truth.x_px.unwrap();
                    let start_x = 2.0 * truth.path_mid_x_px.unwrap() - end_x;
                    if start_x.min(end_x) < 0.0 || start_x.max(end_x) > width_px - 1.0 {
                        assert!(
                            streak.cut_by_edge(),
                            "{spot:?}, frame {index}: past the edge"
                        );
                        // With 8 px of the path in view, the end on the side the path runs
                        // out of the picture is the one cut, and only it (the LED moves to
                        // the right: in at the left edge, out at the right).
                        let in_view_px = end_x.min(width_px - 1.0) - start_x.max(0.0);
                        if in_view_px >= 8.0 {
                            let [a, b] = streak.ends_px;
                            let (left, right) = if a.0 <= b.0 { (0, 1) } else { (1, 0) };
                            let out_left = start_x < 0.0;
                            assert_eq!(
                                (streak.cut_ends[left], streak.cut_ends[right]),
                                (out_left, !out_left),
                                "{spot:?}, frame {index}: the other end cut"
                            );
                            ends += 1;
                        }
                        cut += 1;
                    }
                }
                Visibility::Hidden => {}
            }
        }
        // The LED drives in, across and out: both kinds of frame are seen.
        assert!(cut >= 2 && whole >= 3, "{spot:?}: {cut} cut, {whole} whole");
        assert!(ends >= 2, "{spot:?}: {ends} cut ends told");
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

/// An LED driving out of view, through each edge of the picture and a corner, along lines
/// fast and slow and round a circle, as a sharp disk, a Gaussian spot and a bloom. In the
/// frames the edge cut, on a track, the speed is the track's (within 3 %) and the head within
/// 1.5 px: carried from the tail along the track's heading where the tail is in view, and
/// from the head before where only the last sliver of the light is (the slow line). Read from
/// the visible part, the head was at the cut, 8–9 px short of the LED at 2400 px/s, and the
/// speed 14–15 % slow; the sliver's visible middle was 12–13 px short.
#[test]
fn an_led_driving_out_of_view_is_placed_and_timed_by_its_track() {
    let trajectories = [
        // Out through the right, left, bottom and top edges, and a corner.
        line((-70.0, 240.0), (2400.0, 0.0)),
        line((700.0, 200.0), (-2000.0, 300.0)),
        line((300.0, -30.0), (400.0, 1800.0)),
        line((350.0, 520.0), (-500.0, -2100.0)),
        line((-40.0, -60.0), (1900.0, 1500.0)),
        // Slowly, the edge cutting two or three frames in a row.
        line((560.0, 300.0), (450.0, -100.0)),
        // Round a circle whose right side lies outside the picture, 20° a frame.
        Trajectory::Circle {
            centre_px: Point::new(560.0, 240.0),
            radius_px: 140.0,
            rev_per_s: 1.65,
            phase_rad: 2.0,
        },
    ];
    let (mut from_tail, mut slivers) = (0, 0);
    for spot in SPOTS {
        for trajectory in &trajectories {
            let mut config = Scene::preset_config("fast-line").expect("preset");
            config.led.spot = spot;
            config.frame_count = 16;
            config.trajectory = trajectory.clone();
            let rendered = common::render_scene(Scene::new(config).expect("scene"));
            let out = common::track(&rendered, &[]);
            assert!(out.status.success());
            let lines = common::parse_jsonl(&out.stdout);
            let exposure_s = f64::from(rendered.scene.exposure_us()) * 1e-6;
            let (width_px, height_px) = (
                f64::from(rendered.scene.width_px()),
                f64::from(rendered.scene.height_px()),
            );
            // Inside the picture by `margin_px` (negative: outside by as much).
            let inside = |(x, y): (f64, f64), margin_px: f64| {
                x >= margin_px
                    && y >= margin_px
                    && x <= width_px - 1.0 - margin_px
                    && y <= height_px - 1.0 - margin_px
            };
            let mut tracked_before = false;
            for (line, truth) in lines.iter().zip(&rendered.truths) {
                let found = line["found"] == true;
                let (Some(x), Some(y)) = (truth.x_px, truth.y_px) else {
                    tracked_before = false;
                    continue;
                };
                let tail = trajectory.motion(truth.t_s - exposure_s).position_px;
                let head_out = !inside((x, y), -1.0);
                let cut = line["cut_by_edge"] == true;
                let what = format!("{spot:?}, {trajectory:?}, frame {}", truth.frame);
                if head_out && tracked_before {
                    assert!(found && cut, "{what}: not found cut");
                }
                if cut && tracked_before {
                    // The speed is the track's, wherever the head is.
                    let speed = line["vx"]
                        .as_f64()
                        .unwrap()
                        .hypot(line["vy"].as_f64().unwrap());
                    let true_speed = truth.vx_px_s.unwrap().hypot(truth.vy_px_s.unwrap());
                    let error = (speed - true_speed).abs() / true_speed;
                    assert!(error <= 0.03, "{what}: speed {:.1} % off", 100.0 * error);
                    // The head from the tail where it is a spot's reach inside the picture
                    // with 8 px of path; with less of the LED in view (the last sliver of its
                    // light), from the head before.
                    assert_eq!(line["pos_method"], "head", "{what}");
                    let (rx, ry) = (line["x"].as_f64().unwrap(), line["y"].as_f64().unwrap());
                    let head_px = (rx - x).hypot(ry - y);
                    assert!(head_px <= 1.5, "{what}: head {head_px:.2} px off");
                    let tail_in = inside((tail.x, tail.y), 6.0)
                        && (x - tail.x).abs().max((y - tail.y).abs()) > 8.0;
                    if tail_in {
                        from_tail += 1;
                    } else {
                        slivers += 1;
                    }
                }
                tracked_before = found && line["pos_method"] == "head";
            }
        }
    }
    // Every scene has a frame leaving with its tail in view, and the slow line has the last
    // sliver of its light too.
    assert!(
        from_tail >= 18 && slivers >= 1,
        "{from_tail} from the tail, {slivers} slivers"
    );
}

fn line(start: (f64, f64), velocity: (f64, f64)) -> Trajectory {
    Trajectory::Line {
        start_px: Point::new(start.0, start.1),
        velocity_px_s: Point::new(velocity.0, velocity.1),
    }
}

/// An LED that drives to the right edge, slowing, and parks there with its light cut by it,
/// its centre 3 px inside to 0.5 px outside the picture. Every cut frame gives the visible
/// part's middle (within a spot's reach of the LED: 0.3–5.4 px here) and no velocity, and the
/// parked positions stay put. Its run's motion carried into the frames cut in a row, it
/// outran the parked LED by 23 px a frame; carried into the first cut frame at the speed it
/// had before it slowed, that frame's head landed 14–18 px past where it stopped.
#[test]
fn an_led_parked_at_the_edge_is_not_carried_away() {
    for spot in SPOTS {
        for to_x in [636.0, 638.0, 639.0, 640.5] {
            let mut config = Scene::preset_config("fast-line").expect("preset");
            config.led.spot = spot;
            config.frame_count = 24;
            config.trajectory = Trajectory::Arrive {
                from_px: Point::new(450.0, 240.0),
                to_px: Point::new(to_x, 240.0),
                move_s: 0.3,
                arrive_s: 0.35,
                then_velocity_px_s: Point::new(0.0, 0.0),
            };
            let rendered = common::render_scene(Scene::new(config).expect("scene"));
            let out = common::track(&rendered, &[]);
            assert!(out.status.success());
            let lines = common::parse_jsonl(&out.stdout);
            let mut xs = Vec::new();
            for (line, truth) in lines.iter().zip(&rendered.truths) {
                let what = format!("{spot:?}, parked at {to_x}, frame {}", truth.frame);
                // Parked from frame 10.5 (at 30 fps): found from two frames after.
                if truth.frame >= 12 {
                    assert_eq!(line["found"], true, "{what}");
                    xs.push(line["x"].as_f64().unwrap());
                }
                if line["cut_by_edge"] == true {
                    let (x, y) = (line["x"].as_f64().unwrap(), line["y"].as_f64().unwrap());
                    let off_px = (x - truth.x_px.unwrap()).hypot(y - truth.y_px.unwrap());
                    assert!(off_px <= 8.0, "{what}: {off_px:.1} px off");
                    assert_eq!(line["pos_method"], "mid", "{what}");
                    assert!(line["vx"].is_null(), "{what}: a velocity");
                }
            }
            let spread_px = xs.iter().cloned().fold(f64::MIN, f64::max)
                - xs.iter().cloned().fold(f64::MAX, f64::min);
            assert!(
                spread_px <= 2.0,
                "{spot:?}, parked at {to_x}: moved {spread_px:.1} px"
            );
        }
    }
}
