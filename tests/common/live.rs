//! Helpers for tests of a running `glint`: feeding it frames without end, reading its log as it
//! comes, and talking HTTP to its preview.

use std::io::{BufRead, BufReader, Read, Write};
use std::net::{SocketAddr, TcpStream};
use std::process::{ChildStderr, ChildStdin};
use std::sync::mpsc;
use std::thread;
use std::time::Duration;

/// Longest wait for an HTTP answer.
const HTTP_PATIENCE: Duration = Duration::from_secs(60);

/// Writes `frames` (whole frames of `frame_bytes`) to `stdin` over and over, 5 ms apart, like
/// a camera, until glint stops reading.
pub fn feed_endlessly(
    mut stdin: ChildStdin,
    frames: Vec<u8>,
    frame_bytes: usize,
) -> thread::JoinHandle<()> {
    thread::spawn(move || 'feed: loop {
        for frame in frames.chunks(frame_bytes) {
            if stdin.write_all(frame).is_err() {
                break 'feed;
            }
            thread::sleep(Duration::from_millis(5));
        }
    })
}

/// The lines of `stderr`, as they are written, and the thread that reads them.
pub fn lines_of(stderr: ChildStderr) -> (mpsc::Receiver<String>, thread::JoinHandle<()>) {
    let (tx, lines) = mpsc::channel();
    let reader = thread::spawn(move || {
        for line in BufReader::new(stderr).lines().map_while(Result::ok) {
            let _ = tx.send(line);
        }
    });
    (lines, reader)
}

/// Sends `request` and returns the status line and the body (checked against its length).
pub fn exchange(addr: SocketAddr, request: &[u8]) -> (String, Vec<u8>) {
    let mut stream = TcpStream::connect(addr).unwrap();
    stream.set_read_timeout(Some(HTTP_PATIENCE)).unwrap();
    stream.write_all(request).unwrap();
    let mut reply = Vec::new();
    stream.read_to_end(&mut reply).unwrap();
    let split = reply
        .windows(4)
        .position(|w| w == b"\r\n\r\n")
        .expect("a header");
    let head = String::from_utf8_lossy(&reply[..split]).into_owned();
    let status = head.lines().next().unwrap_or_default().to_owned();
    let length: usize = head
        .lines()
        .find_map(|l| l.strip_prefix("Content-Length: "))
        .and_then(|l| l.parse().ok())
        .expect("a length");
    let body = reply[split + 4..].to_vec();
    assert_eq!(body.len(), length, "{status}");
    (status, body)
}

/// `GET path`, returning the status line and the body.
pub fn get(addr: SocketAddr, path: &str) -> (String, Vec<u8>) {
    exchange(
        addr,
        format!("GET {path} HTTP/1.1\r\nHost: glint\r\n\r\n").as_bytes(),
    )
}
