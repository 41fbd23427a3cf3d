//! The robot-in-the-loop rig, end to end with real parts: the renderer's frames delivered as a
//! USB webcam delivers them (a delay after the exposure, stamped with the exposure's end),
//! `glint run --stamped` (built optimised, profile `rig`: a debug glint cannot keep up with
//! 30 fps on a loaded machine), a real pty pair, the example firmware in qemu-system-arm
//! (mps2-an386), and the simulated robot. A few seconds per case, over a sweep of the camera's
//! delay, with and without latency compensation; then `glint latency` in the same loop. The
//! bounds are on accuracy and on the firmware's age against the truth, never on time.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::{Mutex, OnceLock, PoisonError};

use glint_tools::rig::{run_loop, LoopConfig, LoopReport};

/// Seconds of frames per run: a lap of the figure-eight takes 7.4 s; errors count from 1 s
/// after the start.
const SECONDS: f64 = 6.0;

/// The camera delays swept (ms): none (frames as soon as rendered), and the short and long
/// ends of a USB webcam's.
const CAMERA_DELAYS_MS: [u64; 3] = [0, 40, 80];

/// Frames the creeping robot may take to be acquired at the start: 6 frames at 100 mm/s is
/// 2 cm, several pixels at the rig's camera; a camera's delay adds its frames (the firmware
/// only hears of the robot that much later).
const ACQUIRE_FRAMES: usize = 6;

/// The camera's frame period, ms (30 fps).
const FRAME_PERIOD_MS: f64 = 1e3 / 30.0;

/// Requests of `glint latency` on the rig.
const LATENCY_TRIALS: u32 = 20;

/// One rig at a time: two would share the machine's two cores and miss real time.
static RIG: Mutex<()> = Mutex::new(());

fn repo_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .expect("tools/ has a parent")
        .to_path_buf()
}

fn cargo_build(dir: &Path, args: &[&str]) {
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let status = Command::new(cargo)
        .current_dir(dir)
        .args(["build", "--quiet"])
        .args(args)
        .status()
        .expect("run cargo");
    assert!(
        status.success(),
        "cargo build {args:?} in {}",
        dir.display()
    );
}

/// glint (optimised) and the firmware, built once.
fn binaries() -> &'static (PathBuf, PathBuf) {
    static BUILT: OnceLock<(PathBuf, PathBuf)> = OnceLock::new();
    BUILT.get_or_init(|| {
        let root = repo_root();
        // The rig needs neither capture nor publishing; the `rig` profile (Cargo.toml) is the
        // release build without its slow whole-program optimisation.
        cargo_build(
            &root,
            &[
                "--profile",
                "rig",
                "--no-default-features",
                "-p",
                "glint",
                "--bin",
                "glint",
            ],
        );
        let firmware_dir = root.join("board/firmware");
        cargo_build(
            &firmware_dir,
            &[
                "--release",
                "--target",
                "thumbv7em-none-eabihf",
                "--features",
                "mps2-an386",
                "--bin",
                "glint-firmware-mps2",
            ],
        );
        (
            root.join("target/rig/glint"),
            firmware_dir.join("target/thumbv7em-none-eabihf/release/glint-firmware-mps2"),
        )
    })
}

fn run(compensate: bool, camera_delay_ms: u64, latency_trials: Option<u32>) -> LoopReport {
    let (glint, firmware) = binaries();
    let work = tempfile::tempdir().unwrap();
    let config = LoopConfig {
        seconds: if latency_trials.is_some() {
            30.0
        } else {
            SECONDS
        },
        compensate,
        glint: glint.clone(),
        firmware: firmware.clone(),
        qemu: "qemu-system-arm".into(),
        baud: 115_200,
        camera_delay_us: camera_delay_ms * 1_000,
        seed: 7,
        work_dir: work.path().to_path_buf(),
        latency_trials,
    };
    let report = run_loop(&config).unwrap_or_else(|e| {
        let log = std::fs::read_to_string(work.path().join("glint.log")).unwrap_or_default();
        panic!("the rig failed: {e:#}\nglint's log:\n{log}")
    });
    eprintln!(
        "camera delay {camera_delay_ms} ms, compensate={compensate}: {}",
        report.summary_line()
    );
    report
}

/// Whether `r` kept real time; if not, says so (such a run measures the machine's load).
fn judged(r: &LoopReport) -> bool {
    if !r.kept_real_time() {
        eprintln!(
            "the loop did not keep real time (frames handed p95 {:.1} ms late, updates back p95 \
             {:.1} ms after their exposure): not judged",
            r.late_ms.p95, r.age_on_arrival_ms.p95
        );
    }
    r.kept_real_time()
}

fn sorted(v: &[f64]) -> Vec<f64> {
    let mut v = v.to_vec();
    v.sort_by(f64::total_cmp);
    v
}

fn percentile(v: &[f64], p: f64) -> f64 {
    glint_tools::stats::percentile(&sorted(v), p).expect("values")
}

#[test]
fn the_firmware_in_qemu_steers_the_robot_along_the_figure_eight_from_glints_positions() {
    let _one = RIG.lock().unwrap_or_else(PoisonError::into_inner);
    // The error no compensation can take away: the pursuit's own (cutting bends whose
    // curvature changes), measured with nothing to compensate, at the first delay (0 ms).
    let mut floor_mm = None;
    for delay_ms in CAMERA_DELAYS_MS {
        let compensated = run(true, delay_ms, None);
        let raw = run(false, delay_ms, None);

        // The firmware's lines arrive intact, however busy the machine.
        assert_eq!((compensated.garbled, raw.garbled), (0, 0));
        if !judged(&compensated) || !judged(&raw) {
            continue;
        }
        // Every frame's update came back, the light in view: lost only in the first frames,
        // while the robot creeps until it has moved enough to be told from glare (a light
        // standing still since it appeared is never taken), and at most 3 more.
        let delay_frames = (delay_ms as f64 * 30.0 / 1e3).ceil() as usize;
        for r in [&compensated, &raw] {
            let frames = r.frames;
            assert!(r.updates + 3 >= frames, "{} of {frames} updates", r.updates);
            assert!(
                r.lost <= ACQUIRE_FRAMES + delay_frames + 3,
                "{} frames lost",
                r.lost
            );
        }
        // With compensation the robot follows the path within 10 mm (p95) at every delay.
        assert!(
            compensated.path_error_mm.p95 <= 10.0,
            "{delay_ms} ms: {}",
            compensated.summary_line()
        );
        let (with, without) = (compensated.path_error_mm.p95, raw.path_error_mm.p95);
        match (delay_ms, floor_mm) {
            (0, _) => {
                // Nothing to compensate: the error is the pursuit's own, with or without.
                assert!(without <= 10.0, "{}", raw.summary_line());
                floor_mm = Some(with.max(without));
            }
            // Compensation halves the error (p95) wherever the delay's share of it (what it adds
            // to the pursuit's own) is at least twice the pursuit's own. Below that, halving
            // would need the compensated loop to come within a hair of the pursuit's own error,
            // which its prediction's residual does not allow; compensation must still help.
            (_, Some(floor)) if without - floor >= 2.0 * floor => assert!(
                with * 2.0 <= without,
                "{delay_ms} ms: compensated {} against raw {}",
                compensated.summary_line(),
                raw.summary_line()
            ),
            (_, Some(floor)) => {
                eprintln!(
                    "{delay_ms} ms: the delay adds {:.1} mm to the pursuit's own {floor:.1} mm, \
                     less than twice it: halving is out of reach; {without:.1} mm without \
                     compensation, {with:.1} mm with it",
                    without - floor
                );
                assert!(with < without, "{delay_ms} ms: compensation did not help");
            }
            // The pursuit's own error was not measured (that run was not judged).
            (_, None) => assert!(with < without, "{delay_ms} ms: compensation did not help"),
        }

        // The firmware's age (glint's age on arrival plus its own receive latency) against
        // the truth from the exposure's end to the moment the firmware reckoned it: within
        // 1 ms in the median. A wrong age (a line time at the wrong baud, a clock at the wrong
        // rate, the camera's delay not counted) moves them all. Every delay before the
        // firmware's link reads the bytes is one it cannot see and makes single ages smaller:
        // on this rig that is the wire's thread and qemu handing the bytes on late on a busy
        // machine (a real UART shifts them in at its line rate). The firmware stamps its read,
        // so that lateness is measured for every update and taken out; the raw figures are
        // printed beside it.
        for r in [&compensated, &raw] {
            eprintln!(
                "{delay_ms} ms: age error p50 {:.2} ms raw, {:.2} ms from the firmware's read \
                 on; the read late by p50 {:.2} ms p95 {:.2} ms",
                percentile(&r.age_error_ms, 50.0),
                percentile(&r.age_error_from_receipt_ms, 50.0),
                percentile(&r.board_read_late_ms, 50.0),
                percentile(&r.board_read_late_ms, 95.0),
            );
            let errors = &r.age_error_from_receipt_ms;
            assert!(errors.len() + 3 >= r.frames);
            let median = percentile(errors, 50.0);
            assert!(
                median.abs() <= 1.0,
                "the firmware's age is off the truth by {median:.2} ms (median)"
            );
            // Single ages: at most one in twenty off by a frame period or more, the mark of an
            // age reckoned for another frame's position (a busy machine's scheduling moves
            // single ages by milliseconds, not by a frame).
            let abs: Vec<f64> = errors.iter().map(|e| e.abs()).collect();
            let p95 = percentile(&abs, 95.0);
            assert!(
                p95 < FRAME_PERIOD_MS,
                "the firmware's age is off the truth by {p95:.2} ms (p95 of |error|)"
            );
        }
    }
}

/// The figure after `label` on the line of `stdout` that contains it, in ms.
fn figure_ms(stdout: &str, line_has: &str, label: &str) -> f64 {
    let line = stdout
        .lines()
        .find(|l| l.contains(line_has))
        .unwrap_or_else(|| panic!("no line with {line_has:?} in:\n{stdout}"));
    line.split(label)
        .nth(1)
        .and_then(|rest| rest.trim().split(" ms").next())
        .and_then(|v| v.trim().parse().ok())
        .unwrap_or_else(|| panic!("no figure after {label:?} in {line}"))
}

#[test]
fn glint_latency_on_the_rig_reports_the_rigs_latency() {
    let _one = RIG.lock().unwrap_or_else(PoisonError::into_inner);
    let delay_ms = 70;
    let r = run(true, delay_ms, Some(LATENCY_TRIALS));
    let out = &r.glint_stdout;
    eprintln!("{out}");
    assert!(
        out.contains(&format!(
            "{LATENCY_TRIALS} of {LATENCY_TRIALS} requests answered"
        )),
        "{out}"
    );
    // The camera's delay, from the frames' capture times to their delivery.
    let delivered = figure_ms(out, "capture to delivered", "p50");
    assert!(
        (delivered - delay_ms as f64).abs() <= 2.0,
        "glint latency saw the camera deliver after {delivered} ms, the rig's delay is \
         {delay_ms} ms"
    );
    // From the request written to the simulator's LED going dark (the line time at the baud,
    // the firmware's reaction within its 250 µs tick, the way back to the simulator), against
    // what glint found from the frames' phases, without the wait for the next exposure.
    let found = figure_ms(out, "from the frames' phases", "phases:");
    let truth = &r.led_dark_after_request_ms;
    assert_eq!(truth.len(), LATENCY_TRIALS as usize);
    let (lo, median, hi) = (
        percentile(truth, 0.0),
        percentile(truth, 50.0),
        percentile(truth, 100.0),
    );
    eprintln!("truth: least {lo:.2} p50 {median:.2} most {hi:.2} ms; glint: {found:.2} ms");
    // A switch whose line came after its frame was drawn (qemu more than the rig's settling
    // time late) leaves frames that show the LED as it had been: they and the truth disagree,
    // and the comparison would measure the machine's load.
    if r.led_switches_late > 0 {
        eprintln!(
            "{} LED switches arrived after their frames were drawn: the phases are not judged",
            r.led_switches_late
        );
        return;
    }
    // The estimate is the middle of the moments the brackets share. With a reaction that
    // jitters (qemu's scheduling on a busy machine), the two brackets with the most extreme
    // phases set those moments, each from its own trial's reaction, so the estimate may lie
    // anywhere in the reactions' spread, and taking the frames' moments at their exposures'
    // middles adds up to half an exposure (2 ms) either way. So it is judged against the
    // whole spread widened by that, for a steady machine as for a busy one. Narrower judges
    // failed two CI runs: the median while the spread was under 4 ms (estimate 2.02 ms from
    // it, 0.7 ms past the p95), and the p5 to p95 (1.45 to 1.71 ms), with all 20 brackets
    // sharing 4.6 to 5.6 ms: one trial's LED was still lit 4.6 ms after its request, a trial
    // slower than the p95.
    assert!(
        found >= lo - 2.0 && found <= hi + 2.0,
        "glint latency found {found} ms, the rig's truth spans {lo:.2} to {hi:.2} ms"
    );
}
