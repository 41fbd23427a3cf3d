//! Several robots (`--robots N`) against the scene renderer's truth: crossing paths, two LEDs
//! passing through each other, two robots meeting and standing side by side, a robot leaving
//! the view and coming back, an occlusion, and glare in view all along.
//!
//! For every robot: detected in at least [`MIN_DETECTED`] of its visible frames (counted from
//! the frame after it first moved: a light that has stood still since it appeared is never
//! taken, by design), never a change of the id it is reported under, and the single-robot
//! accuracy bounds of `tests/replay_accuracy.rs` on its unmerged frames. No report anywhere
//! but at a robot: the glare is never a track. The crossing is repeated over a small sweep of
//! LED sizes and brightnesses, exposures, noise and tone curves.

mod common;

use common::shutter_skew;
use glint::frame::{Frame, FrameSize};
use glint::pipeline::{Pipeline, PipelineConfig};
use glint::report::FrameReport;
use glint::source::FrameMeta;
use glint::track::shutter::RollingShutter;
use glint::track::{MultiTracker, TrackerConfig, VelocityMethod};
use glint_tools::scene::{Fleet, Point, Trajectory, Truth, Visibility};

/// The share of a robot's visible frames it must be found in.
const MIN_DETECTED: f64 = 0.99;

/// A report farther than this from every robot is a false report; one this near a robot is
/// that robot (the LEDs are farther apart except while merged).
const REPORT_TOLERANCE_PX: f64 = 3.0;

/// How far from a robot's true middle a report of it may lie when the picture holds less than
/// its whole light: a merged blob's middle lies between the two touching LEDs it holds, a
/// partly hidden LED's visible part within its disk; either is within one LED diameter.
fn tolerance_px(led_radius_px: f64, merged: bool, truth: &Truth) -> f64 {
    if merged || truth.visible == Visibility::Partial {
        REPORT_TOLERANCE_PX + 2.0 * led_radius_px
    } else {
        REPORT_TOLERANCE_PX
    }
}

/// A robot has moved once it is this far from where it started (the static table's drift).
const MOVED_PX: f64 = glint::track::statics::DRIFT_PX as f64;

/// The single-robot bounds (tests/replay_accuracy.rs): streak middle, then current position.
const MID_MEDIAN_MAX_PX: f64 = 0.2;
const MID_P95_MAX_PX: f64 = 0.5;
const POS_MEDIAN_MAX_PX: f64 = 0.5;
const POS_P95_MAX_PX: f64 = 1.5;

fn run(fleet: &Fleet) -> Vec<(FrameReport, Vec<Truth>)> {
    run_through(fleet, None)
}

/// Runs `fleet` through the pipeline, told of a rolling shutter when there is one.
fn run_through(fleet: &Fleet, shutter: Option<RollingShutter>) -> Vec<(FrameReport, Vec<Truth>)> {
    let first = fleet.robot(0).unwrap();
    let size = FrameSize::new(first.width_px(), first.height_px()).unwrap();
    let tracker = TrackerConfig {
        exposure_us: Some(first.exposure_us()),
    };
    let config = PipelineConfig {
        tracker,
        ..PipelineConfig::default()
    };
    let tracks = MultiTracker::new(fleet.robots(), tracker).unwrap();
    let mut pipeline = Pipeline::several(size, config, tracks).unwrap();
    if let Some(shutter) = shutter {
        pipeline = pipeline.with_rolling_shutter(shutter);
    }
    let mut buffer = vec![0u8; first.frame_len_bytes()];
    let frame_us = 1e6 / first.fps();
    (0..first.frame_count())
        .map(|i| {
            let truths = fleet.render(i, &mut buffer).unwrap();
            let frame = Frame::new_checked(&buffer, size, size.row_bytes()).unwrap();
            let t_us = (i as f64 * frame_us) as u64;
            let meta = FrameMeta {
                index: i as u64,
                sequence: i as u64,
                dropped: 0,
                timestamp_us: t_us,
                monotonic_us: t_us,
            };
            (pipeline.process(&frame, meta), truths)
        })
        .collect()
}

fn quantile(values: &[f64], q: f64) -> f64 {
    let mut sorted = values.to_vec();
    sorted.sort_by(f64::total_cmp);
    let rank = ((q * sorted.len() as f64).ceil() as usize).clamp(1, sorted.len());
    sorted[rank - 1]
}

fn distance(p: (f32, f32), x: Option<f64>, y: Option<f64>) -> Option<f64> {
    Some((f64::from(p.0) - x?).hypot(f64::from(p.1) - y?))
}

/// Scores a fleet preset's run; returns the number of merged track reports seen.
fn check(name: &str) -> usize {
    check_fleet(name, &Fleet::preset(name).expect("a fleet preset"))
}

/// Scores a run of `fleet`, labelled `name`; returns the number of merged track reports seen.
fn check_fleet(name: &str, fleet: &Fleet) -> usize {
    let runs = run(fleet);
    let robots = fleet.robots();
    let led_radius_px = fleet.robot(0).unwrap().led_radius_px();
    let mut merged_reports = 0;
    for k in 0..robots {
        let start = runs[0].1[k].clone();
        let moved_from = runs
            .iter()
            .position(|(_, t)| {
                distance(
                    (start.x_px.unwrap() as f32, start.y_px.unwrap() as f32),
                    t[k].x_px,
                    t[k].y_px,
                )
                .is_some_and(|d| d > MOVED_PX)
            })
            .expect("every robot moves");
        let (mut visible, mut detected, mut switches) = (0, 0, 0);
        let mut id = None;
        let (mut mid_errors, mut pos_errors) = (Vec::new(), Vec::new());
        for (i, (report, truths)) in runs.iter().enumerate().skip(moved_from + 1) {
            let truth = &truths[k];
            if truth.visible != Visibility::Visible {
                continue;
            }
            visible += 1;
            let near = report.tracks.iter().find(|t| {
                t.estimate.is_some_and(|e| {
                    distance(e.mid_px, truth.mid_x_px, truth.mid_y_px)
                        .is_some_and(|d| d <= tolerance_px(led_radius_px, t.merged, truth))
                })
            });
            let Some(track) = near else {
                eprintln!("{name}: robot {k} frame {i}: not found");
                continue;
            };
            detected += 1;
            // A merged blob is both robots': its ids say nothing of which is where.
            if track.merged {
                continue;
            }
            if *id.get_or_insert(track.id) != track.id {
                switches += 1;
                eprintln!("{name}: robot {k} frame {i}: id {:?} → {}", id, track.id);
                id = Some(track.id);
            }
            let e = track.estimate.unwrap();
            mid_errors.push(distance(e.mid_px, truth.mid_x_px, truth.mid_y_px).unwrap());
            pos_errors.push(distance(e.position_px, truth.x_px, truth.y_px).unwrap());
        }
        let share = detected as f64 / visible as f64;
        let (mid_median, mid_p95) = (quantile(&mid_errors, 0.5), quantile(&mid_errors, 0.95));
        let (pos_median, pos_p95) = (quantile(&pos_errors, 0.5), quantile(&pos_errors, 0.95));
        eprintln!(
            "{name}: robot {k}: found in {detected} of {visible} visible frames, {switches} id \
             switches; middle error median {mid_median:.3} px, p95 {mid_p95:.3} px; position \
             error median {pos_median:.3} px, p95 {pos_p95:.3} px"
        );
        assert!(
            share >= MIN_DETECTED,
            "{name}: robot {k} found in {share:.3}"
        );
        assert_eq!(switches, 0, "{name}: robot {k} changed ids");
        assert!(
            mid_median <= MID_MEDIAN_MAX_PX,
            "{name}: robot {k} middle median"
        );
        assert!(mid_p95 <= MID_P95_MAX_PX, "{name}: robot {k} middle p95");
        assert!(
            pos_median <= POS_MEDIAN_MAX_PX,
            "{name}: robot {k} position median"
        );
        assert!(pos_p95 <= POS_P95_MAX_PX, "{name}: robot {k} position p95");
    }
    // Every report is at a robot: no glare, no ghost.
    for (i, (report, truths)) in runs.iter().enumerate() {
        for t in &report.tracks {
            let Some(e) = t.estimate else { continue };
            merged_reports += usize::from(t.merged);
            let at_a_robot = truths.iter().any(|truth| {
                let tolerance = tolerance_px(led_radius_px, t.merged, truth);
                distance(e.mid_px, truth.mid_x_px, truth.mid_y_px).is_some_and(|d| d <= tolerance)
            });
            assert!(
                at_a_robot,
                "{name}: frame {i}: track {} at {:?}",
                t.id, e.mid_px
            );
        }
        assert_eq!(report.tracks.len(), robots, "one track per robot");
    }
    merged_reports
}

#[test]
fn crossing_paths_among_glare() {
    check("fleet-crossing");
}

#[test]
fn passing_through_each_other_is_merged_and_meeting_robots_keep_their_ids() {
    let merged = check("fleet-meeting");
    assert!(merged >= 2, "the head-on pair is merged while one blob");
}

#[test]
fn leaving_the_view_and_an_occlusion() {
    check("fleet-leave-return");
}

/// Two robots drive to a spot and park there for 6 s, longer than the static map takes to learn
/// a light that stands still (3.2 s), while a third circles: every parked robot's surroundings
/// are kept out of the map, so none of them is learned as glare and lost.
#[test]
fn robots_parked_longer_than_the_static_map_learns_stay_tracked() {
    use glint_tools::scene::{Point, Trajectory};
    let (mut config, _) = Fleet::preset_config("fleet-meeting").unwrap();
    config.frame_count = 7 * config.fps as usize;
    let park = |x: f64, y: f64, start_s: f64| Trajectory::StopGo {
        waypoints_px: vec![Point::new(x, y), Point::new(x + 60.0, y)],
        move_s: 0.5,
        hold_s: 6.0,
        start_s,
    };
    let trajectories = [
        park(150.0, 150.0, 0.1),
        park(420.0, 300.0, 0.2),
        Trajectory::Circle {
            centre_px: Point::new(320.0, 200.0),
            radius_px: 50.0,
            rev_per_s: 0.3,
            phase_rad: 0.0,
        },
    ];
    check_fleet(
        "two parked robots",
        &Fleet::new(&config, &trajectories).unwrap(),
    );
}

/// The crossing again across the LED's size and brightness, the exposure (streak length), the
/// sensor's noise and tone curve, and the floor's seed: the same bounds at every point.
#[test]
fn crossing_over_a_sweep_of_leds_exposures_and_noise() {
    let points = [
        // (LED radius px, peak × clip, exposure µs, noise σ, gamma, seed)
        (2.5, 8.0, 4_000, 0.01, 1.0, 11),
        (5.5, 30.0, 16_000, 0.03, 2.2, 12),
        (4.0, 12.0, 12_000, 0.02, 1.8, 13),
    ];
    for (radius_px, peak, exposure_us, noise_sigma, gamma, seed) in points {
        let (mut config, trajectories) = Fleet::preset_config("fleet-crossing").unwrap();
        let glow_per_radius = config.led.glow_radius_px / config.led.radius_px;
        config.led.radius_px = radius_px;
        config.led.glow_radius_px = glow_per_radius * radius_px;
        config.led.peak = peak;
        config.exposure_us = exposure_us;
        config.camera.noise_sigma = noise_sigma;
        config.camera.gamma = gamma;
        config.seed = seed;
        let label = format!("fleet-crossing r {radius_px} px, {exposure_us} µs, σ {noise_sigma}");
        check_fleet(&label, &Fleet::new(&config, &trajectories).unwrap());
    }
}

/// A short two-robot dump, written to a temporary file.
fn two_robot_dump() -> (tempfile::TempDir, std::path::PathBuf, usize) {
    use glint_tools::scene::{Point, Scene, Trajectory};
    let mut base = Scene::preset_config("slow-line").unwrap();
    base.frame_count = 12;
    let line = |x: f64, vx: f64| Trajectory::Line {
        start_px: Point::new(x, 240.0),
        velocity_px_s: Point::new(vx, 30.0),
    };
    let fleet = Fleet::new(&base, &[line(200.0, 90.0), line(440.0, -90.0)]).unwrap();
    let len = fleet.robot(0).unwrap().frame_len_bytes();
    let mut bytes = vec![0u8; len * base.frame_count];
    for (i, out) in bytes.chunks_exact_mut(len).enumerate() {
        fleet.render(i, out).unwrap();
    }
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("two.yuv");
    std::fs::write(&path, bytes).unwrap();
    (dir, path, base.frame_count)
}

fn glint(args: &[&str]) -> std::process::Output {
    std::process::Command::new(env!("CARGO_BIN_EXE_glint"))
        .args(args)
        .output()
        .unwrap()
}

#[test]
fn json_lines_and_csv_carry_one_track_per_robot() {
    let (_dir, path, frames) = two_robot_dump();
    let input = path.to_str().unwrap();
    let common = [
        "track", "--input", input, "--size", "640x480", "--robots", "2",
    ];
    let out = glint(&[&common[..], &["--exposure-us", "8000"]].concat());
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let lines: Vec<serde_json::Value> = out
        .stdout
        .split(|&b| b == b'\n')
        .filter(|l| !l.is_empty())
        .map(|l| serde_json::from_slice(l).unwrap())
        .collect();
    assert_eq!(lines.len(), frames);
    let last = lines.last().unwrap();
    assert_eq!(last["found"], true);
    assert!(last.get("x").is_none(), "positions are per track");
    let tracks = last["tracks"].as_array().unwrap();
    assert_eq!(tracks.len(), 2);
    let mut ids: Vec<u64> = tracks.iter().map(|t| t["id"].as_u64().unwrap()).collect();
    ids.sort_unstable();
    assert_eq!(ids, [1, 2]);
    for t in tracks {
        assert_eq!(t["found"], true, "{t}");
        assert_eq!(t["state"], "tracking");
        assert_eq!(
            (&t["merged"], &t["provisional"]),
            (&false.into(), &true.into())
        );
        assert_eq!(t["id_source"], "continuity");
        for key in ["x", "y", "mid_x", "mid_y", "vx", "vy"] {
            assert!(t[key].is_f64(), "{key} in {t}");
        }
    }
    // Both robots, one per track: one left of centre, one right.
    let mut xs: Vec<f64> = tracks.iter().map(|t| t["x"].as_f64().unwrap()).collect();
    xs.sort_by(f64::total_cmp);
    assert!(xs[0] < 320.0 && xs[1] > 320.0, "{xs:?}");

    let out = glint(&[&common[..], &["--format", "csv"]].concat());
    assert!(out.status.success());
    let text = String::from_utf8(out.stdout).unwrap();
    let mut rows = text.lines();
    let header: Vec<&str> = rows.next().unwrap().split(',').collect();
    assert!(header.ends_with(&["id", "provisional", "id_source", "state", "merged"]));
    let rows: Vec<Vec<&str>> = rows.map(|r| r.split(',').collect()).collect();
    assert_eq!(rows.len(), 2 * frames, "one row per robot and frame");
    assert!(rows.iter().all(|r| r.len() == header.len()));
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let last_frame: Vec<&Vec<&str>> = rows.iter().rev().take(2).collect();
    assert!(last_frame.iter().all(|r| r[col("found")] == "true"));
}

#[test]
fn bad_robot_counts_and_serial_ports_with_several_robots_are_refused() {
    let (_dir, path, _) = two_robot_dump();
    let input = path.to_str().unwrap();
    let track = ["track", "--input", input, "--size", "640x480"];
    for (extra, message) in [
        (
            &["--robots", "0"][..],
            "--robots 0 is out of range: glint follows 1 to 16 robots",
        ),
        (
            &["--robots", "17"][..],
            "--robots 17 is out of range: glint follows 1 to 16 robots",
        ),
        (
            &["--robots", "2", "--serial", "3=/dev/null"][..],
            "--serial 3=/dev/null: glint follows 2 robot(s) (--robots), ids 1 to 2",
        ),
        (
            &[
                "--robots",
                "2",
                "--serial",
                "1=/dev/null",
                "--serial",
                "1=/dev/zero",
            ][..],
            "robot 1 is given two serial ports (--serial 1=/dev/null and --serial 1=/dev/zero)",
        ),
        (
            &["--robots", "2", "--serial", "/dev/null", "--mavlink"][..],
            "--mavlink talks to one autopilot",
        ),
        (
            &["--robots", "2", "--detector", "aruco", "--marker", "1"][..],
            "--detector aruco follows one marker",
        ),
    ] {
        let out = glint(&[&track[..], extra].concat());
        let stderr = String::from_utf8_lossy(&out.stderr);
        assert!(!out.status.success(), "{extra:?}");
        assert!(stderr.contains(message), "{extra:?}: {stderr}");
        assert_eq!(stderr.lines().count(), 1, "one line: {stderr}");
    }
}

/// Each robot's speed through a rolling shutter: three robots crossing the picture at 1000 px/s
/// (down, up, and up a diagonal), among the crossing preset's glare, filmed with 60 µs rows (a
/// 29 ms readout) and a 12 ms exposure, so that each robot's picture is skewed by its own
/// vertical speed: 6.4 % fast down, 5.7 % slow up, 4.1 % slow up the diagonal. With
/// `--robots 3 --row-time-us 60` every robot's mean single-frame speed reads within
/// [`BIAS_MAX`] of the same robot's under a global shutter (the same fleet drawn without a row
/// time); without the row time the vertical robots keep more than half their skew. Each
/// track's velocity is undone with its own velocity, and its spot read through its own skew.
/// Measured: −0.4, −1.6 and −2.5 % (down, up, diagonal) against −1.8, −2.3 and −2.4 % under
/// a global shutter; +10.0, −10.3 and −8.5 % without the row time.
#[test]
fn each_robot_s_speed_is_its_own_through_a_rolling_shutter() {
    /// Three standard errors of the mean of a robot's eleven single-frame speeds, which scatter
    /// by about 3.5 % through a rolling shutter (a sharp disk's ends fall on the pixel grid at
    /// a different phase in every row).
    const BIAS_MAX: f64 = 0.03;
    const ROW_TIME_US: f64 = 60.0;
    const SPEED_PX_S: f64 = 1000.0;
    let (mut config, _) = Fleet::preset_config("fleet-crossing").expect("the preset");
    config.frame_count = 12;
    config.exposure_us = 12_000;
    let line = |x: f64, y: f64, vx: f64, vy: f64| Trajectory::Line {
        start_px: Point::new(x, y),
        velocity_px_s: Point::new(vx, vy),
    };
    let diagonal = SPEED_PX_S * std::f64::consts::FRAC_1_SQRT_2;
    let trajectories = [
        line(250.0, 40.0, 0.0, SPEED_PX_S),
        line(420.0, 440.0, 0.0, -SPEED_PX_S),
        line(120.0, 400.0, diagonal, -diagonal),
    ];
    // Each robot's mean signed single-frame speed error, under `row_time_us` and told of it
    // or not.
    let mean_errors = |row_time_us: f64, told: bool| -> Vec<f64> {
        let mut c = config.clone();
        c.row_time_us = row_time_us;
        let fleet = Fleet::new(&c, &trajectories).expect("the fleet");
        let shutter = told.then(|| RollingShutter::new(row_time_us as f32).unwrap());
        let runs = run_through(&fleet, shutter);
        (0..fleet.robots())
            .map(|k| {
                let errors: Vec<f64> = runs
                    .iter()
                    .filter_map(|(report, truths)| {
                        let truth = &truths[k];
                        if truth.visible != Visibility::Visible {
                            return None;
                        }
                        let track = report.tracks.iter().find(|t| {
                            t.estimate.is_some_and(|e| {
                                distance(e.mid_px, truth.mid_x_px, truth.mid_y_px)
                                    .is_some_and(|d| d <= REPORT_TOLERANCE_PX)
                            })
                        })?;
                        let ((vx, vy), method) = track.estimate?.velocity_px_s?;
                        (method == VelocityMethod::Streak).then(|| {
                            let true_speed = truth.vx_px_s?.hypot(truth.vy_px_s?);
                            Some((f64::from(vx).hypot(f64::from(vy)) - true_speed) / true_speed)
                        })?
                    })
                    .collect();
                assert!(errors.len() >= 4, "robot {k}: {} speeds", errors.len());
                errors.iter().sum::<f64>() / errors.len() as f64
            })
            .collect()
    };
    let global = mean_errors(0.0, false);
    let told = mean_errors(ROW_TIME_US, true);
    let untold = mean_errors(ROW_TIME_US, false);
    for (k, direction) in ["down", "up", "diagonal"].into_iter().enumerate() {
        eprintln!(
            "robot {k} ({direction}): mean speed error {:+.2} % with the row time, {:+.2} % \
             without, {:+.2} % under a global shutter",
            100.0 * told[k],
            100.0 * untold[k],
            100.0 * global[k]
        );
        assert!(
            (told[k] - global[k]).abs() <= BIAS_MAX,
            "robot {k} ({direction}): {:+.2} % against {:+.2} %",
            100.0 * told[k],
            100.0 * global[k]
        );
    }
    // The vertical robots' pictures are skewed by `1 / (1 ∓ v τ) − 1`: read without the row
    // time, each keeps more than half of it.
    for (k, vy) in [(0, SPEED_PX_S), (1, -SPEED_PX_S)] {
        let skew = shutter_skew(vy, ROW_TIME_US);
        let kept = (untold[k] - global[k]) / skew;
        assert!(kept > 0.5, "robot {k}: {kept:.2} of the skew kept untold");
    }
}
