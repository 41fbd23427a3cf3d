//! `glint run`: the settings file and its validation, command-line overrides, the same reports
//! as `glint track`, the periodic status line, and a clean stop on SIGTERM.

mod common;

use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

use common::live::{feed_endlessly, lines_of};
use common::{glint, parse_jsonl, render, track, Rendered};

/// Longest wait for the live run to show a status line or to stop.
const PATIENCE: Duration = Duration::from_secs(60);

/// Writes `text` as DIR/glint.toml.
fn settings(dir: &Path, text: &str) -> PathBuf {
    let path = dir.join("glint.toml");
    std::fs::write(&path, text).unwrap();
    path
}

/// The settings of `common::track` for the rendered scene, as a file, with `extra` lines.
fn settings_for(r: &Rendered, dir: &Path, jsonl: &Path, extra: &str) -> PathBuf {
    let text = format!(
        "# as glint track --input DUMP --size WxH --fps F --exposure-us E\n\
         input = {:?}\nsize = \"{}x{}\"\nfps = {}\nexposure-us = {}\njsonl = {:?}\n{extra}",
        r.dump.display().to_string(),
        r.scene.width_px(),
        r.scene.height_px(),
        r.scene.fps(),
        r.scene.exposure_us(),
        jsonl.display().to_string(),
    );
    settings(dir, &text)
}

fn run(args: &[&std::ffi::OsStr]) -> Output {
    glint().arg("run").args(args).output().expect("run glint")
}

fn stderr(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

#[test]
fn a_run_from_settings_reports_what_track_reports() {
    let r = render("fast-line");
    let dir = tempfile::tempdir().unwrap();
    let jsonl = dir.path().join("track.jsonl");
    let config = settings_for(&r, dir.path(), &jsonl, "threshold = 200\nerode = 1\n");
    let out = run(&["--config".as_ref(), config.as_os_str()]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(out.stdout.is_empty(), "JSON goes to the file only");
    let ran = std::fs::read(&jsonl).unwrap();
    let tracked = track(&r, &["--threshold", "200", "--erode", "1"]);
    assert!(tracked.status.success());
    assert_eq!(
        String::from_utf8_lossy(&ran),
        String::from_utf8_lossy(&tracked.stdout)
    );
    let reports = parse_jsonl(&ran);
    assert_eq!(reports.len(), r.truths.len());
    assert!(reports.iter().filter(|v| v["found"] == true).count() > reports.len() / 2);
    // A different setting gives different reports: the comparison above can fail.
    let other = track(&r, &["--threshold", "200", "--erode", "3"]);
    assert_ne!(other.stdout, tracked.stdout);
}

#[test]
fn the_command_line_overrides_the_file() {
    let r = render("slow-line");
    let dir = tempfile::tempdir().unwrap();
    let jsonl = dir.path().join("track.jsonl");
    // The file says 10 fps; the command line 25, which sets the frame times.
    let config = settings_for(&r, dir.path(), &jsonl, "").with_extension("toml");
    let text = std::fs::read_to_string(&config)
        .unwrap()
        .replace(&format!("fps = {}", r.scene.fps()), "fps = 10");
    std::fs::write(&config, text).unwrap();
    let out = run(&[
        "--config".as_ref(),
        config.as_os_str(),
        "--fps".as_ref(),
        "25".as_ref(),
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    let reports = parse_jsonl(&std::fs::read(&jsonl).unwrap());
    let t1 = reports[1]["t"].as_f64().unwrap();
    assert!((t1 - 1.0 / 25.0).abs() < 1e-6, "frame 1 at {t1} s");
}

#[test]
fn bad_settings_stop_start_up_naming_the_key() {
    let r = render("slow-line");
    let dir = tempfile::tempdir().unwrap();
    let jsonl = dir.path().join("never.jsonl");
    let cases = [
        ("exposur-us = 100\n", "unknown key `exposur-us`"),
        ("baud = 10\n", "key `baud`: invalid value '10'"),
        (
            "detector = \"magic\"\n",
            "key `detector`: invalid value 'magic'",
        ),
        ("stats = 1\n", "key `stats`: a switch takes true or false"),
        (
            "calib = \"/nonexistent/calib.toml\"\n",
            "calib = \"/nonexistent/calib.toml\"",
        ),
        (
            "serial = [\"1=/dev/null\", \"1=/dev/zero\"]\n",
            "robot 1 is given two serial ports (--serial 1=/dev/null and --serial 1=/dev/zero)",
        ),
        (
            "serial = \"17=/dev/null\"\n",
            "key `serial`: invalid value '17=/dev/null'",
        ),
        ("serial = [\"/dev/null\", \"2=/dev/zero\"]\n", "do not mix"),
    ];
    for (extra, want) in cases {
        let config = settings_for(&r, dir.path(), &jsonl, extra);
        let out = run(&["--config".as_ref(), config.as_os_str()]);
        let err = stderr(&out);
        assert!(!out.status.success(), "{extra:?} was accepted");
        assert!(err.contains(want), "{extra:?}: {err}");
        let last = err.lines().last().unwrap_or_default();
        assert!(
            last.starts_with("glint: ") && last.contains(want),
            "one line: {err}"
        );
        assert!(!jsonl.exists(), "{extra:?}: nothing ran");
    }
    // Negative frame rates and sizes that are not WxH.
    let config = settings_for(&r, dir.path(), &jsonl, "");
    let text = std::fs::read_to_string(&config).unwrap();
    for (from, to, want) in [
        (
            format!("fps = {}", r.scene.fps()),
            "fps = -30".to_string(),
            "key `fps`",
        ),
        (
            "size = \"640x480\"".to_string(),
            "size = \"640\"".to_string(),
            "key `size`",
        ),
    ] {
        assert!(text.contains(&from), "{text}");
        std::fs::write(&config, text.replace(&from, &to)).unwrap();
        let out = run(&["--config".as_ref(), config.as_os_str()]);
        assert_eq!(out.status.code(), Some(2), "{to}");
        assert!(stderr(&out).contains(want), "{to}: {}", stderr(&out));
    }
}

/// A live run on standard input, fed without end: the status line appears periodically, and
/// SIGTERM ends the run cleanly (exit 0, every JSON line whole, the closing summary logged).
#[test]
fn sigterm_stops_a_live_run_cleanly_after_status_lines() {
    let r = render("circles");
    let frames = std::fs::read(&r.dump).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let jsonl = dir.path().join("live.jsonl");
    let config = settings(
        dir.path(),
        &format!(
            "input = \"-\"\nsize = \"{}x{}\"\nfps = 30\nsummary-every = 0.2\njsonl = {:?}\n",
            r.scene.width_px(),
            r.scene.height_px(),
            jsonl.display().to_string()
        ),
    );
    let mut child = Command::new(env!("CARGO_BIN_EXE_glint"))
        .args(["run", "--config"])
        .arg(&config)
        .stdin(Stdio::piped())
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    // The "camera": the scene over and over, until glint stops reading.
    let frame_bytes = frames.len() / r.truths.len();
    let feeder = feed_endlessly(child.stdin.take().unwrap(), frames, frame_bytes);
    let (lines, reader) = lines_of(child.stderr.take().unwrap());
    let start = Instant::now();
    let mut status = Vec::new();
    while status.len() < 2 {
        let line = lines
            .recv_timeout(PATIENCE.saturating_sub(start.elapsed()))
            .expect("status lines within the patience");
        if line.contains("fps)") {
            status.push(line);
        }
    }
    for line in &status {
        assert!(line.starts_with("glint: info: last "), "{line}");
        assert!(line.contains("LED found in"), "{line}");
        assert!(line.contains("latency p50/p90/p99 µs: wait "), "{line}");
        assert!(line.contains("process "), "{line}");
    }
    let kill = Command::new("kill")
        .args(["-TERM", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(kill.success());
    let exit = child.wait().unwrap();
    feeder.join().unwrap();
    reader.join().unwrap();
    let rest: Vec<String> = lines.try_iter().collect();
    assert!(exit.success(), "{exit:?}: {rest:?}");
    assert!(rest.iter().any(|l| l.contains("stopped after")), "{rest:?}");
    let output = std::fs::read(&jsonl).unwrap();
    assert!(output.ends_with(b"\n"), "the last line is whole");
    let reports = parse_jsonl(&output);
    assert!(reports.len() >= 2, "frames were tracked before the stop");
    for (i, report) in reports.iter().enumerate() {
        assert_eq!(report["frame"].as_u64(), Some(i as u64));
    }
}

/// The example settings file shipped for the Raspberry Pi is one `glint run` accepts: with its
/// camera, calibration and serial port swapped for a rendered dump, it runs and reports.
#[test]
fn the_shipped_example_settings_are_accepted() {
    let r = render("slow-line");
    let dir = tempfile::tempdir().unwrap();
    let jsonl = dir.path().join("out.jsonl");
    let example = include_str!("../board/raspberry-pi/glint.toml");
    let mut swapped = 0;
    let text: String = example
        .lines()
        .map(|line| {
            let key = line.split('=').next().unwrap_or("").trim();
            match key {
                "device" => {
                    swapped += 1;
                    format!(
                        "input = {:?}\njsonl = {:?}",
                        r.dump.display().to_string(),
                        jsonl.display().to_string()
                    )
                }
                "calib" | "serial" | "baud" => {
                    swapped += 1;
                    String::new()
                }
                _ => line.to_owned(),
            }
        })
        .collect::<Vec<_>>()
        .join("\n");
    assert_eq!(
        swapped, 4,
        "the example still names device, calib, serial and baud"
    );
    let path = settings(dir.path(), &text);
    let out = glint()
        .args(["run", "--config"])
        .arg(&path)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let reports = parse_jsonl(&std::fs::read(&jsonl).unwrap());
    assert_eq!(reports.len(), r.truths.len());
    // The slow LED alone in the first frame is not told from a glare spot until it moves.
    assert_eq!(reports[0]["ambiguous"], true);
    assert!(reports[1..].iter().all(|r| r["found"] == true));
}
