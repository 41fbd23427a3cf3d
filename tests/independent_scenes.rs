//! Accuracy on scenes that glint's own renderer did not make.
//!
//! `tests/independent/render_streaks.py` renders streaks with other physics than
//! `glint-scene`: a Moffat spot with power-law wings (or a defocused pillbox, or a Moffat core
//! in a Moffat halo), the path deposited on a finer grid and convolved, a sensor that counts
//! electrons (shot noise, read noise, full-well clipping), an sRGB-like or filmic tone curve,
//! a webcam's unsharp mask, full or studio range, and a vignetted textured floor. Its frames
//! are 8-bit luma (a mono camera's GREY), written to real files and replayed by the real
//! `glint track`, whose JSON lines are held to the truth the script wrote.
//!
//! The scoring follows `tests/streak_sweep.rs`: the LED must be reported at most one frame
//! after it has moved 2 px from where it appeared and in every frame from then on, and never
//! before it moved; the head is measured from the frame after the first report (once an LED
//! that moves into place is in place); the middle on 60 px streaks; the single-frame speed on
//! streaks of at least 8 px.
//!
//! The default run renders [`DEFAULT_SCENES`] scenes at 640×480 and [`HD_SCENES`] at
//! 1280×720 and holds both the detection rules and the accuracy bounds on them (each scene's
//! and pooled); the bounds are not yet held on every scene of larger runs, which the ignored
//! test asks. At 320×240 and 1920×1080 ([`OTHER_SIZES`]) it holds the detection rules and the
//! pooled bounds. `GLINT_INDEPENDENT_SCENES=N` renders
//! N, `GLINT_INDEPENDENT_SEED` another set, `GLINT_INDEPENDENT_SIZE=WxH` scenes drawn as a
//! camera of that size sees them (every length in pixels scaled by W / 640),
//! `GLINT_STREAK_MODEL=fit|auto` replays with that model, and `GLINT_INDEPENDENT_KEEP=DIR`
//! keeps the dumps there.

mod common;

use std::path::Path;

use common::peers::render_independent;
use common::{glint, parse_jsonl, quantile, shutter_skew, slope_and_mean};
use glint_tools::scene::{read_truth_csv, Truth, Visibility};
use serde_json::Value;

const DEFAULT_SCENES: usize = 24;
const DEFAULT_SEED: u64 = 1;
/// The picture the scenes are drawn for.
const SIZE: &str = "640x480";
/// A camera of twice the resolution, which sees scenes drawn alike with every length in pixels
/// doubled (the spot, the streak, the arc), and how many of them its default run renders.
const HD_SIZE: &str = "1280x720";
const HD_SCENES: usize = 12;
/// Smaller and larger cameras, and how many scenes of each the default run renders (a
/// 1920×1080 scene takes the renderer about 5 s).
const OTHER_SIZES: [(&str, usize); 2] = [("320x240", 24), ("1920x1080", 8)];

const HEAD_MEDIAN_MAX_PX: f64 = 0.5;
const HEAD_P95_MAX_PX: f64 = 1.5;
const MID_MEDIAN_MAX_PX: f64 = 0.2;
const MID_P95_MAX_PX: f64 = 0.5;
const MIDDLE_STREAK_PX: f64 = 59.0;
const SPEED_MEDIAN_MAX: f64 = 0.03;
const SPEED_P95_MAX: f64 = 0.10;
const SPEED_MIN_STREAK_PX: f64 = 8.0;
const MOTION_SHOWN_PX: f64 = 2.0;
const ACQUIRE_MAX_FRAMES: usize = 1;

fn env_or<T: std::str::FromStr>(name: &str, default: T) -> T {
    std::env::var(name)
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(default)
}

/// One scene's errors, and what broke the detection rules.
#[derive(Default)]
struct SceneScore {
    head_px: Vec<f64>,
    mid60_px: Vec<f64>,
    speed: Vec<f64>,
    /// Frames whose speed should have come from the streak and did not.
    speed_missing: usize,
    /// Rules broken: reported before it moved, acquired late, lost after acquisition.
    broken: Vec<String>,
}

fn score(reports: &[Value], truths: &[Truth], settled_frame: usize, exposure_s: f64) -> SceneScore {
    let mut s = SceneScore::default();
    assert_eq!(reports.len(), truths.len(), "one report per frame");
    let first = &truths[0];
    // Where the LED was at the start of the first exposure (the straight streak's far end;
    // an arc moves far more than the threshold in its first frame).
    let start = (
        2.0 * first.mid_x_px.unwrap() - first.x_px.unwrap(),
        2.0 * first.mid_y_px.unwrap() - first.y_px.unwrap(),
    );
    let (mut moved, mut acquired) = (None, None);
    for (r, t) in reports.iter().zip(truths) {
        // A streak cut by the picture's border is neither required nor scored.
        if t.visible != Visibility::Visible {
            continue;
        }
        let (x, y) = (t.x_px.unwrap(), t.y_px.unwrap());
        if moved.is_none() && (x - start.0).hypot(y - start.1) > MOTION_SHOWN_PX {
            moved = Some(t.frame);
        }
        if r["found"] != true {
            if acquired.is_some() {
                s.broken.push(format!("lost in frame {}", t.frame));
            }
            continue;
        }
        if moved.is_none() {
            s.broken
                .push(format!("reported in frame {} before it moved", t.frame));
        }
        let acquired = *acquired.get_or_insert(t.frame);
        let at = |kx: &str, ky: &str| (r[kx].as_f64().unwrap(), r[ky].as_f64().unwrap());
        let (mx, my) = at("mid_x", "mid_y");
        let streak_px = t.streak_px.unwrap();
        if streak_px >= MIDDLE_STREAK_PX {
            s.mid60_px
                .push((mx - t.path_mid_x_px.unwrap()).hypot(my - t.path_mid_y_px.unwrap()));
        }
        if t.frame <= acquired || t.frame < settled_frame {
            continue;
        }
        let (hx, hy) = at("x", "y");
        s.head_px.push((hx - x).hypot(hy - y));
        if streak_px >= SPEED_MIN_STREAK_PX {
            // The single-frame speed is the streak's length over the exposure: the path's
            // mean speed during it (an accelerating LED ends the exposure faster).
            let truth = streak_px / exposure_s;
            if r["v_method"] == "streak" {
                let speed = r["vx"].as_f64().unwrap().hypot(r["vy"].as_f64().unwrap());
                s.speed.push((speed - truth).abs() / truth);
            } else {
                s.speed_missing += 1;
            }
        }
    }
    match (moved, acquired) {
        (Some(m), Some(a)) if a > m + ACQUIRE_MAX_FRAMES => {
            s.broken
                .push(format!("acquired in frame {a}, it moved in {m}"));
        }
        (_, None) => s.broken.push("never acquired".into()),
        _ => {}
    }
    s
}

/// Renders the scenes into `dir` (with the renderer's `extra` arguments) and returns their
/// parameters.
fn render(dir: &Path, seed: u64, count: usize, extra: &[&str]) -> Vec<Value> {
    let (seed, count) = (seed.to_string(), count.to_string());
    let mut args = vec!["--seed", &seed, "--count", &count];
    args.extend_from_slice(extra);
    render_independent(dir, &args)
}

fn quantiles(v: &[f64]) -> (f64, f64) {
    if v.is_empty() {
        return (0.0, 0.0);
    }
    (quantile(v, 0.5), quantile(v, 0.95))
}

/// Replays rendered scene `params["scene"]` of `dir` with `glint track` (with `extra`
/// options): its JSON lines and its truth.
fn replay_scene(dir: &Path, params: &Value, extra: &[&str]) -> (Vec<Value>, Vec<Truth>) {
    let k = params["scene"].as_u64().unwrap();
    let exposure = params["exposure_us"].as_u64().unwrap().to_string();
    let size = params["size"].as_str().unwrap();
    let mut cmd = glint();
    cmd.args(["track", "--input"])
        .arg(dir.join(format!("scene_{k}.grey")))
        .args(["--size", size, "--format-in", "grey", "--fps", "30"])
        .args(["--exposure-us", &exposure])
        .args(extra);
    let out = cmd.output().expect("run glint");
    assert!(
        out.status.success(),
        "scene {k}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let csv = std::fs::read(dir.join(format!("scene_{k}.csv"))).expect("truth");
    let truths = read_truth_csv(&csv[..]).expect("truth parses");
    (parse_jsonl(&out.stdout), truths)
}

/// What a replay of the scenes showed.
struct Outcome {
    /// Detection rules broken, per scene.
    broken: Vec<String>,
    /// Scenes out of an accuracy bound, and which.
    scenes_out: Vec<String>,
    /// Pooled bounds not held.
    pooled_out: Vec<String>,
}

/// Renders `count` scenes at `size` (unless `GLINT_INDEPENDENT_SEED`,
/// `GLINT_INDEPENDENT_SCENES` or `GLINT_INDEPENDENT_SIZE` say otherwise) and replays them with
/// `glint track` (`GLINT_STREAK_MODEL`, else the default model), printing every scene's
/// figures and the pooled ones.
fn replay_scenes(size: &str, count: usize) -> Outcome {
    let seed = env_or("GLINT_INDEPENDENT_SEED", DEFAULT_SEED);
    let count = env_or("GLINT_INDEPENDENT_SCENES", count);
    let model = std::env::var("GLINT_STREAK_MODEL").ok();
    let model_args: Vec<&str> = model.iter().flat_map(|m| ["--streak-model", m]).collect();
    let temp = tempfile::tempdir().expect("temp dir");
    let dir = std::env::var_os("GLINT_INDEPENDENT_KEEP")
        .map(std::path::PathBuf::from)
        .unwrap_or_else(|| temp.path().to_path_buf());
    std::fs::create_dir_all(&dir).expect("dump dir");
    let size = std::env::var("GLINT_INDEPENDENT_SIZE").unwrap_or_else(|_| size.into());
    let scenes = render(&dir, seed, count, &["--size", &size]);
    let (mut head, mut mid60, mut speed, mut speed_missing) =
        (Vec::new(), Vec::new(), Vec::new(), 0);
    let mut outcome = Outcome {
        broken: Vec::new(),
        scenes_out: Vec::new(),
        pooled_out: Vec::new(),
    };
    for params in &scenes {
        let k = params["scene"].as_u64().unwrap();
        let (reports, truths) = replay_scene(&dir, params, &model_args);
        let settled = params["settled_frame"].as_u64().unwrap_or(0) as usize;
        let exposure_s = params["exposure_us"].as_f64().unwrap() * 1e-6;
        let s = score(&reports, &truths, settled, exposure_s);
        let (h, m, v) = (
            quantiles(&s.head_px),
            quantiles(&s.mid60_px),
            quantiles(&s.speed),
        );
        let mut out = Vec::new();
        if h.0 > HEAD_MEDIAN_MAX_PX || h.1 > HEAD_P95_MAX_PX {
            out.push("head");
        }
        if m.0 > MID_MEDIAN_MAX_PX || m.1 > MID_P95_MAX_PX {
            out.push("middle");
        }
        let visible = truths.len();
        if v.0 > SPEED_MEDIAN_MAX || v.1 > SPEED_P95_MAX || s.speed_missing * 10 > visible {
            out.push("speed");
        }
        eprintln!(
            "scene {k:>3}: head {:.2}/{:.2} px, mid60 {:.2}/{:.2} px, speed {:.1}/{:.1} % \
             ({} frames without){}{}: {} {} {}",
            h.0,
            h.1,
            m.0,
            m.1,
            100.0 * v.0,
            100.0 * v.1,
            s.speed_missing,
            if out.is_empty() { "" } else { ", out: " },
            out.join(" "),
            params["motion"],
            params["spot"],
            params["camera"],
        );
        for b in &s.broken {
            outcome.broken.push(format!("scene {k}: {b}"));
        }
        if !out.is_empty() {
            outcome
                .scenes_out
                .push(format!("scene {k}: {}", out.join(" ")));
        }
        head.extend(s.head_px);
        mid60.extend(s.mid60_px);
        speed.extend(s.speed);
        speed_missing += s.speed_missing;
    }
    let (h, m, v) = (quantiles(&head), quantiles(&mid60), quantiles(&speed));
    eprintln!(
        "pooled over {} scenes: head {:.3}/{:.3} px ({} frames), middle of 60 px streaks \
         {:.3}/{:.3} px ({}), speed {:.2}/{:.2} % ({}, {} without); {} scenes out",
        scenes.len(),
        h.0,
        h.1,
        head.len(),
        m.0,
        m.1,
        mid60.len(),
        100.0 * v.0,
        100.0 * v.1,
        speed.len(),
        speed_missing,
        outcome.scenes_out.len(),
    );
    let mut out_of = |what: &str, (median, p95): (f64, f64), (mmax, pmax): (f64, f64)| {
        if median > mmax || p95 > pmax {
            outcome.pooled_out.push(format!(
                "pooled {what}: {median:.3} / {p95:.3} against {mmax} / {pmax}"
            ));
        }
    };
    out_of("head", h, (HEAD_MEDIAN_MAX_PX, HEAD_P95_MAX_PX));
    out_of("middle", m, (MID_MEDIAN_MAX_PX, MID_P95_MAX_PX));
    out_of("speed", v, (SPEED_MEDIAN_MAX, SPEED_P95_MAX));
    outcome
}

/// The detection rules hold on every scene: the LED is taken at most a frame after it moved,
/// kept in every frame from then on, and never reported before it moved. And the accuracy
/// bounds hold on each of the default run's scenes and pooled over them (not yet on every
/// scene of larger runs: see [`independent_scenes_hold_the_bounds`]).
#[test]
fn independent_scenes_are_found_and_read_within_the_bounds() {
    assert_found_and_within_the_bounds(replay_scenes(SIZE, DEFAULT_SCENES));
}

/// The same on such scenes seen by a 1280×720 camera: spots up to 12 px wide, streaks up to
/// 120 px long, halos clipped across tens of pixels.
#[test]
fn independent_scenes_seen_in_1280x720_are_found_and_read_within_the_bounds() {
    assert_found_and_within_the_bounds(replay_scenes(HD_SIZE, HD_SCENES));
}

/// Cameras of other sizes see the same scenes with every length scaled: at 320×240 spots
/// 0.75–3 px wide (FWHM) and pillboxes of radius 0.4–1.5 px (some narrower than the 0.8 px
/// the sweep starts at), streaks of 1–30 px; at 1920×1080 spots up to 18 px wide and halos up
/// to 90 px, beyond anything the streak model was built on. The detection rules hold on every
/// scene, and the accuracy bounds pooled over them. Not yet on each scene: of 30 scenes of
/// seeds 1 and 2, 1 and 0 are out at 320×240, 1 and 5 at 1920×1080 (README, "Other camera
/// sizes").
#[test]
fn independent_scenes_seen_by_smaller_and_larger_cameras_are_found_and_read_within_the_bounds() {
    for (size, count) in OTHER_SIZES {
        let outcome = replay_scenes(size, count);
        assert!(
            outcome.broken.is_empty(),
            "{size}: {}",
            outcome.broken.join("\n")
        );
        assert!(
            outcome.pooled_out.is_empty(),
            "{size}: {}",
            outcome.pooled_out.join("\n")
        );
    }
}

/// The detection rules first (a scene that breaks them is scored on what was found), then
/// the accuracy bounds per scene and pooled.
fn assert_found_and_within_the_bounds(outcome: Outcome) {
    assert!(outcome.broken.is_empty(), "{}", outcome.broken.join("\n"));
    let out: Vec<_> = [outcome.scenes_out, outcome.pooled_out].concat();
    assert!(out.is_empty(), "{}", out.join("\n"));
}

/// NOT YET HELD (README, "Accuracy on independently rendered scenes"): the accuracy bounds on
/// every scene and pooled. Run on purpose with `-- --ignored`.
#[test]
#[ignore = "the accuracy bounds are not yet held on every independent scene (README)"]
fn independent_scenes_hold_the_bounds() {
    let outcome = replay_scenes(SIZE, DEFAULT_SCENES);
    let failures: Vec<_> = [outcome.broken, outcome.scenes_out, outcome.pooled_out].concat();
    assert!(failures.is_empty(), "{}", failures.join("\n"));
}

/// A fitted path that wanders off its light is not reported. Independent scenes seed 4,
/// scene 5, as a 1280×720 camera sees it: an LED speeding up from 48 to 112 px a frame, a
/// Moffat core in a wide halo clipped at 56 full wells (its saturated blob some 60 px thick).
/// In the last frame the fit, started from the frame before, ended with its middle 30.5 px
/// from the light's on a 95 px path, and that frame was reported 31 px off in its middle and
/// 38 px off in its head. Every reported middle must stay within [`WILD_MID_PX`] of the
/// truth. NOT YET HELD on this scene, so not asserted: the accuracy bounds (the
/// middles are 1.0–1.4 px off, the heads 2.5–6.2 px).
#[test]
fn a_fit_that_leaves_its_light_is_not_reported() {
    /// Far beyond any reading of the middle this scene's frames get, and far within the
    /// 31 px of the wandering fit.
    const WILD_MID_PX: f64 = 3.0;
    const SEED: u64 = 4;
    const SCENE: u64 = 5;
    let temp = tempfile::tempdir().expect("temp dir");
    let scenes = render(temp.path(), SEED, SCENE as usize + 1, &["--size", HD_SIZE]);
    let params = scenes
        .iter()
        .find(|p| p["scene"] == SCENE)
        .expect("the scene was rendered");
    assert_eq!(
        params["motion"], "accelerate",
        "the scene drawn is not this test's"
    );
    assert_eq!(
        params["spot"]["kind"], "halo",
        "the scene drawn is not this test's"
    );
    let (reports, truths) = replay_scene(temp.path(), params, &[]);
    let mut measured = 0;
    for (r, t) in reports.iter().zip(&truths) {
        if r["found"] != true {
            continue;
        }
        measured += 1;
        let mid = |axis: &str| r[format!("mid_{axis}")].as_f64().unwrap();
        let off_px =
            (mid("x") - t.path_mid_x_px.unwrap()).hypot(mid("y") - t.path_mid_y_px.unwrap());
        eprintln!("frame {}: middle {off_px:.2} px off", t.frame);
        assert!(
            off_px <= WILD_MID_PX,
            "frame {}: middle {off_px:.2} px off (at most {WILD_MID_PX} px)",
            t.frame
        );
    }
    assert!(measured >= 3, "only {measured} frames reported");
}

/// A spot outside the fit's family (a Moffat core in a power-law halo, a defocused pillbox)
/// puts the fitted ends a steady distance off, so that every frame of one LED reads its speed
/// a few per cent fast or slow (see `src/track/length_offset.rs`). Over a long run the
/// middles' motion measures that offset and the single frame's speed is taken without it:
/// on 60-frame arcs, half a second in, each scene's median single-frame speed error is
/// within the 3 %, and the pooled p95 within its 10 %. Without the learned offset a
/// halo scene's median was 5.3 % and a pillbox one's 3.4 %. NOT YET HELD, so not asserted:
/// the p95 of every scene (a halo scene's frames whose fit is poor, `fit_px` 2–6 px, read
/// 10–12 % fast) and a streak speed in 90 % of every scene's frames (a 60 px pillbox
/// streak's is missing in 6 of 45).
#[test]
fn a_long_run_on_a_spot_the_fit_does_not_describe_reads_its_speed() {
    const WARM_FRAMES: usize = 15;
    const FRAMES: &str = "60";
    let (mut out, mut pooled) = (Vec::new(), Vec::new());
    for spot in ["halo", "pillbox"] {
        let temp = tempfile::tempdir().expect("temp dir");
        let args = ["--motion", "arc", "--spot", spot, "--frames", FRAMES];
        for params in &render(temp.path(), 7, 8, &args) {
            let k = params["scene"].as_u64().unwrap();
            let (reports, truths) = replay_scene(temp.path(), params, &[]);
            let exposure_s = params["exposure_us"].as_f64().unwrap() * 1e-6;
            let (mut speed, mut without, mut scored) = (Vec::new(), 0, 0);
            for (r, t) in reports.iter().zip(&truths) {
                let streak_px = t.streak_px.unwrap();
                if t.frame < WARM_FRAMES
                    || t.visible != Visibility::Visible
                    || streak_px < SPEED_MIN_STREAK_PX
                {
                    continue;
                }
                scored += 1;
                if r["found"] != true || r["v_method"] != "streak" {
                    without += 1;
                    continue;
                }
                let v = r["vx"].as_f64().unwrap().hypot(r["vy"].as_f64().unwrap());
                let truth = streak_px / exposure_s;
                speed.push((v - truth).abs() / truth);
            }
            let (median, p95) = quantiles(&speed);
            eprintln!(
                "{spot} scene {k}: speed {:.2} / {:.2} % over {} frames, {without} of {scored} \
                 without",
                100.0 * median,
                100.0 * p95,
                speed.len()
            );
            if median > SPEED_MEDIAN_MAX {
                out.push(format!("{spot} scene {k}: median {:.2} %", 100.0 * median));
            }
            pooled.extend(speed);
        }
    }
    let (median, p95) = quantiles(&pooled);
    eprintln!(
        "pooled: {:.2} / {:.2} % over {} frames",
        100.0 * median,
        100.0 * p95,
        pooled.len()
    );
    assert!(pooled.len() >= 500, "{} frames scored", pooled.len());
    if p95 > SPEED_P95_MAX {
        out.push(format!("pooled p95 {:.2} %", 100.0 * p95));
    }
    assert!(out.is_empty(), "{}", out.join("\n"));
}

/// One frame's readings of a scene under a rolling shutter, against its truth.
struct RowFrame {
    frame: usize,
    head_px: f64,
    /// (read − true) / true, on streaks of at least [`SPEED_MIN_STREAK_PX`].
    speed: Option<f64>,
    /// How much the rows' skew alone changes the speed the picture shows: `1 / (1 − v_y τ) − 1`.
    skew: f64,
}

/// The frames of a replay after its first report, scored as [`score`] scores them, with the
/// speed's sign kept: the truth's speed is its velocity's (these scenes' LEDs keep theirs).
fn row_frames(reports: &[Value], truths: &[Truth], row_time_us: f64) -> Vec<RowFrame> {
    let mut frames = Vec::new();
    let mut acquired = false;
    for (r, t) in reports.iter().zip(truths) {
        if t.visible != Visibility::Visible || r["found"] != true {
            continue;
        }
        if !std::mem::replace(&mut acquired, true) {
            continue;
        }
        let at = |k: &str| r[k].as_f64().unwrap();
        let (vx, vy) = (t.vx_px_s.unwrap(), t.vy_px_s.unwrap());
        let truth = vx.hypot(vy);
        let speed = (t.streak_px.unwrap() >= SPEED_MIN_STREAK_PX && r["v_method"] == "streak")
            .then(|| (at("vx").hypot(at("vy")) - truth) / truth);
        frames.push(RowFrame {
            frame: t.frame,
            head_px: (at("x") - t.x_px.unwrap()).hypot(at("y") - t.y_px.unwrap()),
            speed,
            skew: shutter_skew(vy, row_time_us),
        });
    }
    frames
}

/// A rolling shutter drawn by other physics than glint's: the independent renderer lights
/// each row only with the samples of the LED's path its own exposure holds (glint-scene draws
/// each row's window). Straight runs and circles (seed 7), each drawn twice from the same
/// draws, with 40 µs rows (a 19 ms readout) and with a global shutter, and replayed with
/// `--row-time-us 40`, without it, and the global twin as it is. Frame by frame against the
/// twin's reading, the speed read without the option keeps the whole skew (the renderer's
/// rows are skewed as the physics says), and read with it at most [`SKEW_LEFT_MAX`] of it,
/// [`ROW_BIAS_MAX`] from the twin on average; pooled, the speed and the head hold the
/// issue's bounds. Measured over 116 frames: of a skew of 6.3 % (rms), 1.04 kept without the
/// option and −0.03 left with it, +0.22 % from the global twin; speed 0.90 / 4.74 %, head
/// 0.09 / 0.53 px. Before the spot's skew was read from the velocity expected in the frame
/// (the last one turned on as the LED turns), the circles alone read heads of 3.5 px and
/// speeds of 12.5 % (p95): a circle turning 150° a frame had its spot read through the skew
/// of a velocity pointing nearly the other way. NOT YET HELD, so not asserted: the same
/// circles at 60 µs rows (a 29 ms readout of a 33 ms frame), where that circle's heads read
/// 2.4–3.6 px off with or without the option.
#[test]
fn a_rolling_shutter_drawn_independently_reads_the_leds_speed() {
    /// Four standard errors of the slope over some 110 frames whose speed scatters by 2 %
    /// against a skew of 5 % (rms).
    const SKEW_LEFT_MAX: f64 = 0.2;
    const ROW_BIAS_MAX: f64 = 0.01;
    /// The skew a reading without the option must keep: the whole of it, less the slope's
    /// scatter.
    const SKEW_KEPT_MIN: f64 = 0.8;
    const ROW_TIME_US: f64 = 40.0;
    const SEED: u64 = 7;
    let row_time = ROW_TIME_US.to_string();
    let (mut skews, mut corrected, mut uncorrected) = (Vec::new(), Vec::new(), Vec::new());
    let (mut speed, mut head) = (Vec::new(), Vec::new());
    for (motion, count) in [("line", 8), ("arc", 6)] {
        let rolling_dir = tempfile::tempdir().expect("temp dir");
        let global_dir = tempfile::tempdir().expect("temp dir");
        let args =
            |row_time: &str| ["--motion", motion, "--row-time-us", row_time].map(String::from);
        let a = args(&row_time);
        let g = args("0");
        let rolling = render(
            rolling_dir.path(),
            SEED,
            count,
            &a.each_ref().map(String::as_str),
        );
        let global = render(
            global_dir.path(),
            SEED,
            count,
            &g.each_ref().map(String::as_str),
        );
        for (params, twin) in rolling.iter().zip(&global) {
            let k = params["scene"].as_u64().unwrap();
            for key in ["exposure_us", "streak_px", "spot", "camera", "frames"] {
                assert_eq!(params[key], twin[key], "scene {k}: the twins' {key} differ");
            }
            let read = |dir: &Path, params: &Value, extra: &[&str]| {
                let (reports, truths) = replay_scene(dir, params, extra);
                row_frames(&reports, &truths, ROW_TIME_US)
            };
            let with = read(rolling_dir.path(), params, &["--row-time-us", &row_time]);
            let without = read(rolling_dir.path(), params, &[]);
            let twin = read(global_dir.path(), twin, &[]);
            for f in &with {
                let at = |frames: &[RowFrame]| {
                    frames
                        .iter()
                        .find(|g| g.frame == f.frame)
                        .and_then(|g| g.speed)
                };
                if let (Some(s), Some(u), Some(g)) = (f.speed, at(&without), at(&twin)) {
                    skews.push(f.skew);
                    corrected.push(s - g);
                    uncorrected.push(u - g);
                }
            }
            let scene_speed: Vec<f64> = with.iter().filter_map(|f| f.speed).map(f64::abs).collect();
            let scene_head: Vec<f64> = with.iter().map(|f| f.head_px).collect();
            let (s, h) = (quantiles(&scene_speed), quantiles(&scene_head));
            eprintln!(
                "{motion} scene {k}: speed {:.2} / {:.2} % over {} frames, head {:.2} / {:.2} px",
                100.0 * s.0,
                100.0 * s.1,
                scene_speed.len(),
                h.0,
                h.1,
            );
            speed.extend(scene_speed);
            head.extend(scene_head);
        }
    }
    let (kept, _) = slope_and_mean(&skews, &uncorrected);
    let (left, bias) = slope_and_mean(&skews, &corrected);
    let skew_rms = (skews.iter().map(|s| s * s).sum::<f64>() / skews.len() as f64).sqrt();
    let (speed_q, head_q) = (quantiles(&speed), quantiles(&head));
    eprintln!(
        "{} frames, skew {:.1} % (rms): {kept:+.3} of it kept without the option, {left:+.3} \
         with it, {:+.2} % from the global twin; speed {:.2} / {:.2} %, head {:.3} / {:.3} px",
        skews.len(),
        100.0 * skew_rms,
        100.0 * bias,
        100.0 * speed_q.0,
        100.0 * speed_q.1,
        head_q.0,
        head_q.1,
    );
    assert!(skews.len() >= 60, "{} frames compared", skews.len());
    assert!(
        kept >= SKEW_KEPT_MIN,
        "{kept:+.3} of the skew kept without the option"
    );
    assert!(left.abs() <= SKEW_LEFT_MAX, "{left:+.3} of the skew left");
    assert!(
        bias.abs() <= ROW_BIAS_MAX,
        "{:+.2} % from the twin",
        100.0 * bias
    );
    assert!(
        speed_q.0 <= SPEED_MEDIAN_MAX && speed_q.1 <= SPEED_P95_MAX,
        "speed {:.2} / {:.2} %",
        100.0 * speed_q.0,
        100.0 * speed_q.1
    );
    assert!(
        head_q.0 <= HEAD_MEDIAN_MAX_PX && head_q.1 <= HEAD_P95_MAX_PX,
        "head {:.3} / {:.3} px",
        head_q.0,
        head_q.1
    );
}
