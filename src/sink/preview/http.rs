//! A tiny HTTP/1.1 server for the preview: one request per connection (`Connection: close`),
//! each connection on a thread of its own with read and write timeouts, at most
//! [`MAX_CONNECTIONS`] at a time. `GET /` is the page, `/state.json` what was found in the last
//! copied frame, `/frame.bmp` that frame. Anything else gets 400, 404 or 405; nothing a client
//! sends can panic the server, and nothing it does reaches the tracking thread.

use std::io::{self, Read, Write};
use std::net::{TcpListener, TcpStream};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Arc;
use std::thread;
use std::time::Duration;

use serde_json::json;

use super::{bmp, Shared, Snapshot};

/// The page: an image, an overlay canvas and a script that polls the other two paths.
const PAGE_HTML: &str = include_str!("page.html");
/// Longest request head read.
const MAX_REQUEST_BYTES: usize = 4096;
/// How long a client may take to send its request or to take the answer.
const IO_TIMEOUT: Duration = Duration::from_secs(5);
/// Connections served at once; more are closed unanswered.
const MAX_CONNECTIONS: usize = 8;

/// Starts the accepting thread.
pub fn spawn(listener: TcpListener, shared: Arc<Shared>) -> io::Result<()> {
    thread::Builder::new()
        .name("preview".into())
        .spawn(move || accept(&listener, &shared))
        .map(|_| ())
}

fn accept(listener: &TcpListener, shared: &Arc<Shared>) {
    let open = Arc::new(AtomicUsize::new(0));
    for stream in listener.incoming() {
        let Ok(stream) = stream else {
            // Out of descriptors, say: try again a little later.
            thread::sleep(Duration::from_millis(100));
            continue;
        };
        if open.fetch_add(1, Ordering::AcqRel) >= MAX_CONNECTIONS {
            open.fetch_sub(1, Ordering::AcqRel);
            continue;
        }
        let shared = Arc::clone(shared);
        let done = Arc::clone(&open);
        let spawned = thread::Builder::new()
            .name("preview-conn".into())
            .spawn(move || {
                if let Err(e) = serve(stream, &shared) {
                    log::debug!("preview: {e}");
                }
                done.fetch_sub(1, Ordering::AcqRel);
            });
        if spawned.is_err() {
            open.fetch_sub(1, Ordering::AcqRel);
        }
    }
}

/// A response: status line, content type, body.
struct Response {
    status: &'static str,
    content_type: &'static str,
    body: Vec<u8>,
}

impl Response {
    fn text(status: &'static str) -> Self {
        Response {
            status,
            content_type: "text/plain; charset=utf-8",
            body: format!("{status}\n").into_bytes(),
        }
    }
}

fn serve(mut stream: TcpStream, shared: &Shared) -> io::Result<()> {
    stream.set_read_timeout(Some(IO_TIMEOUT))?;
    stream.set_write_timeout(Some(IO_TIMEOUT))?;
    let head = read_head(&mut stream)?;
    let response = respond(&head, shared);
    write!(
        stream,
        "HTTP/1.1 {}\r\nContent-Type: {}\r\nContent-Length: {}\r\n\
         Cache-Control: no-store\r\nConnection: close\r\n\r\n",
        response.status,
        response.content_type,
        response.body.len()
    )?;
    stream.write_all(&response.body)?;
    stream.flush()
}

/// Reads up to the blank line ending the request head, or [`MAX_REQUEST_BYTES`].
fn read_head(stream: &mut TcpStream) -> io::Result<Vec<u8>> {
    let mut head = Vec::with_capacity(MAX_REQUEST_BYTES);
    let mut chunk = [0u8; 512];
    while head.len() < MAX_REQUEST_BYTES && !head.windows(4).any(|w| w == b"\r\n\r\n") {
        let n = stream.read(&mut chunk)?;
        if n == 0 {
            break;
        }
        head.extend_from_slice(chunk.get(..n).unwrap_or_default());
    }
    Ok(head)
}

/// Routes one request head.
fn respond(head: &[u8], shared: &Shared) -> Response {
    let line = head.split(|&b| b == b'\n').next().unwrap_or_default();
    let Ok(line) = std::str::from_utf8(line) else {
        return Response::text("400 Bad Request");
    };
    let mut parts = line.trim_end_matches('\r').split(' ');
    let (Some(method), Some(target), Some(version), None) =
        (parts.next(), parts.next(), parts.next(), parts.next())
    else {
        return Response::text("400 Bad Request");
    };
    if !version.starts_with("HTTP/1.") || !target.starts_with('/') {
        return Response::text("400 Bad Request");
    }
    if method != "GET" {
        return Response::text("405 Method Not Allowed");
    }
    // `?n=...` only defeats caches.
    let path = target.split('?').next().unwrap_or_default();
    let body = match path {
        "/" | "/index.html" => (PAGE_HTML.as_bytes().to_vec(), "text/html; charset=utf-8"),
        "/state.json" => (
            state_json(&shared.snapshot(), &shared.calibration_markers_px),
            "application/json",
        ),
        "/frame.bmp" => {
            let mut out = Vec::new();
            bmp::encode(&shared.snapshot(), &mut out);
            (out, "image/bmp")
        }
        _ => return Response::text("404 Not Found"),
    };
    shared.note_request();
    Response {
        status: "200 OK",
        content_type: body.1,
        body: body.0,
    }
}

/// What the page draws and prints. Non-finite numbers become `null`.
fn state_json(s: &Snapshot, calibration_markers_px: &[[(f32, f32); 4]]) -> Vec<u8> {
    let point = |p: (f32, f32)| [p.0, p.1];
    let state = json!({
        "captured": s.captured,
        "index": s.index,
        "t_s": s.t_s,
        "width": s.size.width(),
        "height": s.size.height(),
        "threshold_luma": s.threshold_luma,
        "found": s.position_px.is_some(),
        "position_px": s.position_px.map(point),
        "mid_px": s.mid_px.map(point),
        "ends_px": s.ends_px.map(|e| e.map(point)),
        "marker_px": s.marker_px.map(|m| m.map(|c| [c.0, c.1])),
        "track_px": s.track_px.iter().copied().map(point).collect::<Vec<_>>(),
        "calibration_markers_px": calibration_markers_px
            .iter()
            .map(|m| m.map(point))
            .collect::<Vec<_>>(),
        "fps": s.fps,
    });
    state.to_string().into_bytes()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::frame::FrameSize;
    use std::sync::atomic::AtomicU64;
    use std::sync::Mutex;
    use std::time::Instant;

    fn shared() -> Shared {
        Shared {
            epoch: Instant::now(),
            last_request_ms: AtomicU64::new(0),
            snapshot: Mutex::new(Snapshot::new(FrameSize::new(4, 2).unwrap())),
            calibration_markers_px: vec![[(0.5, 0.5), (3.0, 0.5), (3.0, 1.5), (0.5, 1.5)]],
        }
    }

    #[test]
    fn bad_requests_are_refused_and_do_not_count_as_viewers() {
        let shared = shared();
        let cases: [(&[u8], &str); 8] = [
            (b"", "400 Bad Request"),
            (b"\xff\xfe\r\n\r\n", "400 Bad Request"),
            (b"GET\r\n\r\n", "400 Bad Request"),
            (b"GET / HTTP/1.1 extra\r\n\r\n", "400 Bad Request"),
            (b"GET nothing HTTP/1.1\r\n\r\n", "400 Bad Request"),
            (b"GET / SPDY/3\r\n\r\n", "400 Bad Request"),
            (b"POST / HTTP/1.1\r\n\r\n", "405 Method Not Allowed"),
            (b"GET /etc/passwd HTTP/1.1\r\n\r\n", "404 Not Found"),
        ];
        for (head, status) in cases {
            assert_eq!(respond(head, &shared).status, status, "{head:?}");
        }
        assert!(!shared.watched(Instant::now()));
    }

    #[test]
    fn the_three_paths_answer_and_mark_a_viewer() {
        let shared = shared();
        let page = respond(b"GET / HTTP/1.1\r\nHost: x\r\n\r\n", &shared);
        assert_eq!(page.status, "200 OK");
        assert!(String::from_utf8_lossy(&page.body).contains("/state.json"));
        assert!(shared.watched(Instant::now()));
        let state = respond(b"GET /state.json?n=3 HTTP/1.1\r\n\r\n", &shared);
        let value: serde_json::Value = serde_json::from_slice(&state.body).unwrap();
        assert_eq!(value["width"], 4);
        assert_eq!(value["captured"], false);
        assert_eq!(value["calibration_markers_px"][0][2][0], 3.0);
        let frame = respond(b"GET /frame.bmp HTTP/1.0\r\n\r\n", &shared);
        assert_eq!(frame.content_type, "image/bmp");
        assert_eq!(&frame.body[..2], b"BM");
    }
}
