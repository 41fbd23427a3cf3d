//! The `glint-demo` and `glint-view` binaries, run as a user runs them.

use std::fs::{self, File};
use std::io::{BufWriter, Write};
use std::path::Path;
use std::process::{Command, Output, Stdio};

use glint_tools::overlay::style;
use glint_tools::scene::{write_truth_csv, Scene};

/// Frames in the scenes rendered here: enough for a table, few enough to stay quick.
const FRAMES: usize = 12;

fn run(mut command: Command) -> (Output, String, String) {
    let output = command.output().expect("the binary runs");
    let stdout = String::from_utf8_lossy(&output.stdout).into_owned();
    let stderr = String::from_utf8_lossy(&output.stderr).into_owned();
    (output, stdout, stderr)
}

/// The decoded RGB pixels and size of a PNG file.
fn decode_png(path: &Path) -> (u32, u32, Vec<u8>) {
    let decoder = png::Decoder::new(std::io::BufReader::new(File::open(path).expect("png")));
    let mut reader = decoder.read_info().expect("a PNG header");
    let mut buf = vec![0; reader.output_buffer_size().expect("a sane size")];
    let info = reader.next_frame(&mut buf).expect("PNG pixels");
    assert_eq!(info.color_type, png::ColorType::Rgb);
    buf.truncate(info.buffer_size());
    (info.width, info.height, buf)
}

fn has_colour(rgb: &[u8], colour: [u8; 3]) -> bool {
    rgb.chunks_exact(3).any(|p| p == colour)
}

#[test]
fn the_demo_prints_a_summary_and_writes_its_overlay_in_the_current_directory() {
    let dir = tempfile::tempdir().unwrap();
    let mut demo = Command::new(env!("CARGO_BIN_EXE_glint-demo"));
    demo.current_dir(dir.path())
        .args(["--frames", &FRAMES.to_string()]);
    let (output, stdout, stderr) = run(demo);
    assert!(output.status.success(), "{stderr}");

    let summary = stdout
        .lines()
        .find(|l| l.starts_with("summary:"))
        .unwrap_or_else(|| panic!("no summary in:\n{stdout}"));
    // Every frame of `circles` shows the whole LED, and glint finds it in each.
    assert_eq!(
        summary,
        format!(
            "summary: {FRAMES} frames, LED visible in {FRAMES}, detected in {FRAMES} \
             (missed 0 visible, found 0 while hidden)"
        )
    );
    assert!(stdout.contains("streak middle (mid_x, mid_y) error: median"));
    assert!(stdout.contains("time per frame: glint"));

    let (width, height, rgb) = decode_png(&dir.path().join("demo-overlay.png"));
    // The 640×480 frame, the gap and an inset at most the frame's height, then a caption.
    assert!((640 + 8 + 240..=640 + 8 + 480).contains(&width), "{width}");
    assert!(height > 480, "{height}");
    // glint's middle and the truth are drawn.
    assert!(has_colour(&rgb, style::MID.colour));
    assert!(has_colour(&rgb, style::TRUTH_MID.colour));
}

#[test]
fn the_demo_writes_where_told_and_refuses_what_it_cannot_do() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("fast.png");
    let mut demo = Command::new(env!("CARGO_BIN_EXE_glint-demo"));
    demo.args([
        "--scene",
        "fast-line",
        "--frames",
        "4",
        "--frame",
        "3",
        "--out",
    ])
    .arg(&out);
    let (output, stdout, stderr) = run(demo);
    assert!(output.status.success(), "{stderr}");
    assert!(stdout.contains("<- overlay"), "{stdout}");
    let (width, _, _) = decode_png(&out);
    assert!(width > 640);

    let mut unknown = Command::new(env!("CARGO_BIN_EXE_glint-demo"));
    unknown
        .args(["--scene", "no-such-scene", "--out"])
        .arg(&out);
    let (output, _, stderr) = run(unknown);
    assert!(!output.status.success());
    assert!(
        stderr.contains("unknown scene") && stderr.contains("circles"),
        "{stderr}"
    );

    let mut past = Command::new(env!("CARGO_BIN_EXE_glint-demo"));
    past.args(["--frames", "4", "--frame", "4", "--out"])
        .arg(&out);
    let (output, _, stderr) = run(past);
    assert!(!output.status.success());
    assert!(stderr.contains("past the end"), "{stderr}");
}

/// A short `slow-line` dump and its truth CSV in `dir`.
fn write_scene(dir: &Path) -> (std::path::PathBuf, std::path::PathBuf, usize) {
    let mut config = Scene::preset_config("slow-line").unwrap();
    config.frame_count = 4;
    let scene = Scene::new(config).unwrap();
    let (bytes, truths) = scene.render_dump();
    let dump = dir.join("slow.yuv");
    let truth = dir.join("slow.truth.csv");
    fs::write(&dump, &bytes).unwrap();
    let mut csv = BufWriter::new(File::create(&truth).unwrap());
    write_truth_csv(&mut csv, &truths).unwrap();
    csv.flush().unwrap();
    (dump, truth, scene.frame_len_bytes())
}

fn view(dump: &Path, frame: u64, out: &Path) -> Command {
    let mut command = Command::new(env!("CARGO_BIN_EXE_glint-view"));
    command
        .arg("--input")
        .arg(dump)
        .args(["--size", "640x480", "--frame", &frame.to_string(), "--out"])
        .arg(out);
    command
}

#[test]
fn view_draws_a_frame_of_a_dump_with_its_truth() {
    let dir = tempfile::tempdir().unwrap();
    let (dump, truth, _) = write_scene(dir.path());
    let out = dir.path().join("frame2.png");
    let mut command = view(&dump, 2, &out);
    command.arg("--truth").arg(&truth);
    let (output, stdout, stderr) = run(command);
    assert!(output.status.success(), "{stderr}");
    assert!(stdout.starts_with("frame 2: found, mid "), "{stdout}");
    assert!(stdout.contains("truth: mid "), "{stdout}");
    let (width, height, rgb) = decode_png(&out);
    assert!(width > 640 && height > 480);
    assert!(has_colour(&rgb, style::TRUTH_POSITION.colour));
    assert!(has_colour(&rgb, style::POSITION.colour));
}

#[test]
fn view_refuses_a_frame_past_the_end_before_processing() {
    let dir = tempfile::tempdir().unwrap();
    let (dump, _, _) = write_scene(dir.path());
    let out = dir.path().join("never.png");
    let (output, stdout, stderr) = run(view(&dump, 4, &out));
    assert!(!output.status.success());
    assert!(stdout.is_empty());
    assert_eq!(
        stderr.trim(),
        format!(
            "glint-view: frame 4 is past the end of {}: it holds 4 whole frames of 640x480 \
             (614400 bytes each)",
            dump.display()
        )
    );
    assert!(!out.exists());
}

#[test]
fn view_reports_a_truncated_dump_from_a_file_and_from_a_pipe() {
    let dir = tempfile::tempdir().unwrap();
    let (dump, _, frame_bytes) = write_scene(dir.path());
    let cut = dir.path().join("cut.yuv");
    let bytes = fs::read(&dump).unwrap();
    fs::write(&cut, &bytes[..frame_bytes + 1000]).unwrap();
    let out = dir.path().join("never.png");

    let (output, _, stderr) = run(view(&cut, 1, &out));
    assert!(!output.status.success());
    assert!(
        stderr.contains("holds 1 whole frames") && stderr.contains("1000 trailing bytes"),
        "{stderr}"
    );

    // Through standard input the length is unknown until the stream ends inside frame 1.
    let mut piped = view(Path::new("-"), 1, &out);
    piped
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped());
    let mut child = piped.spawn().unwrap();
    let mut stdin = child.stdin.take().unwrap();
    // Should the child fail early, the write fails too; its stderr says why.
    let _ = stdin.write_all(&bytes[..frame_bytes + 1000]);
    drop(stdin);
    let output = child.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&output.stderr);
    assert!(!output.status.success());
    assert!(stderr.contains("input ends inside frame 1"), "{stderr}");
    assert!(!out.exists());
}

/// Runs `glint-plot` on `track` (written to a file) with `extra` arguments.
fn plot(dir: &Path, track: &str, extra: &[&str]) -> (Output, String) {
    let input = dir.join("track.jsonl");
    fs::write(&input, track).unwrap();
    let mut command = Command::new(env!("CARGO_BIN_EXE_glint-plot"));
    command
        .arg("--input")
        .arg(&input)
        .arg("--out")
        .arg(dir.join("plot.png"))
        .args(extra);
    let (output, _, stderr) = run(command);
    (output, stderr)
}

#[test]
fn glint_plot_writes_a_png_of_the_requested_size() {
    use glint_tools::plot::style as plot_style;
    let dir = tempfile::tempdir().unwrap();
    let track: String = (0..40)
        .map(|k| {
            let found = k % 13 != 7;
            let a = f64::from(k) * 0.2;
            if found {
                format!(
                    "{{\"frame\":{k},\"t\":{},\"found\":true,\"x\":{},\"y\":{}}}\n",
                    f64::from(k) / 30.0,
                    320.0 + 100.0 * a.cos(),
                    240.0 + 60.0 * a.sin()
                )
            } else {
                format!(
                    "{{\"frame\":{k},\"t\":{},\"found\":false}}\n",
                    f64::from(k) / 30.0
                )
            }
        })
        .collect();
    let (output, stderr) = plot(dir.path(), &track, &["--width", "640", "--height", "720"]);
    assert!(output.status.success(), "{stderr}");
    assert!(stderr.contains("40 frames (37 with a position"), "{stderr}");
    let (width, height, rgb) = decode_png(&dir.path().join("plot.png"));
    assert_eq!((width, height), (640, 720));
    assert!(has_colour(&rgb, plot_style::TRAJECTORY));
    assert!(has_colour(&rgb, plot_style::SPEED));
}

#[test]
fn glint_plot_refuses_bad_lines_empty_input_and_bad_sizes() {
    let dir = tempfile::tempdir().unwrap();
    let good = "{\"t\":0.0,\"found\":true,\"x\":1.0,\"y\":2.0}\n";
    let cases = [
        (
            format!("{good}{{\"t\":0.1,\"found\":tru\n"),
            "line 2: not a glint track record",
        ),
        (String::new(), "the track is empty"),
        (
            "{\"t\":0.0,\"found\":false}\n".into(),
            "none of the 1 frames has a position",
        ),
    ];
    for (track, expected) in cases {
        let (output, stderr) = plot(dir.path(), &track, &[]);
        assert!(!output.status.success(), "accepted {track:?}");
        assert!(stderr.contains(expected), "{track:?}: {stderr}");
        assert!(
            !dir.path().join("plot.png").exists(),
            "wrote a PNG for {track:?}"
        );
    }
    let (output, stderr) = plot(dir.path(), good, &["--width", "10"]);
    assert!(!output.status.success());
    assert!(stderr.contains("outside 240..=8192"), "{stderr}");
}
