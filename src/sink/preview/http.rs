//! The preview's HTTP/1.1 server: one request per connection (`Connection: close`), each
//! connection on a thread of its own. `GET /` (or `HEAD /`) is the page, `/state.json` what was
//! found in the last copied frame, `/frame.bmp` that frame. Anything else gets 400, 404, 405,
//! 408 or 431 (and the frame 503 when the system has no memory for it); nothing a client sends can panic the server, and nothing it does reaches the
//! tracking thread.
//!
//! Request heads are parsed by `httparse` (the parser under hyper: no allocation, no
//! dependencies, bare line feeds accepted as line ends). A full server (hyper, actix) would
//! bring an async runtime for a page with one viewer; `tiny_http` has no bound on the whole time
//! of a request nor on connections per client. So the connections are handled here, bounded:
//! - a client has [`REQUEST_TIME`] from being accepted to send its whole request head, however
//!   it trickles it (each read waits only for what is left of that time), and
//!   [`RESPONSE_TIME`] to take the answer;
//! - a head is at most [`MAX_HEAD_BYTES`] and [`MAX_HEADERS`] headers, else 431;
//! - connections per client address and in all are capped, the oldest shed for newcomers
//!   ([`super::clients`]).

use std::fmt::Write as _;
use std::io::{self, ErrorKind, Read, Write};
use std::net::{Shutdown, TcpListener, TcpStream};
use std::sync::Arc;
use std::thread;
use std::time::{Duration, Instant};

use memmap2::MmapMut;
use serde_json::json;

use super::clients::{Clients, Ticket};
use super::{Seen, Shared};

/// The page: an image, an overlay canvas and a script that polls the other two paths.
const PAGE_HTML: &str = include_str!("page.html");
/// Longest request head read (request line and headers).
pub const MAX_HEAD_BYTES: usize = 8192;
/// Most headers in a request head.
const MAX_HEADERS: usize = 32;
/// How long a client has, from being accepted, to send its whole request head.
pub const REQUEST_TIME: Duration = Duration::from_secs(5);
/// How long a client has to take the whole answer (a 640×480 frame is 0.9 MB).
const RESPONSE_TIME: Duration = Duration::from_secs(10);
/// After answering, how long what the client still sends is read and dropped, so that closing
/// does not reset the connection before the client has read the answer.
const LINGER: Duration = Duration::from_millis(500);
/// Bytes read and dropped while lingering, at most.
const LINGER_BYTES: usize = 64 * 1024;
/// Bytes written per `write`, so the response deadline is checked between them.
const WRITE_CHUNK_BYTES: usize = 64 * 1024;
/// Stack of a connection's thread: the head buffer and a little more.
const THREAD_STACK_BYTES: usize = 128 * 1024;

/// Starts the accepting thread.
pub fn spawn(listener: TcpListener, shared: Arc<Shared>) -> io::Result<()> {
    thread::Builder::new()
        .name("preview".into())
        .spawn(move || accept(&listener, &shared))
        .map(|_| ())
}

fn accept(listener: &TcpListener, shared: &Arc<Shared>) {
    let clients = Clients::new();
    for stream in listener.incoming() {
        let accepted = Instant::now();
        let Ok(stream) = stream else {
            // Out of descriptors, say: try again a little later.
            thread::sleep(Duration::from_millis(100));
            continue;
        };
        let Ok(peer) = stream.peer_addr() else {
            continue;
        };
        let Ok(ticket) = clients.admit(&stream, peer.ip()) else {
            continue;
        };
        let shared = Arc::clone(shared);
        let spawned = thread::Builder::new()
            .name("preview-conn".into())
            .stack_size(THREAD_STACK_BYTES)
            .spawn(move || {
                if let Err(e) = serve(stream, accepted, &shared, &ticket) {
                    log::debug!("preview: {peer}: {e}");
                }
            });
        if let Err(e) = spawned {
            log::debug!("preview: no thread for {peer}: {e}");
        }
    }
}

/// What a request asks for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Route {
    Page,
    State,
    Frame,
}

/// A request head, read and checked.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Request {
    /// GET or HEAD (`head_only`) of a path served.
    Fetch { route: Route, head_only: bool },
    /// A request refused with this status.
    Refused(&'static str),
}

const BAD_REQUEST: &str = "400 Bad Request";
const NOT_FOUND: &str = "404 Not Found";
const NOT_ALLOWED: &str = "405 Method Not Allowed";
const TIMEOUT: &str = "408 Request Timeout";
const TOO_LARGE: &str = "431 Request Header Fields Too Large";
const UNAVAILABLE: &str = "503 Service Unavailable";

/// Parses a request head: `None` while it is incomplete.
fn parse(head: &[u8]) -> Option<Request> {
    let mut headers = [httparse::EMPTY_HEADER; MAX_HEADERS];
    let mut request = httparse::Request::new(&mut headers);
    let (method, target) = match request.parse(head) {
        Ok(httparse::Status::Partial) => return None,
        Err(httparse::Error::TooManyHeaders) => return Some(Request::Refused(TOO_LARGE)),
        Err(_) => return Some(Request::Refused(BAD_REQUEST)),
        Ok(httparse::Status::Complete(_)) => (request.method, request.path),
    };
    let (Some(method), Some(target)) = (method, target) else {
        return Some(Request::Refused(BAD_REQUEST));
    };
    if !target.starts_with('/') {
        return Some(Request::Refused(BAD_REQUEST));
    }
    let head_only = match method {
        "GET" => false,
        "HEAD" => true,
        _ => return Some(Request::Refused(NOT_ALLOWED)),
    };
    // `?n=...` only defeats caches.
    let route = match target.split('?').next().unwrap_or_default() {
        "/" | "/index.html" => Route::Page,
        "/state.json" => Route::State,
        "/frame.bmp" => Route::Frame,
        _ => return Some(Request::Refused(NOT_FOUND)),
    };
    Some(Request::Fetch { route, head_only })
}

/// The time left before `deadline`, if any (socket timeouts must not be zero).
fn left(deadline: Instant) -> Option<Duration> {
    deadline
        .checked_duration_since(Instant::now())
        .filter(|d| !d.is_zero())
}

fn timed_out(e: &io::Error) -> bool {
    matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut)
}

/// Reads a request head until it is complete, `buf` is full (431) or `deadline` passes (408).
/// `None`: the client closed the connection first.
fn read_request(
    stream: &mut TcpStream,
    buf: &mut [u8],
    deadline: Instant,
) -> io::Result<Option<Request>> {
    let mut len = 0;
    loop {
        let Some(wait) = left(deadline) else {
            return Ok(Some(Request::Refused(TIMEOUT)));
        };
        let Some(free) = buf.get_mut(len..).filter(|free| !free.is_empty()) else {
            return Ok(Some(Request::Refused(TOO_LARGE)));
        };
        stream.set_read_timeout(Some(wait))?;
        match stream.read(free) {
            Ok(0) => return Ok(None),
            Ok(n) => len += n,
            Err(e) if timed_out(&e) => return Ok(Some(Request::Refused(TIMEOUT))),
            Err(e) if e.kind() == ErrorKind::Interrupted => continue,
            Err(e) => return Err(e),
        }
        if let Some(request) = parse(buf.get(..len).unwrap_or_default()) {
            return Ok(Some(request));
        }
    }
}

/// A response body: the page, a small document, or the frame shared with other viewers.
enum Body {
    Static(&'static [u8]),
    Owned(Vec<u8>),
    Shared(Arc<MmapMut>),
}

impl Body {
    fn bytes(&self) -> &[u8] {
        match self {
            Body::Static(b) => b,
            Body::Owned(b) => b,
            Body::Shared(b) => b,
        }
    }
}

/// A response: status, content type, body.
struct Response {
    status: &'static str,
    content_type: &'static str,
    body: Body,
}

impl Response {
    fn text(status: &'static str) -> Self {
        Response {
            status,
            content_type: "text/plain; charset=utf-8",
            body: Body::Owned(format!("{status}\n").into_bytes()),
        }
    }
}

/// Answers a request; a served one marks a viewer.
fn respond(request: Request, shared: &Shared) -> Response {
    let route = match request {
        Request::Refused(status) => return Response::text(status),
        Request::Fetch { route, .. } => route,
    };
    shared.note_request();
    let (content_type, body) = match route {
        Route::Page => (
            "text/html; charset=utf-8",
            Body::Static(PAGE_HTML.as_bytes()),
        ),
        Route::State => (
            "application/json",
            Body::Owned(state_json(&shared.seen(), &shared.calibration_markers_px)),
        ),
        Route::Frame => match shared.encoded.frame(&shared.snapshot) {
            Ok(image) => ("image/bmp", Body::Shared(image)),
            Err(e) => {
                log::debug!("preview: no memory for the frame: {e}");
                return Response::text(UNAVAILABLE);
            }
        },
    };
    Response {
        status: "200 OK",
        content_type,
        body,
    }
}

fn serve(
    mut stream: TcpStream,
    accepted: Instant,
    shared: &Shared,
    ticket: &Ticket,
) -> io::Result<()> {
    let mut buf = [0u8; MAX_HEAD_BYTES];
    let Some(request) = read_request(&mut stream, &mut buf, accepted + REQUEST_TIME)? else {
        return Ok(());
    };
    ticket.answering();
    let head_only = matches!(
        request,
        Request::Fetch {
            head_only: true,
            ..
        }
    );
    let response = respond(request, shared);
    let body = response.body.bytes();
    let mut head = String::with_capacity(160);
    let _ = write!(
        head,
        "HTTP/1.1 {}\r\nContent-Type: {}\r\nContent-Length: {}\r\n",
        response.status,
        response.content_type,
        body.len()
    );
    if response.status == NOT_ALLOWED {
        head.push_str("Allow: GET, HEAD\r\n");
    }
    head.push_str("Cache-Control: no-store\r\nConnection: close\r\n\r\n");
    let deadline = Instant::now() + RESPONSE_TIME;
    write_by(&mut stream, head.as_bytes(), deadline)?;
    if !head_only {
        write_by(&mut stream, body, deadline)?;
    }
    drop(response);
    linger(&mut stream)
}

/// Writes all of `bytes` before `deadline`, or fails.
fn write_by(stream: &mut TcpStream, bytes: &[u8], deadline: Instant) -> io::Result<()> {
    for chunk in bytes.chunks(WRITE_CHUNK_BYTES) {
        let mut rest = chunk;
        while !rest.is_empty() {
            let Some(wait) = left(deadline) else {
                return Err(io::Error::new(
                    ErrorKind::TimedOut,
                    "the answer was not taken",
                ));
            };
            stream.set_write_timeout(Some(wait))?;
            match stream.write(rest) {
                Ok(0) => return Err(ErrorKind::WriteZero.into()),
                Ok(n) => rest = rest.get(n..).unwrap_or_default(),
                Err(e) if timed_out(&e) || e.kind() == ErrorKind::Interrupted => {}
                Err(e) => return Err(e),
            }
        }
    }
    Ok(())
}

/// Ends the answer and reads what the client still sends for a moment before closing.
fn linger(stream: &mut TcpStream) -> io::Result<()> {
    stream.shutdown(Shutdown::Write)?;
    let deadline = Instant::now() + LINGER;
    let mut sink = [0u8; 4096];
    let mut dropped = 0;
    while dropped < LINGER_BYTES {
        let Some(wait) = left(deadline) else {
            break;
        };
        stream.set_read_timeout(Some(wait))?;
        match stream.read(&mut sink) {
            Ok(0) => break,
            Ok(n) => dropped += n,
            Err(e) if e.kind() == ErrorKind::Interrupted => {}
            Err(_) => break,
        }
    }
    Ok(())
}

/// What the page draws and prints. Non-finite numbers become `null`.
fn state_json(s: &Seen, calibration_markers_px: &[[(f32, f32); 4]]) -> Vec<u8> {
    let point = |p: (f32, f32)| [p.0, p.1];
    let state = json!({
        "captured": s.copies > 0,
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
        "floor_grid_px": s
            .grid_px
            .split(|p| p.0.is_nan())
            .filter(|line| line.len() >= 2)
            .map(|line| line.iter().copied().map(point).collect::<Vec<_>>())
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

    fn shared() -> Shared {
        Shared {
            epoch: Instant::now(),
            last_request_ms: AtomicU64::new(0),
            snapshot: Mutex::new(super::super::Snapshot::new(FrameSize::new(4, 2).unwrap())),
            encoded: super::super::encoded::Encoded::new(),
            calibration_markers_px: vec![[(0.5, 0.5), (3.0, 0.5), (3.0, 1.5), (0.5, 1.5)]],
        }
    }

    fn fetch(route: Route) -> Option<Request> {
        Some(Request::Fetch {
            route,
            head_only: false,
        })
    }

    #[test]
    fn heads_parse_with_either_line_end_and_bad_ones_are_refused() {
        let refused = |status| Some(Request::Refused(status));
        let too_many =
            "GET / HTTP/1.1\r\n".to_owned() + &"A: b\r\n".repeat(MAX_HEADERS + 1) + "\r\n";
        let cases: [(&[u8], Option<Request>); 14] = [
            (b"GET / HTTP/1.1\r\nHost: x\r\n\r\n", fetch(Route::Page)),
            (b"GET / HTTP/1.1\n\n", fetch(Route::Page)),
            (
                b"GET /state.json?n=3 HTTP/1.0\nHost: x\n\n",
                fetch(Route::State),
            ),
            (
                b"HEAD /frame.bmp HTTP/1.1\r\n\r\n",
                Some(Request::Fetch {
                    route: Route::Frame,
                    head_only: true,
                }),
            ),
            (b"GET / HTTP/1.1\r\nHost: x\r\n", None),
            (b"GE", None),
            (b"\xff\xfe\r\n\r\n", refused(BAD_REQUEST)),
            (b"GET\r\n\r\n", refused(BAD_REQUEST)),
            (b"GET / HTTP/1.1 extra\r\n\r\n", refused(BAD_REQUEST)),
            (b"GET nothing HTTP/1.1\r\n\r\n", refused(BAD_REQUEST)),
            (b"GET / SPDY/3\r\n\r\n", refused(BAD_REQUEST)),
            (b"POST / HTTP/1.1\r\n\r\n", refused(NOT_ALLOWED)),
            (b"GET /etc/passwd HTTP/1.1\r\n\r\n", refused(NOT_FOUND)),
            (too_many.as_bytes(), refused(TOO_LARGE)),
        ];
        for (head, expected) in cases {
            assert_eq!(parse(head), expected, "{:?}", String::from_utf8_lossy(head));
        }
    }

    #[test]
    fn refusals_do_not_count_as_viewers_and_the_three_paths_do() {
        let shared = shared();
        for status in [BAD_REQUEST, NOT_FOUND, NOT_ALLOWED, TIMEOUT, TOO_LARGE] {
            let response = respond(Request::Refused(status), &shared);
            assert_eq!(response.status, status);
        }
        assert!(!shared.watched(Instant::now()));
        let page = respond(fetch(Route::Page).unwrap(), &shared);
        assert_eq!(page.status, "200 OK");
        assert!(String::from_utf8_lossy(page.body.bytes()).contains("/state.json"));
        assert!(shared.watched(Instant::now()));
        let state = respond(fetch(Route::State).unwrap(), &shared);
        let value: serde_json::Value = serde_json::from_slice(state.body.bytes()).unwrap();
        assert_eq!(value["width"], 4);
        assert_eq!(value["captured"], false);
        assert_eq!(value["calibration_markers_px"][0][2][0], 3.0);
        let frame = respond(fetch(Route::Frame).unwrap(), &shared);
        assert_eq!(frame.content_type, "image/bmp");
        assert_eq!(&frame.body.bytes()[..2], b"BM");
    }
}
