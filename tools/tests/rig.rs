//! The robot-in-the-loop rig, end to end with real parts: the renderer's frames, `glint run`
//! (built optimised, profile `rig`: a debug glint cannot keep up with 30 fps on a loaded
//! machine), a real pty pair, the example firmware in qemu-system-arm (mps2-an386), and the
//! simulated robot. A few seconds each with and without latency compensation; the bounds are
//! on accuracy and on the firmware's age against the truth, never on time.

use std::path::{Path, PathBuf};
use std::process::Command;

use glint_tools::rig::{run_loop, LoopConfig, LoopReport};

/// Seconds of frames per run: a lap of the figure-eight takes 7.4 s; errors count from 1 s
/// after the start.
const SECONDS: f64 = 7.0;

/// Frames the creeping robot may take to be acquired at the start: 6 frames at 100 mm/s is
/// 2 cm, several pixels at the rig's camera.
const ACQUIRE_FRAMES: usize = 6;

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

fn run(compensate: bool, glint: &Path, firmware: &Path) -> LoopReport {
    let work = tempfile::tempdir().unwrap();
    let config = LoopConfig {
        seconds: SECONDS,
        compensate,
        glint: glint.to_path_buf(),
        firmware: firmware.to_path_buf(),
        qemu: "qemu-system-arm".into(),
        baud: 115_200,
        seed: 7,
        work_dir: work.path().to_path_buf(),
    };
    let report = run_loop(&config).unwrap_or_else(|e| {
        let log = std::fs::read_to_string(work.path().join("glint.log")).unwrap_or_default();
        panic!("the rig failed: {e:#}\nglint's log:\n{log}")
    });
    eprintln!("compensate={compensate}: {}", report.summary_line());
    report
}

#[test]
fn the_firmware_in_qemu_steers_the_robot_along_the_figure_eight_from_glints_positions() {
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
    let glint = root.join("target/rig/glint");
    let firmware = firmware_dir.join("target/thumbv7em-none-eabihf/release/glint-firmware-mps2");

    let compensated = run(true, &glint, &firmware);
    let raw = run(false, &glint, &firmware);

    // The firmware's lines arrive intact, however busy the machine.
    assert_eq!((compensated.garbled, raw.garbled), (0, 0));
    // A machine too busy to keep 30 fps and the firmware's replies in real time measures its
    // own load: such a run is reported, not judged.
    for r in [&compensated, &raw] {
        if !r.kept_real_time() {
            eprintln!(
                "the loop did not keep real time (frames handed p95 {:.1} ms after their \
                 exposure, updates back p95 {:.1} ms): not judged",
                r.delivery_ms.p95, r.age_on_arrival_ms.p95
            );
            return;
        }
    }
    // Every frame's update came back, the light in view: lost only in the first frames, while
    // the robot creeps until it has moved enough to be told from glare (a light standing still
    // since it appeared is never taken), and at most 3 more.
    for r in [&compensated, &raw] {
        let frames = r.frames;
        assert!(r.updates + 3 >= frames, "{} of {frames} updates", r.updates);
        assert!(r.lost <= ACQUIRE_FRAMES + 3, "{} frames lost", r.lost);
    }
    // The robot follows the path: within 10 mm (p95) with compensation. Without it, the
    // firmware steers from positions as they come, as one that ignores the age frame does:
    // it still follows the path.
    assert!(
        compensated.path_error_mm.p95 <= 10.0,
        "{}",
        compensated.summary_line()
    );
    assert!(raw.path_error_mm.p95 <= 20.0, "{}", raw.summary_line());

    // The firmware's age (glint's age on arrival plus its own receive latency) against the
    // truth since glint took the frame, in the median: a process scheduled late on a busy
    // machine moves single updates by many milliseconds either way (late in the rig's
    // stamping: the firmware's age looks larger; late in qemu or the wire: smaller), but a
    // wrong age (a line time counted at the wrong baud, a clock at the wrong rate) moves them
    // all.
    let mut signed = compensated.age_error_ms.clone();
    assert!(signed.len() + 3 >= compensated.frames);
    signed.sort_by(f64::total_cmp);
    let median = glint_tools::stats::percentile(&signed, 50.0).unwrap();
    assert!(
        median.abs() <= 3.0,
        "the firmware's age is off the truth by {median:.2} ms (median)"
    );
}
