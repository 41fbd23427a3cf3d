//! What the tests against independent implementations share: the Python venv that holds them
//! (pymavlink, eclipse-zenoh, ...), and a calibration that gives reports floor positions.

use std::io::{BufRead, BufReader, Write};
use std::net::TcpListener;
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, Command, Stdio};
use std::sync::mpsc::{self, Receiver};
use std::thread;
use std::time::Duration;

use glint::detect::aruco::Dictionary;
use glint::geometry::Point;
use glint_tools::markers::{reference_camera, MarkerScene, PlacedMarker};
use serde_json::Value;

use super::{glint, parse_jsonl};

/// The venv's python, or a failure that says how to make it.
pub fn python() -> PathBuf {
    let venv = std::env::var_os("GLINT_PY_VENV")
        .map(PathBuf::from)
        .unwrap_or_else(|| {
            PathBuf::from(std::env::var_os("HOME").expect("HOME")).join(".cache/glint-py")
        });
    let python = venv.join("bin/python");
    assert!(
        python.exists(),
        "no Python venv at {}: run tools/setup-python.sh (tools/test.sh does)",
        venv.display()
    );
    python
}

/// Renders scenes into `dir` with the independent renderer (`tests/independent/
/// render_streaks.py`, its `args`) and returns their parameters (its `scenes.json`).
pub fn render_independent<S: AsRef<std::ffi::OsStr>>(dir: &Path, args: &[S]) -> Vec<Value> {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/independent/render_streaks.py");
    let out = Command::new(python())
        .arg(script)
        .args(args)
        .arg("--out")
        .arg(dir)
        .output()
        .expect("run the renderer");
    assert!(
        out.status.success(),
        "renderer failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let scenes = std::fs::read(dir.join("scenes.json")).expect("scenes.json");
    serde_json::from_slice::<Vec<Value>>(&scenes).expect("scenes.json parses")
}

/// Decodes MAVLink `bytes` with pymavlink (tests/mavlink/decode.py): the messages, then the
/// summary.
pub fn decode_mavlink(bytes: &[u8]) -> (Vec<Value>, Value) {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/mavlink/decode.py");
    let mut child = Command::new(python())
        .arg(script)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("start python");
    child.stdin.take().unwrap().write_all(bytes).unwrap();
    let out = child.wait_with_output().unwrap();
    assert!(
        out.status.success(),
        "decode.py: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let mut lines = parse_jsonl(&out.stdout);
    let summary = lines.pop().expect("summary line")["summary"].clone();
    (lines, summary)
}

/// A JSON number, or a failure naming the value.
pub fn number(v: &Value) -> f64 {
    v.as_f64().unwrap_or_else(|| panic!("not a number: {v}"))
}

/// Floor cm → (north, east) m under the README's MAVLink convention, for a yaw offset of
/// `yaw_offset_deg` (`--mavlink-yaw-offset-deg`).
pub fn north_east_m(x_cm: f64, y_cm: f64, yaw_offset_deg: f64) -> (f64, f64) {
    let (s, c) = yaw_offset_deg.to_radians().sin_cos();
    ((x_cm * c - y_cm * s) / 100.0, (x_cm * s + y_cm * c) / 100.0)
}

/// A free TCP port on the loopback interface.
pub fn free_port() -> u16 {
    TcpListener::bind("127.0.0.1:0")
        .and_then(|l| l.local_addr())
        .expect("a free port")
        .port()
}

/// A Python subscriber (a script under tests/ run by the venv's python) that prints one JSON
/// value a line, the first `{"ready": true}` once its subscriptions are declared, and exits when
/// its standard input closes.
pub struct PySubscriber {
    child: Child,
    stdin: Option<ChildStdin>,
    /// What it printed after `ready`, in order.
    pub samples: Receiver<Value>,
}

impl PySubscriber {
    /// Starts `script` (relative to the package) with `args`, and waits up to `patience` for
    /// it to be ready.
    pub fn start(script: &str, args: &[&str], patience: Duration) -> PySubscriber {
        let mut child = Command::new(python())
            .arg(Path::new(env!("CARGO_MANIFEST_DIR")).join(script))
            .args(args)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .expect("start python");
        let stdin = child.stdin.take();
        let stdout = child.stdout.take().expect("the subscriber's stdout");
        let (tx, samples) = mpsc::channel();
        thread::spawn(move || {
            for line in BufReader::new(stdout).lines().map_while(Result::ok) {
                let value: Value = serde_json::from_str(&line)
                    .unwrap_or_else(|e| panic!("subscriber printed {line:?}: {e}"));
                if tx.send(value).is_err() {
                    break;
                }
            }
        });
        let ready = samples.recv_timeout(patience).expect("subscriber ready");
        assert_eq!(ready["ready"], true, "{ready}");
        PySubscriber {
            child,
            stdin,
            samples,
        }
    }

    /// Closes its input, so it exits, and returns every sample it printed since.
    pub fn stop(mut self) -> Vec<Value> {
        drop(self.stdin.take());
        let status = self.child.wait().expect("wait for the subscriber");
        assert!(status.success(), "subscriber: {status:?}");
        self.samples.try_iter().collect()
    }
}

fn marker(id: u16, x_cm: f64, y_cm: f64) -> PlacedMarker {
    PlacedMarker {
        dictionary: Dictionary::Aruco6x6_250,
        id,
        size_cm: 20.0,
        origin_cm: Point::new(x_cm, y_cm),
        rotation_deg: 0.0,
    }
}

/// `glint calibrate` (ideal lens) on rendered frames of two 20 cm markers, ids 23 at the
/// origin and 101 at (55, 45) cm, seen by the reference camera; the calibration file's path.
pub fn calibrate_two_markers(dir: &Path) -> PathBuf {
    let scene = MarkerScene::new(
        reference_camera(),
        vec![marker(23, 0.0, 0.0), marker(101, 55.0, 45.0)],
    );
    let dump = dir.join("markers.yuv");
    std::fs::write(&dump, scene.render_yuyv()).unwrap();
    let out = dir.join("calib.toml");
    let run = glint()
        .args(["calibrate", "--input"])
        .arg(&dump)
        .args(["--size", "640x480", "--out"])
        .arg(&out)
        .args(["--marker", "23:20", "--marker", "101:20@55,45"])
        .args(["--lens", "ideal"])
        .output()
        .unwrap();
    assert!(
        run.status.success(),
        "{}",
        String::from_utf8_lossy(&run.stderr)
    );
    out
}
