//! `--streak-model auto` fits the streaks whose ramps' reading is doubtful and only those
//! (`src/detect/cascade.rs`): a spot whose edge is resolved (a glow) is fitted, so is a frame
//! whose ramps contradict themselves (still, with tips a streak apart; short lines of sharp
//! disks keep their single-frame speed so), and the sharp disk of
//! `fast-line` is read by the ramps alone, at the ramps' cost, as are `circles`' arcs of one
//! across a grout line. Streaks along a grout line, whose ends' floor is darker than their
//! sides', hold the bounds.

mod common;

use common::{in_process, line_through};
use glint::detect::streak::StreakModel;
use glint::frame::{Frame, FrameSize};
use glint::track::VelocityMethod;
use glint_tools::scene::{Point, Scene, Spot, Squeeze, SweepPoint, Visibility};

/// What a visible frame in which the LED was found gave.
struct Read {
    /// Whether its streak was fitted.
    fitted: bool,
    /// The head's error (px), in frames after the first found (which has no previous
    /// position).
    head_px: Option<f64>,
    /// Where its velocity was read from its own streak, that speed's error relative to the
    /// true speed.
    speed_error: Option<f64>,
}

/// The frames of `scene` up to `frames` in which the LED was visible and found.
fn run(scene: &Scene, frames: usize) -> Vec<Read> {
    let size = FrameSize::new(scene.width_px(), scene.height_px()).unwrap();
    let mut pipeline = in_process::pipeline(scene, StreakModel::Auto);
    let mut bytes = vec![0u8; scene.frame_len_bytes()];
    let mut out = Vec::new();
    for index in 0..frames.min(scene.frame_count()) {
        let truth = scene.render(index, &mut bytes).unwrap();
        let frame = Frame::new_checked(&bytes, size, size.row_bytes()).unwrap();
        let report = pipeline.process(&frame, in_process::meta(scene, index));
        let (Some(e), Some((_, streak))) = (report.position, report.detection.best) else {
            continue;
        };
        if truth.visible != Visibility::Visible {
            continue;
        }
        let (x, y) = (truth.x_px.unwrap(), truth.y_px.unwrap());
        let head_px = (!out.is_empty())
            .then(|| (f64::from(e.position_px.0) - x).hypot(f64::from(e.position_px.1) - y));
        let speed_error = match e.velocity_px_s {
            Some(((vx, vy), VelocityMethod::Streak)) => {
                let true_speed = truth.vx_px_s.unwrap().hypot(truth.vy_px_s.unwrap());
                let speed = f64::from(vx).hypot(f64::from(vy));
                Some((speed - true_speed).abs() / true_speed)
            }
            _ => None,
        };
        out.push(Read {
            fitted: streak.fitted(),
            head_px,
            speed_error,
        });
    }
    out
}

/// The median and the 95th percentile (nearest rank).
fn median_p95(values: &mut [f64]) -> (f64, f64) {
    values.sort_by(f64::total_cmp);
    let at =
        |q: f64| values[((q * values.len() as f64).ceil() as usize).clamp(1, values.len()) - 1];
    (at(0.5), at(0.95))
}

/// `point` at the picture's centre, where the lens leaves its spot round: these tests hold
/// one case of the models' choice each (the sweep's lens is tested by the sweep, with the
/// detector told the lens's map).
fn round(mut point: SweepPoint) -> SweepPoint {
    point.lens = Squeeze::NONE;
    point
}

/// Point `index` of the sweep of `seed`, drawn round, run in full: the point, and its frames
/// (at least `min_found` found).
fn run_round_point(seed: u64, index: usize, min_found: usize) -> (SweepPoint, Vec<Read>) {
    let point = round(SweepPoint::new(seed, index));
    let frames = run(&Scene::new(point.config()).unwrap(), usize::MAX);
    assert!(
        frames.len() >= min_found,
        "{point}: found in {} frames",
        frames.len()
    );
    (point, frames)
}

/// Point 14 of seed 11: a 60 px streak of a spot in a glow 4.2× its core, which the ramps
/// read 0.69 / 1.03 px off at the head (median / p95; the bound 0.5 / 1.5 px) and the
/// fit 0.15 / 0.19 px. Its edge falls over the glow's flank, pixels wide: every frame is
/// fitted, and the head holds the bound.
#[test]
fn a_streak_in_a_glow_the_ramps_misread_is_fitted() {
    let (point, frames) = run_round_point(11, 14, 4);
    assert!(
        frames.iter().all(|f| f.fitted),
        "{point}: fitted {:?}",
        frames.iter().map(|f| f.fitted).collect::<Vec<_>>()
    );
    let mut heads: Vec<f64> = frames.iter().filter_map(|f| f.head_px).collect();
    let (median, p95) = median_p95(&mut heads);
    assert!(
        median <= 0.5 && p95 <= 1.5,
        "{point}: head {median:.2} / {p95:.2} px"
    );
}

/// `fast-line`'s 60 px streaks of a sharp disk: its edge falls within a pixel, the ramps read
/// it, and no frame pays for the fit.
#[test]
fn a_sharp_disk_s_streak_is_left_to_the_ramps() {
    let scene = Scene::preset("fast-line").unwrap();
    let frames = run(&scene, 32);
    assert!(frames.len() >= 30, "found in {} frames of 32", frames.len());
    let fitted = frames.iter().filter(|f| f.fitted).count();
    assert_eq!(fitted, 0, "{fitted} of {} frames fitted", frames.len());
}

/// Point 179 of seed 11: a 1.3 px disk on a 19.4 px arc (radius 25 px), whose edge is sharp.
/// In one frame the ramps called it still (the blob no longer than the spot, by its caps)
/// while their own tips lay 19.3 px apart, five times the spot's width; the head was then
/// carried from the middle, 5.65 px off. That reading contradicts itself and is fitted. The
/// arc is also bent (its middle 1.9 px off its chord, more than a quarter of its thickness),
/// and a bent streak is now fitted in every frame; the head holds the bound in every frame.
#[test]
fn a_streak_the_ramps_call_still_across_their_own_path_is_fitted() {
    let (point, frames) = run_round_point(11, 179, 8);
    let fitted = frames.iter().filter(|f| f.fitted).count();
    assert!(
        fitted == frames.len(),
        "{point}: fitted in {fitted} of {} frames",
        frames.len()
    );
    let mut heads: Vec<f64> = frames.iter().filter_map(|f| f.head_px).collect();
    let (median, p95) = median_p95(&mut heads);
    assert!(
        median <= 0.5 && p95 <= 1.5,
        "{point}: head {median:.2} / {p95:.2} px"
    );
}

/// `circles`: 18.8 px arcs of a sharp disk on a 20 px circle, over a floor of grout lines. The
/// ray across an arc's middle towards the circle's centre runs along a dark grout line in one
/// frame of five, and away from it along another in a second: read there, the floor lies far
/// below the floor beside the streak, and the edge's fall (8.9 and 4.1 px on that side, under
/// 1.3 px on the other) passed for a resolved edge, so those frames were fitted (the fit reads
/// these arcs' middle 0.25 px off in the median against the ramps' 0.06 px,
/// `tests/replay_accuracy.rs`): 35 of the first 60 frames. The edge falls to the brighter of
/// the two sides' floors, and those frames are left to the ramps (5 of 60 fitted). One more
/// heading of the five falls over 0.99–1.01 px, at `SHARP_EDGE_PX` itself, and may be fitted:
/// at most one frame in five.
#[test]
fn a_grout_line_along_the_ray_does_not_make_a_sharp_edge_resolved() {
    let scene = Scene::preset("circles").unwrap();
    let frames = run(&scene, 60);
    assert!(frames.len() >= 55, "found in {} frames of 60", frames.len());
    let fitted = frames.iter().filter(|f| f.fitted).count();
    assert!(
        fitted * 5 <= frames.len(),
        "{fitted} of {} frames fitted",
        frames.len()
    );
}

/// Short lines of sharp disks, sweep points 37 and 161 of seed 11 and 97 of seed 12 (1.4–2.2
/// px disks at 2.8–13× the clip on 8–10 px lines). In a frame or two of each, the ramps call
/// the blob still by its caps while their own tips lie a whole streak apart; with that reading
/// taken, the frame has no single-frame speed (the velocity comes from the middles' motion):
/// two, two and four frames of ten without the rule. That reading contradicts itself and is
/// fitted, and every frame after the first reads its speed from its streak.
#[test]
fn short_disk_streaks_the_ramps_call_still_keep_their_speed() {
    for (seed, index) in [(11, 37), (11, 161), (12, 97)] {
        let (point, frames) = run_round_point(seed, index, 4);
        let without: Vec<usize> = (1..frames.len())
            .filter(|&i| frames[i].speed_error.is_none())
            .collect();
        assert!(
            without.is_empty(),
            "{point}: frames {without:?} of {} without a speed from the streak",
            frames.len()
        );
    }
}

/// Spots whose edge reads either side of `SHARP_EDGE_PX` from frame to frame: point 155 of
/// seed 13 (a Gaussian of σ 1.28 px at 15× the clip on a 15.3 px arc) and point 117 of seed
/// 11 (σ 1.50 px at 3.9×, a 10.6 px line). Judged frame by frame, the first was read
/// `FFrFrrrFrF` (F fitted, r the ramps), its speed 3.6 / 6.0 % off (median / p95; the issue's
/// bound 3 / 10 %), and the second fitted in all but its last frame. The edge is judged by the
/// median of its falls over the LED's last frames (alone, that read the first `FFrrrrrrrr`),
/// and an LED whose median has read resolved stays with the fit (`src/detect/cascade.rs`):
/// each is fitted in every frame from its first fitted one, and its single-frame speed holds
/// the bound (the first 1.0 / 6.3 %).
#[test]
fn an_led_whose_edge_reads_either_side_of_sharp_is_read_by_one_model() {
    for (seed, index) in [(13, 155), (11, 117)] {
        let (point, frames) = run_round_point(seed, index, 8);
        let readers: String = frames
            .iter()
            .map(|f| if f.fitted { 'F' } else { 'r' })
            .collect();
        let first_fitted = readers.find('F').unwrap_or(readers.len());
        assert!(
            !readers[first_fitted..].contains('r'),
            "{point}: read {readers}"
        );
        let mut speeds: Vec<f64> = frames
            .iter()
            .skip(1)
            .filter_map(|f| f.speed_error)
            .collect();
        assert!(
            speeds.len() + 1 >= frames.len(),
            "{point}: {} speeds",
            speeds.len()
        );
        let (median, p95) = median_p95(&mut speeds);
        assert!(
            median <= 0.03 && p95 <= 0.10,
            "{point}: read {readers}, speed {:.1} / {:.1} %",
            100.0 * median,
            100.0 * p95
        );
    }
}

/// `fast-line`'s floor with the LED driving along one of its dark grout lines (a robot
/// following a painted line), along `velocity_px_s` (down, up or across the picture) for 12
/// frames of 15 ms exposures, with `spot`, the camera's `gamma` and the floor's `seed`.
fn along_a_grout_line(velocity_px_s: (f64, f64), spot: Spot, gamma: f64, seed: u64) -> Scene {
    const FRAMES: usize = 12;
    let mut config = Scene::preset("fast-line").unwrap().config().clone();
    // The grout line nearest the picture's centre is the first 2 px of a tile: its middle is
    // 1 px in.
    let tile_px = f64::from(config.floor.tile_px);
    let line = |size_px: u32| (0.5 * f64::from(size_px) / tile_px).floor() * tile_px + 1.0;
    let centre = Point::new(line(config.width_px), line(config.height_px));
    let velocity = Point::new(velocity_px_s.0, velocity_px_s.1);
    line_through(&mut config, centre, velocity, FRAMES);
    config.exposure_us = 15_000;
    config.seed = seed;
    config.camera.gamma = gamma;
    if let Spot::Gaussian { .. } = spot {
        config.led.glow_peak = 0.0;
    }
    config.led.spot = spot;
    Scene::new(config).unwrap()
}

/// A streak along a dark line of the floor: its body's sides lie on the tile beside the
/// line, and its ends' axis on the line, some 40 luma darker. The ramps' line profile cuts
/// both at levels set from the sides' floor, so that the ends fall through them early: on a
/// σ 1.5 px spot they read the speed 2.4–3.5 % slow on average at gammas 1.8–2.4 (README,
/// "Along a grout line again"). The default fits spots whose edge is resolved with the floor
/// it has learned under them, and a narrow spot's short path (`cascade::NARROW_SPOT_PX`):
/// over Gaussian spots of σ 0.9–2.5 px and a bloom, gamma 1.8–2.4, down and across at
/// 1000 px/s (15 px paths) and up and back at 700 px/s (10.5 px), each case holds the
/// issue's bounds on the single frame's speed (3 % median, 10 % p95) and the head's p95
/// (1.5 px). Before the narrow spots were fitted, the σ 0.9 px spot's edge read sharp on the
/// line and the ramps' disk rule read it at 10.8–11.7 % (p95) going up. NOT YET HELD, so not
/// swept: a linear camera (gamma 1), whose σ 1.5 px spot the ramps read 3.3–5.9 % slow in the
/// median.
#[test]
fn streaks_along_a_grout_line_hold_the_bounds() {
    let spots = [
        Spot::Gaussian { sigma_px: 0.9 },
        Spot::Gaussian { sigma_px: 1.2 },
        Spot::Gaussian { sigma_px: 1.5 },
        Spot::Gaussian { sigma_px: 2.5 },
        Spot::Bloom {
            sigma_px: 1.2,
            glow_sigma_px: 4.8,
            glow_ratio: 0.05,
        },
    ];
    let paths = [
        ("down", (0.0, 1000.0)),
        ("across", (1000.0, 0.0)),
        ("up", (0.0, -700.0)),
        ("back", (-700.0, 0.0)),
    ];
    let mut out = Vec::new();
    let mut case = 0u64;
    for spot in spots {
        for gamma in [1.8, 2.1, 2.4] {
            for (name, velocity) in paths {
                case += 1;
                let scene = along_a_grout_line(velocity, spot, gamma, 1 + case % 3);
                let frames = run(&scene, usize::MAX);
                assert!(
                    frames.len() >= 10,
                    "{spot:?}, gamma {gamma}, {name}: found in {} frames",
                    frames.len()
                );
                let mut speeds: Vec<f64> = frames.iter().filter_map(|f| f.speed_error).collect();
                let mut heads: Vec<f64> = frames.iter().filter_map(|f| f.head_px).collect();
                assert!(
                    speeds.len() >= 9,
                    "{spot:?}, gamma {gamma}, {name}: {} frames with a speed from the streak",
                    speeds.len()
                );
                let (speed_median, speed_p95) = median_p95(&mut speeds);
                let (_, head_p95) = median_p95(&mut heads);
                if speed_median > 0.03 || speed_p95 > 0.10 || head_p95 > 1.5 {
                    out.push(format!(
                        "{spot:?}, gamma {gamma}, {name}: speed {:.1} / {:.1} %, head p95 \
                         {head_p95:.2} px",
                        100.0 * speed_median,
                        100.0 * speed_p95
                    ));
                }
            }
        }
    }
    assert!(out.is_empty(), "{}", out.join("\n"));
}

/// Sharp spots under 3 px of radius (`cascade::NARROW_SPOT_PX`), each read by the ramps in
/// all but a frame or none before: point 159 of seed 11 (a Gaussian of σ 0.96 px on a
/// 14.3 px arc), 93 of seed 11 (a 1.55 px disk, an 8.8 px line) and 25 and 33 of seed 12
/// (2.16 and 2.63 px disks, 11.7 and 8.3 px lines). The ramps read their single-frame speed
/// 0.9–3.2 % off in the median and 10.2–15.8 % at the p95 (the bounds: 3 and 10 %).
/// Fitted, each holds the speed's bounds and the head's (0.5 px median, 1.5 px p95).
#[test]
fn narrow_sharp_spots_are_fitted_and_hold_the_bounds() {
    let mut out = Vec::new();
    for (seed, index) in [(11, 159), (11, 93), (12, 25), (12, 33)] {
        let (point, frames) = run_round_point(seed, index, 8);
        assert!(frames.iter().any(|f| f.fitted), "{point}: no frame fitted");
        let mut speeds: Vec<f64> = frames.iter().filter_map(|f| f.speed_error).collect();
        let mut heads: Vec<f64> = frames.iter().filter_map(|f| f.head_px).collect();
        assert!(
            speeds.len() + 1 >= frames.len(),
            "{point}: {} of {} frames with a speed from the streak",
            speeds.len(),
            frames.len()
        );
        let (speed_median, speed_p95) = median_p95(&mut speeds);
        let (head_median, head_p95) = median_p95(&mut heads);
        if speed_median > 0.03 || speed_p95 > 0.10 || head_median > 0.5 || head_p95 > 1.5 {
            out.push(format!(
                "{point}: speed {:.1} / {:.1} %, head {head_median:.2} / {head_p95:.2} px",
                100.0 * speed_median,
                100.0 * speed_p95
            ));
        }
    }
    assert!(out.is_empty(), "{}", out.join("\n"));
}
