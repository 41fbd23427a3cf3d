//! The preview's memory with many viewers that ask for the frame and never read it (issue 13:
//! 8 such viewers at 4096×4096 took the process from 55 to 580 MB, and 187 MB stayed after they
//! left). Every viewer is sent one shared image, so the growth is one image whatever their
//! number, and it is freed when they leave. Alone in its test binary: it reads this process's
//! resident size.
//!
//! `GLINT_PREVIEW_MEMORY_SIZE=4096x4096` measures at another frame size (the default is
//! 2048×2048), `GLINT_PREVIEW_MEMORY_STALL_S=8` watches the stalled readers longer (the default
//! is 2 s); run with `--nocapture` for the figures.

use std::io::{Cursor, Read, Write};
use std::net::{SocketAddr, TcpStream};
use std::thread;
use std::time::{Duration, Instant};

use glint::frame::FrameSize;
use glint::pipeline::{self, Pipeline, PipelineConfig};
use glint::sink::preview::PreviewSink;
use glint::source::dump::DumpSource;

/// Viewers that ask for the frame and stall.
const STALLED_READERS: usize = 8;
/// How long the stalled readers are watched by default; the server has blocked on them well
/// before.
const STALL_S: u64 = 2;
/// Between two readings of the resident size.
const SAMPLE_PERIOD: Duration = Duration::from_millis(100);
/// File and info headers of a BMP.
const BMP_HEADER_BYTES: usize = 54;
const MB: f64 = 1024.0 * 1024.0;

/// This process's resident size (`VmRSS`), in bytes.
fn rss_bytes() -> usize {
    let status = std::fs::read_to_string("/proc/self/status").unwrap();
    let kb: usize = status
        .lines()
        .find_map(|l| l.strip_prefix("VmRSS:"))
        .and_then(|v| v.trim().trim_end_matches("kB").trim().parse().ok())
        .expect("VmRSS in /proc/self/status");
    kb * 1024
}

/// Sends a GET and reads the whole answer.
fn get(addr: SocketAddr, path: &str) -> Vec<u8> {
    let mut stream = TcpStream::connect(addr).unwrap();
    stream
        .set_read_timeout(Some(Duration::from_secs(60)))
        .unwrap();
    write!(stream, "GET {path} HTTP/1.1\r\n\r\n").unwrap();
    let mut reply = Vec::new();
    stream.read_to_end(&mut reply).unwrap();
    reply
}

fn stall() -> Duration {
    let text = std::env::var("GLINT_PREVIEW_MEMORY_STALL_S").unwrap_or_default();
    Duration::from_secs(text.parse().unwrap_or(STALL_S))
}

fn size() -> FrameSize {
    let text = std::env::var("GLINT_PREVIEW_MEMORY_SIZE").unwrap_or("2048x2048".into());
    let (w, h) = text.split_once('x').expect("WIDTHxHEIGHT");
    FrameSize::new(w.parse().unwrap(), h.parse().unwrap()).unwrap()
}

#[test]
fn stalled_frame_readers_share_one_image_and_it_is_freed() {
    let size = size();
    let sink = PreviewSink::start("127.0.0.1:0".parse().unwrap(), size, Vec::new()).unwrap();
    let addr = sink.local_addr();
    // A viewer asks: the next frame is copied. A frame of a luma ramp, so its pages are real.
    assert!(get(addr, "/state.json").starts_with(b"HTTP/1.1 200 OK"));
    let frame: Vec<u8> = (0..size.frame_bytes())
        .map(|i| if i % 2 == 0 { (i / 2 % 251) as u8 } else { 128 })
        .collect();
    let mut sink = sink;
    {
        let mut source = DumpSource::new(Cursor::new(&frame), size, 30.0);
        let mut pipeline = Pipeline::new(size, PipelineConfig::default()).unwrap();
        let (summary, result) = pipeline::run(&mut source, &mut pipeline, &mut sink);
        result.unwrap();
        assert_eq!(summary.frames, 1);
    }
    drop(frame);
    // One whole answer first: the frame is served, and the allocator has seen an image.
    let bmp_bytes = BMP_HEADER_BYTES + (size.width() * 3).div_ceil(4) * 4 * size.height();
    let reply = get(addr, "/frame.bmp");
    assert!(reply.starts_with(b"HTTP/1.1 200 OK"));
    assert!(reply.len() > bmp_bytes);
    drop(reply);
    thread::sleep(SAMPLE_PERIOD);
    let before = rss_bytes();

    let stalled: Vec<TcpStream> = (0..STALLED_READERS)
        .map(|_| {
            let mut s = TcpStream::connect(addr).unwrap();
            s.write_all(b"GET /frame.bmp HTTP/1.1\r\n\r\n").unwrap();
            s
        })
        .collect();
    let mut peak = before;
    let start = Instant::now();
    while start.elapsed() < stall() {
        thread::sleep(SAMPLE_PERIOD);
        peak = peak.max(rss_bytes());
    }
    drop(stalled);
    thread::sleep(Duration::from_secs(1));
    let after = rss_bytes();

    let grown = peak.saturating_sub(before);
    let kept = after.saturating_sub(before);
    println!(
        "{}x{}, {STALLED_READERS} stalled /frame.bmp readers, image {:.1} MB: resident {:.1} MB \
         before, {:.1} MB while they stalled (+{:.1}), {:.1} MB after they left (+{:.1})",
        size.width(),
        size.height(),
        bmp_bytes as f64 / MB,
        before as f64 / MB,
        peak as f64 / MB,
        grown as f64 / MB,
        after as f64 / MB,
        kept as f64 / MB,
    );
    // One shared image (a copy per reader would be 8 images and 8 frames of luma).
    assert!(
        grown < 2 * bmp_bytes,
        "grew by {:.1} MB with {STALLED_READERS} readers of a {:.1} MB image",
        grown as f64 / MB,
        bmp_bytes as f64 / MB
    );
    assert!(
        kept < bmp_bytes / 2,
        "{:.1} MB stayed after the readers left",
        kept as f64 / MB
    );
}
