//! End-to-end: the background-difference detector (`--detector bgdiff`) on rendered scenes,
//! with the background learned from the first frames or from a separate recording of the
//! empty scene.

mod common;

use common::{parse_jsonl, quantile, render, score, temp_file, track, Rendered};
use glint_tools::scene::Scene;

/// Frames the background is learned from (the command's default).
const LEARNING_FRAMES: usize = 9;

fn check(name: &str, r: &Rendered, reports: &[serde_json::Value], learning_frames: usize) {
    let learning = reports.iter().take_while(|r| r["learning"] == true).count();
    assert_eq!(learning, learning_frames, "{name}: learning frames");
    assert!(reports[..learning].iter().all(|r| r["found"] == false));
    let s = score(&reports[learning..], &r.truths[learning..]);
    // A round LED alone in the first frame searched is not told from glare until it moves.
    let leading_ambiguous = reports[learning..]
        .iter()
        .take_while(|r| r["ambiguous"] == true)
        .count();
    assert!(
        leading_ambiguous <= 1,
        "{name}: {leading_ambiguous} ambiguous"
    );
    assert_eq!(
        s.detected + leading_ambiguous,
        s.visible,
        "{name}: every visible frame after learning (and that one) is detected"
    );
    assert_eq!(s.false_reports, 0, "{name}");
    let (mid, pos) = (
        quantile(&s.mid_errors_px, 0.5),
        quantile(&s.pos_errors_px, 0.5),
    );
    let (mid95, pos95) = (
        quantile(&s.mid_errors_px, 0.95),
        quantile(&s.pos_errors_px, 0.95),
    );
    eprintln!("bgdiff {name}: middle median {mid:.3} p95 {mid95:.3}; position median {pos:.3} p95 {pos95:.3}");
    assert!(
        mid <= 0.2 && mid95 <= 0.5,
        "{name}: middle {mid:.3} / {mid95:.3}"
    );
    assert!(
        pos <= 0.5 && pos95 <= 1.5,
        "{name}: position {pos:.3} / {pos95:.3}"
    );
}

#[test]
fn learned_from_the_first_frames() {
    for name in ["fast-line", "circles", "glare", "dim-noisy"] {
        let r = render(name);
        let out = track(&r, &["--detector", "bgdiff"]);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        check(name, &r, &parse_jsonl(&out.stdout), LEARNING_FRAMES);
    }
}

#[test]
fn learned_from_a_separate_recording_of_the_empty_scene() {
    let r = render("glare");
    // The same scene with the LED switched off: floor, glare and noise only.
    let mut config = Scene::preset_config("glare").unwrap();
    config.led.peak = 0.0;
    config.led.glow_peak = 0.0;
    config.seed += 1; // other noise than the tracked video
    let (empty, _) = Scene::new(config).unwrap().render_dump();
    let (_dir, background) = temp_file("empty.yuv", &empty);
    let out = track(
        &r,
        &[
            "--detector",
            "bgdiff",
            "--background",
            background.to_str().unwrap(),
        ],
    );
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    check("glare", &r, &parse_jsonl(&out.stdout), 0);
}

#[test]
fn a_background_too_short_or_without_bgdiff_is_refused() {
    let r = render("slow-line");
    let one_frame = vec![16u8; (r.scene.width_px() * r.scene.height_px() * 2) as usize];
    let (_dir, background) = temp_file("short.yuv", &one_frame);
    let path = background.to_str().unwrap();
    let out = track(&r, &["--detector", "bgdiff", "--background", path]);
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("has 1 whole frames, --background-frames wants 9"),
        "{stderr}"
    );
    let out = track(&r, &["--background", path]);
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("--background goes with --detector bgdiff")
    );
}
