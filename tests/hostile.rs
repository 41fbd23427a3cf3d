//! The hostile world of issue 13, replayed in quick versions against the real binary: signals
//! while the input is idle, a standard error that cannot be written, memory asked for by the
//! options, settings and calibration files that are devices, FIFOs or huge, out-of-range
//! numbers, and the rough edges of issue 10 (empty input, no arguments). Every test of a fault
//! failed against the binary before its fix; one (the slowest frame rate) guards what a fix
//! must keep.

mod common;

use std::fs::{File, OpenOptions};
use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, ExitStatus, Output, Stdio};
use std::thread;
use std::time::{Duration, Instant};

use common::glint;

/// A small frame size for the quick replays.
const SIZE: &str = "64x48";
const FRAME_BYTES: usize = 64 * 48 * 2;
/// Longest any refusal or stop may take here before the test calls it a hang. Generous: the
/// machine is shared; the figures themselves are in the report and the README.
const HANG: Duration = Duration::from_secs(20);

/// Waits for `child` until `deadline`; kills it and returns `None` if it is still running.
fn wait_or_kill(child: &mut Child, deadline: Duration) -> Option<ExitStatus> {
    let start = Instant::now();
    while start.elapsed() < deadline {
        if let Some(status) = child.try_wait().unwrap() {
            return Some(status);
        }
        thread::sleep(Duration::from_millis(10));
    }
    let _ = child.kill();
    let _ = child.wait();
    None
}

/// Runs `glint` with `args` and no standard input, giving up (and failing) after [`HANG`].
fn run_bounded(args: &[&str]) -> Output {
    let mut child = glint()
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let stdout = child.stdout.take().unwrap();
    let stderr = child.stderr.take().unwrap();
    let out = thread::spawn(move || std::io::read_to_string(stdout).unwrap_or_default());
    let err = thread::spawn(move || std::io::read_to_string(stderr).unwrap_or_default());
    let status = wait_or_kill(&mut child, HANG);
    let stdout = out.join().unwrap();
    let stderr = err.join().unwrap();
    let status = status.unwrap_or_else(|| panic!("glint {args:?} hung; stderr: {stderr}"));
    Output {
        status,
        stdout: stdout.into_bytes(),
        stderr: stderr.into_bytes(),
    }
}

fn stderr_of(out: &Output) -> String {
    String::from_utf8_lossy(&out.stderr).into_owned()
}

/// One line on standard error, naming `want`, and exit code `code`.
fn assert_refused(out: &Output, code: i32, want: &str) {
    let err = stderr_of(out);
    assert_eq!(out.status.code(), Some(code), "{err}");
    assert_eq!(err.lines().count(), 1, "one line: {err}");
    assert!(err.contains(want), "{want:?} in {err}");
    assert!(!err.contains("panicked"), "{err}");
}

/// A dump of `frames` dark frames.
fn dark_dump(dir: &Path, frames: usize) -> PathBuf {
    let path = dir.join("dark.yuv");
    std::fs::write(&path, vec![16u8; FRAME_BYTES * frames]).unwrap();
    path
}

fn mkfifo(path: &Path) {
    let made = Command::new("mkfifo").arg(path).status().unwrap();
    assert!(made.success());
}

/// Fault 1: SIGTERM stops `glint <command> --input -` while its input pipe is open but quiet:
/// exit 0 within a few seconds, with the frames before it reported and the run's summary logged.
fn sigterm_on_an_idle_pipe(command: &str) {
    let mut child = glint()
        .args([command, "--input", "-", "--size", SIZE, "-v"])
        .args(if command == "run" {
            &["--jsonl", "-"][..]
        } else {
            &[]
        })
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let mut stdin = child.stdin.take().unwrap();
    stdin.write_all(&vec![16u8; FRAME_BYTES * 3]).unwrap();
    stdin.flush().unwrap();
    // The three frames are reported (flushed line by line: standard input is live); then the
    // pipe stays open and quiet.
    let mut stdout = BufReader::new(child.stdout.take().unwrap());
    for _ in 0..3 {
        let mut line = String::new();
        stdout.read_line(&mut line).unwrap();
        assert!(line.starts_with("{\"frame\":"), "{line:?}");
    }
    let signalled = Instant::now();
    let kill = Command::new("kill")
        .args(["-TERM", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(kill.success());
    let status = wait_or_kill(&mut child, HANG);
    let took = signalled.elapsed();
    drop(stdin);
    let err = std::io::read_to_string(child.stderr.take().unwrap()).unwrap();
    let status =
        status.unwrap_or_else(|| panic!("{command}: still running {HANG:?} after SIGTERM"));
    assert!(status.success(), "{command}: {status:?}: {err}");
    assert!(err.contains("3 frames, LED found in 0"), "{command}: {err}");
    eprintln!("{command}: SIGTERM to exit on an idle pipe: {took:?}");
}

#[test]
fn sigterm_stops_run_on_an_idle_pipe() {
    sigterm_on_an_idle_pipe("run");
}

#[test]
fn sigterm_stops_track_on_an_idle_pipe() {
    sigterm_on_an_idle_pipe("track");
}

/// Fault 1 on a FIFO: with no writer at all (opening used to wait for one), and with a writer
/// that keeps it open and says nothing.
#[test]
fn sigterm_stops_a_run_on_a_quiet_fifo() {
    let dir = tempfile::tempdir().unwrap();
    let fifo = dir.path().join("frames.fifo");
    mkfifo(&fifo);
    for with_writer in [false, true] {
        let mut child = glint()
            .args(["run", "--size", SIZE, "--input"])
            .arg(&fifo)
            .stdin(Stdio::null())
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let writer = with_writer.then(|| OpenOptions::new().write(true).open(&fifo).unwrap());
        // Time for glint to open the FIFO and install its handlers.
        thread::sleep(Duration::from_millis(500));
        let kill = Command::new("kill")
            .args(["-TERM", &child.id().to_string()])
            .status()
            .unwrap();
        assert!(kill.success());
        let status = wait_or_kill(&mut child, HANG);
        drop(writer);
        let err = std::io::read_to_string(child.stderr.take().unwrap()).unwrap();
        let status = status.unwrap_or_else(|| panic!("writer {with_writer}: hung after SIGTERM"));
        assert!(status.success(), "writer {with_writer}: {status:?}: {err}");
        assert!(err.contains("stopped after 0 frames"), "{err}");
    }
}

/// Fault 3: a standard error that cannot be written (a full disk) never panics: the run goes
/// on and ends as it would, and a failing command still exits with its own code.
#[test]
fn a_full_standard_error_is_no_panic() {
    let dir = tempfile::tempdir().unwrap();
    let dump = dark_dump(dir.path(), 5);
    let full = || File::options().write(true).open("/dev/full").unwrap();
    let run = glint()
        .args(["run", "--size", SIZE, "--jsonl", "-", "--input"])
        .arg(&dump)
        .stderr(full())
        .output()
        .unwrap();
    assert_eq!(run.status.code(), Some(0));
    assert_eq!(run.stdout.iter().filter(|&&b| b == b'\n').count(), 5);
    let failing = glint()
        .args(["track", "--size", SIZE, "--input", "/nonexistent/dump.yuv"])
        .stderr(full())
        .output()
        .unwrap();
    assert_eq!(failing.status.code(), Some(1));
    let usage = glint()
        .args(["track", "--bogus"])
        .stderr(full())
        .output()
        .unwrap();
    assert_eq!(usage.status.code(), Some(2));
}

/// Issue 10: an empty dump or an empty standard input says there were no frames and fails.
#[test]
fn empty_input_says_there_were_no_frames() {
    let dir = tempfile::tempdir().unwrap();
    let empty = dir.path().join("empty.yuv");
    std::fs::write(&empty, b"").unwrap();
    let out = run_bounded(&["track", "--size", SIZE, "--input", empty.to_str().unwrap()]);
    assert_refused(&out, 1, "no frames");
    assert!(out.stdout.is_empty());
    let out = glint()
        .args(["track", "--size", SIZE, "--input", "-"])
        .stdin(Stdio::null())
        .output()
        .unwrap();
    assert_refused(&out, 1, "no frames");
}

/// Runs `glint` with `args`, returning its output and how long it took.
fn timed(args: &[&str]) -> (Output, Duration) {
    let start = Instant::now();
    let out = run_bounded(args);
    (out, start.elapsed())
}

/// Fault 5: `--calib` on devices, a FIFO and a huge file is refused at once with one line.
#[test]
fn calibration_files_must_be_small_regular_files() {
    let dir = tempfile::tempdir().unwrap();
    let dump = dark_dump(dir.path(), 1);
    let fifo = dir.path().join("calib.fifo");
    mkfifo(&fifo);
    let huge = dir.path().join("huge.toml");
    std::fs::write(&huge, vec![b'\n'; 10 * 1024 * 1024]).unwrap();
    let cases = [
        ("/dev/zero", "a character device, not a regular file"),
        ("/dev/urandom", "a character device, not a regular file"),
        (fifo.to_str().unwrap(), "a FIFO, not a regular file"),
        (huge.to_str().unwrap(), "too large (at most 1048576 bytes)"),
    ];
    for command in ["track", "run"] {
        for (calib, want) in cases {
            let (out, took) = timed(&[
                command,
                "--size",
                SIZE,
                "--input",
                dump.to_str().unwrap(),
                "--calib",
                calib,
            ]);
            assert_refused(&out, 1, want);
            assert!(stderr_of(&out).contains(calib), "names the file");
            eprintln!("{command} --calib {calib}: refused in {took:?}");
        }
    }
}

/// Fault 5: the settings file of `glint run` likewise, including 10 MB of blank lines.
#[test]
fn settings_files_must_be_small_regular_files() {
    let dir = tempfile::tempdir().unwrap();
    let fifo = dir.path().join("glint.fifo");
    mkfifo(&fifo);
    let blank = dir.path().join("blank.toml");
    std::fs::write(&blank, vec![b'\n'; 10 * 1024 * 1024]).unwrap();
    for (config, want) in [
        ("/dev/zero", "a character device, not a regular file"),
        (fifo.to_str().unwrap(), "a FIFO, not a regular file"),
        (blank.to_str().unwrap(), "too large (at most 1048576 bytes)"),
    ] {
        let (out, took) = timed(&["run", "--config", config]);
        assert_refused(&out, 2, want);
        eprintln!("run --config {config}: refused in {took:?}");
    }
}

/// Fault 5 and 8: a sidecar that is a FIFO is refused without waiting; one that says version 0
/// is not called newer.
#[test]
fn sidecars_that_are_fifos_or_version_0_are_refused_for_what_they_are() {
    let dir = tempfile::tempdir().unwrap();
    let dump = dark_dump(dir.path(), 2);
    let sidecar = dir.path().join("dark.yuv.json");
    mkfifo(&sidecar);
    let args = ["track", "--size", SIZE, "--input", dump.to_str().unwrap()];
    let (out, took) = timed(&args);
    assert_refused(&out, 1, "a FIFO, not a regular file (--no-sidecar");
    eprintln!("a FIFO as the sidecar: refused in {took:?}");
    std::fs::remove_file(&sidecar).unwrap();
    std::fs::write(
        &sidecar,
        r#"{"version":0,"format":"YUYV","width":64,"height":48,"stride":128,
            "driver_stride":128,"frames":[{"seq":0,"t_us":0},{"seq":1,"t_us":33333}]}"#,
    )
    .unwrap();
    let out = run_bounded(&args);
    assert_refused(&out, 1, "sidecar version 0 does not exist");
    assert!(!stderr_of(&out).contains("newer"), "{}", stderr_of(&out));
}

/// Fault 8: the system's text appears once, not once per layer of the error.
#[test]
fn errors_say_the_system_s_text_once() {
    let dir = tempfile::tempdir().unwrap();
    let dump = dark_dump(dir.path(), 1);
    let dump = dump.to_str().unwrap();
    let mut cases = vec![
        (
            vec![
                "track",
                "--size",
                SIZE,
                "--input",
                dump,
                "--serial",
                "/dev/null",
            ],
            "Not a typewriter",
        ),
        (
            vec![
                "track",
                "--size",
                SIZE,
                "--input",
                dump,
                "--serial",
                "/nonexistent/tty",
            ],
            "No such file or directory",
        ),
    ];
    if cfg!(feature = "v4l2") {
        cases.push((
            vec!["track", "--size", SIZE, "--device", "/nonexistent/video0"],
            "No such file or directory",
        ));
    }
    for (args, text) in cases {
        let out = run_bounded(&args);
        let err = stderr_of(&out);
        assert_eq!(out.status.code(), Some(1), "{err}");
        assert_eq!(err.matches(text).count(), 1, "{args:?}: {err}");
    }
}

/// Fault 6 and issue 10: numbers out of range are refused by the option's name, negative ones
/// included, and the message does not say a bound the value meets.
#[test]
fn numbers_out_of_range_name_their_option() {
    let dir = tempfile::tempdir().unwrap();
    let dump = dark_dump(dir.path(), 1);
    let dump = dump.to_str().unwrap();
    let cases: &[(&[&str], &str)] = &[
        (
            &["--fps", "0"],
            "'--fps <FPS>': a frame rate is 0.1 to 1000",
        ),
        (
            &["--fps", "-1"],
            "'--fps <FPS>': a frame rate is 0.1 to 1000",
        ),
        (&["--fps", "1e-300"], "'--fps <FPS>'"),
        (
            &["--erode", "100000"],
            "'--erode <N>': 100000 is not in 0..=32",
        ),
        (&["--erode", "4294967295"], "'--erode <N>'"),
        (&["--erode", "-1"], "'--erode <N>'"),
        (&["--background-frames", "64"], "'--background-frames <N>'"),
        (&["--background-frames", "-3"], "'--background-frames <N>'"),
        (&["--baud", "0"], "'--baud <BAUD>'"),
        (&["--summary-every", "-1"], "'--summary-every <SECONDS>'"),
        (&["--max-memory-mb", "0"], "'--max-memory-mb <MB>'"),
        (
            &["--row-time-us", "0"],
            "'--row-time-us <MICROSECONDS>': not a row time above 0 and up to 1000 µs",
        ),
        (&["--row-time-us", "-30"], "'--row-time-us <MICROSECONDS>'"),
        (&["--row-time-us", "1001"], "'--row-time-us <MICROSECONDS>'"),
        (&["--row-time-us", "NaN"], "'--row-time-us <MICROSECONDS>'"),
    ];
    for (extra, want) in cases {
        let mut args = vec!["track", "--size", SIZE, "--input", dump];
        args.extend_from_slice(extra);
        let (out, took) = timed(&args);
        assert_refused(&out, 2, want);
        assert!(
            !stderr_of(&out).contains("between 0 and"),
            "{}",
            stderr_of(&out)
        );
        assert!(took < HANG);
    }
}

/// `--help` shows the bounds it enforces.
#[test]
fn help_shows_the_bounds() {
    let out = glint().args(["track", "--help"]).output().unwrap();
    let help = String::from_utf8_lossy(&out.stdout)
        .split_whitespace()
        .collect::<Vec<_>>()
        .join(" ");
    for bound in [
        "0 to 32",
        "1 to 63",
        "0.1 to 1000",
        "50 to 4000000 baud",
        "up to 86400",
        "its rows), up to 1000",
        "sides 1 to 16384",
        "16 to 65536",
        "A regular file of at most 1 MB",
    ] {
        assert!(help.contains(bound), "{bound:?} in {help}");
    }
}

/// Fault 8: a huge value is quoted back cut short, and one too long for any option (on the
/// command line, or from the settings file) is refused before parsing, naming its option.
#[test]
fn huge_values_are_not_echoed_whole() {
    let long = "a".repeat(2_000);
    let out = run_bounded(&["track", "--input", "-", "--size", &long]);
    assert_refused(&out, 2, "'--size <WxH>'");
    assert!(stderr_of(&out).len() < 400, "{}", stderr_of(&out));
    assert!(stderr_of(&out).contains('…'));
    // The kernel takes at most 128 kB per argument.
    let huge = "b".repeat(100_000);
    let out = run_bounded(&["track", "--input", "-", "--size", &huge]);
    assert_refused(&out, 2, "the value of --size is 100000 bytes");
    assert!(stderr_of(&out).len() < 400);
    let dir = tempfile::tempdir().unwrap();
    let config = dir.path().join("glint.toml");
    let value = "c".repeat(1_000_000);
    for text in [
        format!("size = \"{value}\"\n"),
        format!("size = [\"{value}\"]\n"),
        format!("{value} = 1\n"),
    ] {
        std::fs::write(&config, text).unwrap();
        let out = run_bounded(&["run", "--config", config.to_str().unwrap()]);
        assert_eq!(out.status.code(), Some(2), "{}", stderr_of(&out));
        assert!(stderr_of(&out).len() < 400, "{}", stderr_of(&out));
    }
}

/// Issue 10: `glint` alone prints the usage, and exits 2.
#[test]
fn no_arguments_print_the_usage() {
    let out = glint().output().unwrap();
    assert_eq!(out.status.code(), Some(2));
    let err = stderr_of(&out);
    assert!(err.contains("Usage: glint"), "{err}");
    assert!(err.contains("track"), "{err}");
}

/// Issue 10: the Pi's settings file can be tried on a dump, without its serial port or its
/// calibration, from the command line.
#[test]
fn the_pi_settings_run_on_a_dump_without_serial_or_calibration() {
    let dir = tempfile::tempdir().unwrap();
    let dump = dark_dump(dir.path(), 3);
    let config = concat!(env!("CARGO_MANIFEST_DIR"), "/board/raspberry-pi/glint.toml");
    let base = [
        "run",
        "--config",
        config,
        "--size",
        SIZE,
        "--input",
        dump.to_str().unwrap(),
    ];
    let out = run_bounded(&base);
    assert_eq!(
        out.status.code(),
        Some(1),
        "without the switches: {}",
        stderr_of(&out)
    );
    let mut args = base.to_vec();
    args.extend(["--no-serial", "--no-calib", "--jsonl", "-"]);
    let out = run_bounded(&args);
    assert!(out.status.success(), "{}", stderr_of(&out));
    assert_eq!(String::from_utf8_lossy(&out.stdout).lines().count(), 3);
    // The switch also wins over a --serial given before it, and loses to one after it.
    let mut args = base.to_vec();
    args.extend(["--no-calib", "--no-serial", "--serial", "/nonexistent/tty"]);
    let out = run_bounded(&args);
    assert!(
        stderr_of(&out).contains("/nonexistent/tty"),
        "{}",
        stderr_of(&out)
    );
}

/// Fault 4: options that need more memory than `--max-memory-mb` are refused before anything
/// is allocated, with one line naming the option and the need; no abort, no backtrace.
#[test]
fn options_that_need_too_much_memory_are_refused_up_front() {
    let cases: &[(&[&str], &str)] = &[
        (
            &[
                "track",
                "--input",
                "-",
                "--size",
                "16384x16384",
                "--detector",
                "bgdiff",
            ],
            "the options need 4549 MB, more than --max-memory-mb 256: the background model \
             (--background-frames 9 × --size 16384x16384) takes 2560 MB",
        ),
        (
            &[
                "track",
                "--input",
                "-",
                "--size",
                "16384x16384",
                "--detector",
                "bgdiff",
                "--background-frames",
                "63",
            ],
            "(--background-frames 63 × --size 16384x16384) takes 16384 MB",
        ),
        // The default model learns the floor; the line says which option plans none.
        (
            &["run", "--input", "-", "--size", "16384x16384"],
            "the options need 1989 MB, more than --max-memory-mb 256: the streak fit's learned \
             floor (--size 16384x16384 with --streak-model auto, the default; --streak-model \
             ramps has none) takes 800 MB",
        ),
        (
            &[
                "run",
                "--input",
                "-",
                "--size",
                "16384x16384",
                "--streak-model",
                "ramps",
            ],
            "the options need 1189 MB, more than --max-memory-mb 256: the masks and scratch \
             (--size 16384x16384) takes 673 MB",
        ),
        (
            &[
                "calibrate",
                "--input",
                "-",
                "--size",
                "16384x16384",
                "--marker",
                "7:20",
                "--out",
                "/nonexistent/calib.toml",
            ],
            "the marker detector (--size 16384x16384) takes 513 MB",
        ),
        (
            &[
                "track",
                "--input",
                "-",
                "--size",
                "4096x4096",
                "--max-memory-mb",
                "16",
            ],
            "more than --max-memory-mb 16",
        ),
    ];
    let mut cases = cases.to_vec();
    if cfg!(feature = "v4l2") {
        // Refused before the camera is even looked for.
        cases.push((
            &[
                "record",
                "--device",
                "/nonexistent/video0",
                "--size",
                "16384x16384",
                "--frames",
                "10",
                "--out",
                "/nonexistent/out.yuv",
            ],
            "the camera's buffers (--buffers 4 × --size 16384x16384) takes 2048 MB",
        ));
    }
    for (args, want) in cases {
        let (out, took) = timed(args);
        assert_refused(&out, 1, want);
        eprintln!("{args:?}: refused in {took:?}");
    }
    // Within a raised limit it is what the system gives that counts: under a 2 GB address
    // space limit, a message rather than an abort.
    let out = Command::new("sh")
        .args(["-c", "ulimit -v 2000000 && exec \"$0\" \"$@\""])
        .arg(env!("CARGO_BIN_EXE_glint"))
        .args([
            "track",
            "--input",
            "-",
            "--size",
            "16384x16384",
            "--detector",
            "bgdiff",
        ])
        .args(["--max-memory-mb", "65536"])
        .stdin(Stdio::null())
        .output()
        .unwrap();
    assert_refused(
        &out,
        1,
        "the options need 4549 MB, which this system will not give",
    );
}

/// Fault 1 at start-up: a background dump that is a quiet FIFO does not hold off SIGTERM.
#[test]
fn sigterm_stops_learning_from_a_quiet_fifo() {
    let dir = tempfile::tempdir().unwrap();
    let dump = dark_dump(dir.path(), 1);
    let fifo = dir.path().join("background.fifo");
    mkfifo(&fifo);
    let mut child = glint()
        .args(["track", "--size", SIZE, "--detector", "bgdiff", "--input"])
        .arg(&dump)
        .arg("--background")
        .arg(&fifo)
        .stdout(Stdio::null())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    thread::sleep(Duration::from_millis(500));
    let kill = Command::new("kill")
        .args(["-TERM", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(kill.success());
    let status = wait_or_kill(&mut child, HANG).expect("stopped after SIGTERM");
    let err = std::io::read_to_string(child.stderr.take().unwrap()).unwrap();
    assert_eq!(status.code(), Some(1), "{err}");
    assert!(err.contains("stopped while waiting for input"), "{err}");
    assert_eq!(err.lines().count(), 1, "{err}");
}

/// Fault 8, what the fix must keep: `--fps 1e-300` (which pinned `t` at 18446744073709.55 s)
/// is now refused, and the slowest rate still accepted gives frame times that move on.
#[test]
fn the_slowest_frame_rate_gives_true_times() {
    let dir = tempfile::tempdir().unwrap();
    let dump = dark_dump(dir.path(), 3);
    let out = run_bounded(&[
        "track",
        "--size",
        SIZE,
        "--fps",
        "0.1",
        "--input",
        dump.to_str().unwrap(),
    ]);
    assert!(out.status.success(), "{}", stderr_of(&out));
    let times: Vec<f64> = common::parse_jsonl(&out.stdout)
        .iter()
        .map(|r| r["t"].as_f64().unwrap())
        .collect();
    assert_eq!(times, [0.0, 10.0, 20.0]);
}
