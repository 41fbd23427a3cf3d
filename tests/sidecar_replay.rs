//! `glint track --input` with the sidecar `glint record` writes: replays carry the recorded
//! frame times, sequence numbers and drops; a sidecar that disagrees with its dump stops the
//! replay with one clear line. Also the choice between `--input` and `--device`.

mod common;

use std::path::{Path, PathBuf};
use std::process::Output;

use common::{glint, parse_jsonl, render, Rendered};
use glint::frame::FrameSize;
use glint::source::sidecar::{FrameTiming, Sidecar};

/// Frames of the rendered scene kept in the "recording".
const KEPT: usize = 40;

/// A recording of the first frames of slow-line in which the camera dropped two frames after
/// every five, at irregular times; written as DIR/rec.yuv plus DIR/rec.yuv.json.
struct Recording {
    rendered: Rendered,
    dump: PathBuf,
    timings: Vec<FrameTiming>,
    /// The scene frame each recorded frame shows.
    scene_frames: Vec<usize>,
}

fn record() -> Recording {
    let rendered = render("slow-line");
    let size = FrameSize::new(rendered.scene.width_px(), rendered.scene.height_px()).unwrap();
    let all = std::fs::read(&rendered.dump).unwrap();
    let mut dump = Vec::new();
    let mut timings = Vec::new();
    let mut scene_frames = Vec::new();
    for (i, frame) in all.chunks_exact(size.frame_bytes()).enumerate() {
        if i % 7 >= 5 {
            continue;
        }
        if timings.len() == KEPT {
            break;
        }
        dump.extend_from_slice(frame);
        timings.push(FrameTiming {
            seq: 1000 + i as u64,
            t_us: i as u64 * 33_367 + (i as u64 * 31) % 400,
        });
        scene_frames.push(i);
    }
    let path = rendered.dump.with_file_name("rec.yuv");
    std::fs::write(&path, dump).unwrap();
    let mut sidecar = Sidecar::new(size, size.row_bytes(), timings.clone());
    sidecar.fps = Some(29.97);
    write_sidecar(&path, &sidecar);
    Recording {
        rendered,
        dump: path,
        timings,
        scene_frames,
    }
}

fn write_sidecar(dump: &Path, sidecar: &Sidecar) {
    let file = std::fs::File::create(Sidecar::path_for(dump)).unwrap();
    sidecar.write(file).unwrap();
}

fn track(dump: &Path, extra: &[&str]) -> Output {
    glint()
        .args(["track", "--input"])
        .arg(dump)
        .args(["--size", "640x480"])
        .args(extra)
        .output()
        .unwrap()
}

fn assert_one_line_error(out: &Output, needles: &[&str]) {
    assert!(!out.status.success(), "must fail");
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!stderr.contains("panicked"), "{stderr}");
    assert_eq!(stderr.trim_end().lines().count(), 1, "one line: {stderr}");
    for needle in needles {
        assert!(stderr.contains(needle), "{needle:?} in {stderr}");
    }
}

#[test]
fn a_replay_reproduces_the_recorded_times_sequence_and_drops() {
    let rec = record();
    let out = track(&rec.dump, &[]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let reports = parse_jsonl(&out.stdout);
    assert_eq!(reports.len(), KEPT);
    for (i, (r, timing)) in reports.iter().zip(&rec.timings).enumerate() {
        assert_eq!(r["frame"].as_u64(), Some(i as u64));
        assert_eq!(r["seq"].as_u64(), Some(timing.seq));
        let dropped = if i == 0 {
            0
        } else {
            timing.seq - rec.timings[i - 1].seq - 1
        };
        assert_eq!(r["dropped"].as_u64(), Some(dropped), "{r}");
        let t_us = (r["t"].as_f64().unwrap() * 1e6).round() as u64;
        assert_eq!(t_us, timing.t_us, "{r}");
        if i == 0 && r["ambiguous"] == true {
            // A round LED alone in the first frame is not told from glare until it moves.
            continue;
        }
        // The frame shows what the scene rendered for its own index, not for the report's.
        let truth = &rec.rendered.truths[rec.scene_frames[i]];
        let error_px = (r["mid_x"].as_f64().unwrap() - truth.mid_x_px.unwrap())
            .hypot(r["mid_y"].as_f64().unwrap() - truth.mid_y_px.unwrap());
        assert!(error_px < 0.5, "{r}: {error_px:.3} px off");
    }
    assert!(reports.iter().any(|r| r["dropped"] == 2));
}

#[test]
fn no_sidecar_falls_back_to_the_nominal_frame_rate() {
    let rec = record();
    let out = track(&rec.dump, &["--no-sidecar", "--fps", "10"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let reports = parse_jsonl(&out.stdout);
    assert_eq!(reports.len(), KEPT);
    assert_eq!(reports[3]["t"].as_f64(), Some(0.3));
    assert_eq!(reports[3]["seq"].as_u64(), Some(3));
    assert!(reports.iter().all(|r| r["dropped"] == 0));
}

#[test]
fn a_sidecar_that_disagrees_with_its_dump_is_one_clear_error() {
    let rec = record();
    let size = FrameSize::new(640, 480).unwrap();
    let sidecar_path = Sidecar::path_for(&rec.dump);
    let name = sidecar_path.display().to_string();

    // One frame fewer listed than the dump holds.
    write_sidecar(
        &rec.dump,
        &Sidecar::new(size, 1280, rec.timings[1..].to_vec()),
    );
    let out = track(&rec.dump, &[]);
    assert_one_line_error(
        &out,
        &[
            &name,
            "lists 39 frames but the dump holds 40 frames",
            "--no-sidecar",
        ],
    );
    assert!(out.stdout.is_empty(), "nothing is tracked");

    // Frames of another size.
    let small = FrameSize::new(320, 240).unwrap();
    write_sidecar(&rec.dump, &Sidecar::new(small, 640, rec.timings.clone()));
    assert_one_line_error(
        &track(&rec.dump, &[]),
        &["the sidecar says the frames are 320x240, but --size is 640x480"],
    );

    // Not a sidecar at all, and a timeline that runs backwards.
    std::fs::write(&sidecar_path, b"width=640\n").unwrap();
    assert_one_line_error(&track(&rec.dump, &[]), &[&name, "not a glint sidecar"]);
    let mut backwards = rec.timings.clone();
    backwards[5].t_us = 0;
    write_sidecar(&rec.dump, &Sidecar::new(size, 1280, backwards));
    assert_one_line_error(&track(&rec.dump, &[]), &["frame 5: time 0 µs is earlier"]);

    // The escape hatch.
    let out = track(&rec.dump, &["--no-sidecar"]);
    assert!(out.status.success());
    assert_eq!(parse_jsonl(&out.stdout).len(), KEPT);
}

#[cfg(feature = "v4l2")]
#[test]
fn input_and_device_are_mutually_exclusive_and_one_is_required() {
    let both = glint()
        .args([
            "track",
            "--input",
            "x.yuv",
            "--device",
            "/dev/video0",
            "--size",
            "64x48",
        ])
        .output()
        .unwrap();
    assert_eq!(both.status.code(), Some(2));
    assert_one_line_error(&both, &["cannot be used with"]);
    let neither = glint().args(["track", "--size", "64x48"]).output().unwrap();
    assert_eq!(neither.status.code(), Some(2));
    assert_one_line_error(&neither, &["required", "--input", "--device"]);
    let camera_option_on_a_dump = glint()
        .args([
            "track", "--input", "x.yuv", "--size", "64x48", "--gain", "5",
        ])
        .output()
        .unwrap();
    assert_one_line_error(&camera_option_on_a_dump, &["need --device"]);
    // The exposure also describes a recording (it gives the single-frame speed): allowed.
    let (_dir, dump) = {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("blank.yuv");
        std::fs::write(&path, vec![0u8; 64 * 48 * 2]).unwrap();
        (dir, path)
    };
    let exposure_on_a_dump = glint()
        .args([
            "track",
            "--size",
            "64x48",
            "--exposure-us",
            "500",
            "--input",
        ])
        .arg(&dump)
        .output()
        .unwrap();
    assert!(
        exposure_on_a_dump.status.success(),
        "{}",
        String::from_utf8_lossy(&exposure_on_a_dump.stderr)
    );
}

#[cfg(feature = "v4l2")]
#[test]
fn a_device_that_is_not_there_or_not_a_camera_is_a_clear_error() {
    let out = glint()
        .args([
            "track",
            "--device",
            "/dev/no-such-video9",
            "--size",
            "640x480",
        ])
        .output()
        .unwrap();
    assert_one_line_error(&out, &["cannot open /dev/no-such-video9"]);
    let out = glint()
        .args([
            "record",
            "--device",
            "/dev/null",
            "--size",
            "640x480",
            "--frames",
            "3",
        ])
        .args(["--out", "/nonexistent/x.yuv"])
        .output()
        .unwrap();
    assert_one_line_error(&out, &["/dev/null"]);
}
