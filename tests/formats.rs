//! Mono and UYVY cameras: the same rendered scenes, repacked as UYVY and as GREY (8-bit luma),
//! give exactly the reports of the YUYV original through the whole `glint track` binary, and a
//! recording's sidecar carries the format to its replay.

mod common;

use std::path::{Path, PathBuf};
use std::process::Output;

use common::{glint, parse_jsonl, render, repack, Rendered};
use glint::frame::{FrameSize, PixelFormat};
use glint::source::sidecar::{FrameTiming, Sidecar};

/// Frames of each scene replayed.
const KEPT: usize = 45;

fn size_of(r: &Rendered) -> FrameSize {
    FrameSize::new(r.scene.width_px(), r.scene.height_px()).unwrap()
}

/// Writes the first [`KEPT`] frames of `r` as `format` beside its dump.
fn write_as(r: &Rendered, format: PixelFormat) -> PathBuf {
    let size = size_of(r);
    let all = std::fs::read(&r.dump).unwrap();
    let yuyv = &all[..KEPT * size.frame_bytes()];
    let path = r.dump.with_file_name(format!("frames.{format}"));
    std::fs::write(&path, repack(yuyv, format)).unwrap();
    path
}

fn track(r: &Rendered, dump: &Path, extra: &[&str]) -> Output {
    let size = format!("{}x{}", r.scene.width_px(), r.scene.height_px());
    let exposure = r.scene.exposure_us().to_string();
    glint()
        .args(["track", "--input"])
        .arg(dump)
        .args(["--size", &size, "--exposure-us", &exposure])
        .args(extra)
        .output()
        .expect("run glint")
}

fn stdout_of(out: &Output) -> String {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8(out.stdout.clone()).unwrap()
}

#[test]
fn uyvy_and_grey_frames_give_the_reports_of_yuyv() {
    for name in ["fast-line", "glare", "window"] {
        let r = render(name);
        let yuyv = write_as(&r, PixelFormat::Yuyv);
        let reference = stdout_of(&track(&r, &yuyv, &[]));
        let found = parse_jsonl(reference.as_bytes())
            .iter()
            .filter(|j| j["found"] == true)
            .count();
        assert!(found >= KEPT / 2, "{name}: the YUYV replay finds the LED");
        for format in [PixelFormat::Uyvy, PixelFormat::Grey] {
            let dump = write_as(&r, format);
            let out = stdout_of(&track(&r, &dump, &["--format-in", format.name()]));
            assert_eq!(out, reference, "{name} as {format}");
        }
    }
}

#[test]
fn the_sidecar_carries_the_format_and_a_contradiction_is_refused() {
    let r = render("slow-line");
    let size = size_of(&r);
    let dump = write_as(&r, PixelFormat::Grey);
    let reference = stdout_of(&track(&r, &dump, &["--format-in", "grey"]));
    let timings: Vec<FrameTiming> = (0..KEPT as u64)
        .map(|i| FrameTiming {
            seq: i,
            // The times a dump without a sidecar gets at its nominal 30 fps.
            t_us: (i as f64 * 1e6 / 30.0).round() as u64,
        })
        .collect();
    let sidecar = Sidecar::new(size, size.width(), timings).with_format(PixelFormat::Grey);
    let mut text = Vec::new();
    sidecar.write(&mut text).unwrap();
    assert!(String::from_utf8_lossy(&text).contains("\"format\":\"GREY\""));
    std::fs::write(Sidecar::path_for(&dump), text).unwrap();

    // Without --format-in the sidecar's GREY is used; the frames and times are the same.
    let replayed = stdout_of(&track(&r, &dump, &[]));
    let frames = |text: &str| -> Vec<(bool, Option<f64>, Option<f64>)> {
        parse_jsonl(text.as_bytes())
            .iter()
            .map(|j| (j["found"] == true, j["x"].as_f64(), j["y"].as_f64()))
            .collect()
    };
    assert_eq!(frames(&replayed), frames(&reference));

    let out = track(&r, &dump, &["--format-in", "yuyv"]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("the frames are grey, but --format-in is yuyv"),
        "{err}"
    );

    // Read as YUYV without the sidecar, the GREY dump is half a frame short at its end.
    let out = track(&r, &dump, &["--no-sidecar"]);
    assert!(!out.status.success());
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("is --size right?"),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let out = track(&r, &dump, &["--format-in", "nv12"]);
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("yuyv, uyvy, grey"));
}
