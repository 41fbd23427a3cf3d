//! Hostile lens files given to `glint calibrate --lens FILE`, through the real binary: a file
//! for another image size, NaN or absurd coefficients, a lens that folds the picture over, a
//! FIFO, a device, binary garbage. Each gets one line naming the problem and a failure exit,
//! never a panic or a hang, and no calibration file is written. (The parser's own cases, and
//! the calibration file's edited lens, are unit tests beside the code; overlapping markers on
//! the map are in `tests/cli_calibrate.rs`.)

mod common;

use std::path::Path;
use std::process::{Command, Output, Stdio};
use std::thread;
use std::time::{Duration, Instant};

use common::glint;

/// Longest a refusal may take before the test calls it a hang (the machine is shared).
const HANG: Duration = Duration::from_secs(20);

/// A ROS `camera_info` file for 640×480 with `distortion` as its coefficients.
fn ros(width: u32, height: u32, distortion: &str) -> String {
    format!(
        "image_width: {width}\nimage_height: {height}\ncamera_name: webcam\ncamera_matrix:\n  \
         rows: 3\n  cols: 3\n  data: [460.0, 0.0, 319.5, 0.0, 462.0, 239.5, 0.0, 0.0, 1.0]\n\
         distortion_model: plumb_bob\ndistortion_coefficients:\n  rows: 1\n  cols: 5\n  \
         data: [{distortion}]\n"
    )
}

/// `glint calibrate` with `--lens lens` on an empty dump, bounded by [`HANG`].
fn calibrate_with(dir: &Path, lens: &Path) -> Output {
    let dump = dir.join("empty.yuv");
    std::fs::write(&dump, []).unwrap();
    let mut child = glint()
        .args([
            "calibrate",
            "--size",
            "640x480",
            "--marker",
            "23:20",
            "--input",
        ])
        .arg(&dump)
        .arg("--lens")
        .arg(lens)
        .arg("--out")
        .arg(dir.join("calib.toml"))
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let start = Instant::now();
    while child.try_wait().unwrap().is_none() {
        if start.elapsed() > HANG {
            let _ = child.kill();
            panic!("glint calibrate --lens {} hung", lens.display());
        }
        thread::sleep(Duration::from_millis(10));
    }
    child.wait_with_output().unwrap()
}

fn assert_one_line(out: &Output, want: &str, dir: &Path) {
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{err}");
    assert_eq!(err.trim_end().lines().count(), 1, "one line: {err}");
    assert!(err.contains(want), "{want:?} in {err}");
    assert!(!err.contains("panicked"), "{err}");
    assert!(!dir.join("calib.toml").exists(), "nothing written");
}

#[test]
fn bad_lens_files_get_one_line_naming_the_problem() {
    let dir = tempfile::tempdir().unwrap();
    let good = "-0.3, 0.09, 0.001, -0.0005, 0.0";
    let cases = [
        (
            ros(1280, 720, good),
            "made for 1280x720 images, but the frames are 640x480",
        ),
        (
            ros(640, 480, "nan, 0.09, 0.001, -0.0005, 0.0"),
            "a number is NaN or infinite",
        ),
        (
            ros(640, 480, "-0.3, 1e999, 0.001, -0.0005, 0.0"),
            "a number is NaN or infinite",
        ),
        (
            ros(640, 480, "-3000.0, 0.09, 0.001, -0.0005, 0.0"),
            "absurdly large",
        ),
        // Within the size bound, but the picture folds over before its corners.
        (
            ros(640, 480, "-5.0, 0.0, 0.0, 0.0, 0.0"),
            "folds the picture over",
        ),
        (ros(640, 480, "-0.3, 0.09"), "distortion_coefficients"),
    ];
    for (i, (text, want)) in cases.iter().enumerate() {
        let lens = dir.path().join(format!("lens{i}.yaml"));
        std::fs::write(&lens, text).unwrap();
        let out = calibrate_with(dir.path(), &lens);
        assert_one_line(&out, want, dir.path());
        assert!(
            String::from_utf8_lossy(&out.stderr).contains(lens.to_str().unwrap()),
            "names the file"
        );
    }
    // The reference file itself is accepted: the refusals above are the edits'.
    let lens = dir.path().join("good.yaml");
    std::fs::write(&lens, ros(640, 480, good)).unwrap();
    let out = calibrate_with(dir.path(), &lens);
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("holds no whole frame"),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
}

#[test]
fn a_lens_path_that_is_no_file_is_refused_without_waiting() {
    let dir = tempfile::tempdir().unwrap();
    let fifo = dir.path().join("lens.fifo");
    assert!(Command::new("mkfifo")
        .arg(&fifo)
        .status()
        .unwrap()
        .success());
    let garbage = dir.path().join("garbage.yaml");
    std::fs::write(&garbage, [0xff, 0xfe, 0x00, 0x9c, 0x12]).unwrap();
    let huge = dir.path().join("huge.yaml");
    std::fs::write(&huge, vec![b'#'; 1024 * 1024]).unwrap();
    for (path, want) in [
        (fifo.as_path(), "a FIFO, not a regular file"),
        (
            Path::new("/dev/zero"),
            "a character device, not a regular file",
        ),
        (garbage.as_path(), "not UTF-8 text"),
        (huge.as_path(), "too large"),
        (dir.path(), "a directory, not a regular file"),
    ] {
        let out = calibrate_with(dir.path(), path);
        assert_one_line(&out, want, dir.path());
    }
}
