//! `glint-scene` with a camera view, run as a user runs it: marker presets, lens, height,
//! knock and moved-marker flags, the floor truth and the calibrate command it prints.

use std::process::Command;

fn scene(args: &[&str]) -> (bool, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_glint-scene"))
        .args(args)
        .output()
        .expect("glint-scene runs");
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn a_marker_map_scene_prints_its_calibrate_command_and_writes_the_floor_truth() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().to_str().unwrap();
    let (ok, stdout, stderr) = scene(&[
        "--scene",
        "marker-map",
        "--out-dir",
        d,
        "--frames",
        "3",
        "--distortion",
        "-0.2,0.05,0,0.001,0",
        "--led-height-cm",
        "10",
        "--knock",
        "1:0.8",
        "--move-marker",
        "2:4:2.5,-1",
    ]);
    assert!(ok, "{stderr}");
    assert!(
        stdout.contains("calibrate with: glint calibrate --input")
            && stdout.contains("--marker 1:18@93,54")
            && stdout.contains("--marker 6:18@-64,-62"),
        "{stdout}"
    );
    let floor = std::fs::read_to_string(dir.path().join("marker-map.floor.csv")).unwrap();
    let lines: Vec<&str> = floor.lines().collect();
    assert_eq!(lines[0], "frame,floor_x_cm,floor_y_cm");
    assert_eq!(lines.len(), 4);
    assert!(lines[1].split(',').nth(1).unwrap().parse::<f64>().is_ok());
    let dump = std::fs::metadata(dir.path().join("marker-map.yuv")).unwrap();
    assert_eq!(dump.len(), 3 * 640 * 480 * 2);
}

#[test]
fn view_flags_are_checked() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path().to_str().unwrap();
    // A scene without a camera view has no lens to bend.
    let (ok, _, stderr) = scene(&["--scene", "circles", "--out-dir", d, "--led-height-cm", "5"]);
    assert!(
        !ok && stderr.contains("need a preset with a camera view"),
        "{stderr}"
    );
    let (ok, _, stderr) = scene(&[
        "--scene",
        "lens-wide",
        "--out-dir",
        d,
        "--distortion",
        "1,2",
    ]);
    assert!(!ok && stderr.contains("is not five numbers"), "{stderr}");
    // A lens that folds over inside the picture is refused by the scene.
    let (ok, _, stderr) = scene(&[
        "--scene",
        "lens-wide",
        "--out-dir",
        d,
        "--frames",
        "1",
        "--distortion",
        "-0.9,0,0,0,0",
    ]);
    assert!(!ok && stderr.contains("the lens folds over"), "{stderr}");
    let (ok, _, stderr) = scene(&["--scene", "led-mast", "--out-dir", d, "--knock", "x"]);
    assert!(!ok && stderr.contains("FRAME:TILT_DEG"), "{stderr}");
    let (ok, _, stderr) = scene(&["--scene", "knocked", "--out-dir", d, "--move-marker", "5:2"]);
    assert!(!ok && stderr.contains("FRAME:ID:DX_CM,DY_CM"), "{stderr}");
    let (ok, _, stderr) = scene(&[
        "--scene",
        "knocked",
        "--out-dir",
        d,
        "--frames",
        "1",
        "--move-marker",
        "0:42:1,0",
    ]);
    assert!(!ok && stderr.contains("no marker 42"), "{stderr}");
}
