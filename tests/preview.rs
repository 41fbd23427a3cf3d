//! `glint run --preview`: the page, the state and the frame over plain HTTP on loopback while a
//! live run tracks an endless feed, and the page as headless Chromium renders it.

mod common;

use std::io::BufReader;
use std::net::{SocketAddr, TcpStream};
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::thread;
use std::time::{Duration, Instant};

use common::live::{exchange, feed_endlessly, get, lines_of};
use common::{render, Rendered};
use serde_json::Value;

/// Longest wait for the preview to come up and show a found LED.
const PATIENCE: Duration = Duration::from_secs(60);
/// BMP file + info header bytes.
const BMP_HEADER_BYTES: usize = 54;
/// Points of track the page is opened with: at the slow line's 2 px a frame, a track some
/// 100 px long.
const TRACK_SHOWN_POINTS: usize = 50;
/// The screenshot's rows above the colour key under a 640×480 frame.
const LEGEND_TOP_PX: usize = 505;

/// A live `glint run` on an endless stdin feed of a scene, with the preview on a free port.
struct Live {
    child: Child,
    addr: SocketAddr,
    feeder: Option<thread::JoinHandle<()>>,
}

impl Live {
    fn start(r: &Rendered) -> Live {
        Live::feeding(r, std::fs::read(&r.dump).unwrap())
    }

    /// A live run fed `frames` (whole frames of `r`'s scene) over and over.
    fn feeding(r: &Rendered, frames: Vec<u8>) -> Live {
        let size = format!("{}x{}", r.scene.width_px(), r.scene.height_px());
        let mut child = Command::new(env!("CARGO_BIN_EXE_glint"))
            .args(["run", "--input", "-", "--size", &size, "--fps", "30"])
            .args(["--preview", "127.0.0.1:0"])
            .stdin(Stdio::piped())
            .stdout(Stdio::null())
            .stderr(Stdio::piped())
            .spawn()
            .unwrap();
        let frame_bytes = r.scene.frame_len_bytes();
        let feeder = feed_endlessly(child.stdin.take().unwrap(), frames, frame_bytes);
        let (lines, _reader) = lines_of(child.stderr.take().unwrap());
        let addr = loop {
            let line = lines.recv_timeout(PATIENCE).expect("the preview's address");
            if let Some(rest) = line.split("preview on http://").nth(1) {
                break rest.trim_end_matches('/').parse().unwrap();
            }
        };
        Live {
            child,
            addr,
            feeder: Some(feeder),
        }
    }
}

impl Drop for Live {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
        if let Some(feeder) = self.feeder.take() {
            let _ = feeder.join();
        }
    }
}

fn state(addr: SocketAddr) -> Value {
    let (status, body) = get(addr, "/state.json");
    assert_eq!(status, "HTTP/1.1 200 OK");
    serde_json::from_slice(&body).unwrap()
}

/// RGB of pixel (x, y), top-down, of a bottom-up 24-bit BMP.
fn pixel(bmp: &[u8], width: usize, height: usize, x: usize, y: usize) -> [u8; 3] {
    let row_bytes = (width * 3).div_ceil(4) * 4;
    let at = BMP_HEADER_BYTES + (height - 1 - y) * row_bytes + 3 * x;
    [bmp[at + 2], bmp[at + 1], bmp[at]]
}

#[test]
fn the_page_state_and_frame_are_served_while_tracking() {
    let r = render("slow-line");
    let (width, height) = (r.scene.width_px() as usize, r.scene.height_px() as usize);
    let live = Live::start(&r);
    let (status, page) = get(live.addr, "/");
    assert_eq!(status, "HTTP/1.1 200 OK");
    let page = String::from_utf8(page).unwrap();
    assert!(page.contains("/state.json") && page.contains("/frame.bmp"));
    // The page asked: copies start. Wait for a snapshot in which the LED was found, then take
    // a frame between two states of the same frame, so the three belong together.
    let start = Instant::now();
    let (s, bmp) = loop {
        assert!(start.elapsed() < PATIENCE, "no snapshot with the LED found");
        let before = state(live.addr);
        let (status, bmp) = get(live.addr, "/frame.bmp?n=1");
        assert_eq!(status, "HTTP/1.1 200 OK");
        let after = state(live.addr);
        if before["found"] == true && before["index"] == after["index"] {
            break (after, bmp);
        }
        thread::sleep(Duration::from_millis(100));
    };
    assert_eq!(s["width"], width);
    assert_eq!(s["height"], height);
    assert!(!s["track_px"].as_array().unwrap().is_empty());
    // Frames keep coming at 200 fps at most: a measured rate appears on a later snapshot.
    let rate_start = Instant::now();
    while state(live.addr)["fps"].is_null() {
        assert!(rate_start.elapsed() < PATIENCE, "no frame rate");
        thread::sleep(Duration::from_millis(100));
    }
    assert!(state(live.addr)["fps"].as_f64().unwrap() > 1.0);
    // The frame: the BMP's size, the LED where the scene put it, tinted, and a grey floor.
    assert_eq!(&bmp[..2], b"BM");
    let row_bytes = (width * 3).div_ceil(4) * 4;
    assert_eq!(bmp.len(), BMP_HEADER_BYTES + row_bytes * height);
    let index = s["index"].as_u64().unwrap() as usize;
    let truth = &r.truths[index % r.truths.len()];
    let (x, y) = (
        truth.x_px.unwrap().round() as usize,
        truth.y_px.unwrap().round() as usize,
    );
    let led = pixel(&bmp, width, height, x, y);
    assert!(
        led[0] == 255 && led[1] < 128,
        "LED at ({x}, {y}) is {led:?}"
    );
    let [r0, g0, b0] = pixel(&bmp, width, height, 5, 5);
    assert!(r0 == g0 && g0 == b0 && r0 < 200, "corner {r0} {g0} {b0}");
    // The reported position is near the truth.
    let p = &s["position_px"];
    let (px, py) = (p[0].as_f64().unwrap(), p[1].as_f64().unwrap());
    let (tx, ty) = (truth.x_px.unwrap(), truth.y_px.unwrap());
    assert!(
        (px - tx).hypot(py - ty) < 3.0,
        "({px}, {py}) vs ({tx}, {ty})"
    );
    // Bad requests.
    assert_eq!(get(live.addr, "/nothing").0, "HTTP/1.1 404 Not Found");
    assert_eq!(
        exchange(live.addr, b"garbage\r\n\r\n").0,
        "HTTP/1.1 400 Bad Request"
    );
    // A client that connects and never speaks holds up nobody.
    let _silent = TcpStream::connect(live.addr).unwrap();
    assert_eq!(get(live.addr, "/").0, "HTTP/1.1 200 OK");
}

/// Where Debian's `chromium` package puts the browser (tools/setup-system.sh installs it).
fn chromium() -> Option<&'static str> {
    ["/usr/bin/chromium", "/usr/bin/chromium-browser"]
        .into_iter()
        .find(|p| Path::new(p).exists())
}

#[test]
fn headless_chromium_renders_the_page() {
    // Like the VM suite: skipped only when asked to, never because something is missing.
    if common::skipped(
        "GLINT_SKIP_BROWSER",
        "the preview page in headless Chromium",
    ) {
        return;
    }
    let browser = chromium().expect("chromium is installed (tools/setup-system.sh installs it)");
    let r = render("slow-line");
    // The scene forward and then back, over and over: fed forward only, the LED jumps back to
    // its start at every loop (0.75 s), and its track is lost and begins again.
    let forward = std::fs::read(&r.dump).unwrap();
    let frame_bytes = r.scene.frame_len_bytes();
    let back_and_forth: Vec<u8> = forward
        .chunks(frame_bytes)
        .chain(forward.chunks(frame_bytes).rev())
        .flatten()
        .copied()
        .collect();
    let live = Live::feeding(&r, back_and_forth);
    // And the page is opened once the track is long: opened as the run starts, the page's
    // first state held the few points tracked by then.
    let start = Instant::now();
    while state(live.addr)["track_px"]
        .as_array()
        .is_none_or(|t| t.len() < TRACK_SHOWN_POINTS)
    {
        assert!(start.elapsed() < PATIENCE, "the track never grew");
        thread::sleep(Duration::from_millis(100));
    }
    let dir = tempfile::tempdir().unwrap();
    let shot = std::env::var_os("GLINT_PREVIEW_SCREENSHOT")
        .map(std::path::PathBuf::from)
        .unwrap_or_else(|| dir.path().join("preview.png"));
    let profile = dir.path().join("profile");
    let out = Command::new(browser)
        .args([
            "--headless",
            "--no-sandbox",
            "--disable-gpu",
            "--disable-quic",
            "--no-first-run",
            "--disable-background-networking",
            "--disable-component-update",
            "--disable-sync",
            "--window-size=800,600",
            "--virtual-time-budget=3000",
        ])
        .arg(format!("--user-data-dir={}", profile.display()))
        .arg(format!("--screenshot={}", shot.display()))
        .arg(format!("http://{}/", live.addr))
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let (width, height, pixels) = read_png(&shot);
    assert_eq!((width, height), (800, 600));
    // Not blank: above the legend (whose swatches would count), the frame's grey floor, the
    // tinted LED and the drawn track.
    let above_legend = &pixels[..LEGEND_TOP_PX * width as usize];
    let count = |f: fn(&[u8; 3]) -> bool| above_legend.iter().filter(|p| f(p)).count();
    let grey = count(|p| p[0] == p[1] && p[1] == p[2] && (60..200).contains(&p[0]));
    assert!(grey > 100_000, "{grey} grey pixels");
    let red = count(|p| p[0] > 200 && p[1] < 120 && p[2] < 120);
    assert!(red > 3, "the tinted LED shows: {red} red pixels");
    let yellow = count(|p| p[0] > 200 && p[1] > 200 && p[2] < 100);
    assert!(yellow > 50, "the track shows: {yellow} yellow pixels");
}

/// Width, height and RGB pixels of an 8-bit RGB or RGBA PNG.
fn read_png(path: &Path) -> (u32, u32, Vec<[u8; 3]>) {
    let file = std::fs::File::open(path).expect("a screenshot");
    let mut reader = png::Decoder::new(BufReader::new(file)).read_info().unwrap();
    let mut buf = vec![0; reader.output_buffer_size().unwrap()];
    let info = reader.next_frame(&mut buf).unwrap();
    assert_eq!(info.bit_depth, png::BitDepth::Eight);
    let channels = match info.color_type {
        png::ColorType::Rgb => 3,
        png::ColorType::Rgba => 4,
        other => panic!("screenshot in {other:?}"),
    };
    let pixels = buf[..info.buffer_size()]
        .chunks_exact(channels)
        .map(|p| [p[0], p[1], p[2]])
        .collect();
    (info.width, info.height, pixels)
}
