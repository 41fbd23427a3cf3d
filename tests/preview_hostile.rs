//! The preview against hostile clients (issue 13): connections that trickle their request a
//! byte at a time, requests with bare line feeds, HEAD, oversized heads, and one address opening
//! more connections than it may hold. The real server, in this process, on loopback.

use std::io::{ErrorKind, Read, Write};
use std::net::{SocketAddr, TcpStream};
use std::thread;
use std::time::{Duration, Instant};

use glint::frame::FrameSize;
use glint::sink::preview::{PreviewSink, CONNECTIONS_PER_CLIENT, MAX_HEAD_BYTES, REQUEST_TIME};

/// How long a probe waits for its whole answer: a page under attack still answers within this.
const PROBE_PATIENCE: Duration = Duration::from_secs(2);
/// How long the trickling clients keep at it.
const ATTACK: Duration = Duration::from_secs(7);
/// Between two trickled bytes.
const TRICKLE_PERIOD: Duration = Duration::from_secs(1);
/// Between an attacker's connection being cut and its next one.
const RECONNECT_PAUSE: Duration = Duration::from_millis(100);
/// Slack on the request deadline for a loaded machine (a bound that must hold, not a speed).
const DEADLINE_SLACK: Duration = Duration::from_secs(3);

fn server() -> PreviewSink {
    let size = FrameSize::new(64, 48).unwrap();
    PreviewSink::start("127.0.0.1:0".parse().unwrap(), size, Vec::new()).unwrap()
}

/// The answer to `request`, head and body, if the whole of it came within [`PROBE_PATIENCE`].
fn probe(addr: SocketAddr, request: &[u8]) -> Option<(String, Vec<u8>)> {
    let deadline = Instant::now() + PROBE_PATIENCE;
    let mut stream = TcpStream::connect_timeout(&addr, PROBE_PATIENCE).ok()?;
    stream.set_write_timeout(Some(PROBE_PATIENCE)).ok()?;
    stream.write_all(request).ok()?;
    let mut reply = Vec::new();
    let mut chunk = [0u8; 4096];
    loop {
        let wait = deadline.checked_duration_since(Instant::now())?;
        stream.set_read_timeout(Some(wait)).ok()?;
        match stream.read(&mut chunk) {
            Ok(0) => break,
            Ok(n) => reply.extend_from_slice(&chunk[..n]),
            Err(e) if e.kind() == ErrorKind::Interrupted => {}
            Err(_) => return None,
        }
    }
    let split = reply.windows(4).position(|w| w == b"\r\n\r\n")?;
    let head = String::from_utf8_lossy(&reply[..split]).into_owned();
    Some((head, reply[split + 4..].to_vec()))
}

fn status(head: &str) -> &str {
    head.lines().next().unwrap_or_default()
}

fn content_length(head: &str) -> usize {
    head.lines()
        .find_map(|l| l.strip_prefix("Content-Length: "))
        .and_then(|l| l.parse().ok())
        .expect("a length")
}

/// Whether the server has closed `stream` (or answered on it) within `wait`.
fn closed_within(stream: &mut TcpStream, wait: Duration) -> bool {
    stream.set_read_timeout(Some(wait)).unwrap();
    let mut byte = [0u8; 1];
    match stream.read(&mut byte) {
        // End of stream, or an answer (408): either way its request is over.
        Ok(0 | 1) => true,
        Ok(_) => unreachable!("one byte asked"),
        Err(e) => !matches!(e.kind(), ErrorKind::WouldBlock | ErrorKind::TimedOut),
    }
}

/// One attacker for [`ATTACK`]: connects, sends a request line and then one header byte per
/// [`TRICKLE_PERIOD`], never ending the head; when the server cuts it off, connects again
/// [`RECONNECT_PAUSE`] later.
/// Returns how long each of its connections lasted.
fn trickle(addr: SocketAddr) -> Vec<Duration> {
    let start = Instant::now();
    let mut lifetimes = Vec::new();
    while start.elapsed() < ATTACK {
        let Ok(mut stream) = TcpStream::connect(addr) else {
            thread::sleep(TRICKLE_PERIOD);
            continue;
        };
        let opened = Instant::now();
        let _ = stream.write_all(b"GET / HTTP/1.1\r\nX-Slow: ");
        while start.elapsed() < ATTACK + REQUEST_TIME + DEADLINE_SLACK {
            if closed_within(&mut stream, TRICKLE_PERIOD) || stream.write_all(b"a").is_err() {
                break;
            }
        }
        lifetimes.push(opened.elapsed());
        thread::sleep(RECONNECT_PAUSE);
    }
    lifetimes
}

#[test]
fn trickling_clients_neither_starve_the_page_nor_outlast_the_request_deadline() {
    let sink = server();
    let addr = sink.local_addr();
    let attackers: Vec<_> = (0..CONNECTIONS_PER_CLIENT + 2)
        .map(|_| thread::spawn(move || trickle(addr)))
        .collect();
    // Let them take every slot, then ask for the page all through the attack.
    thread::sleep(TRICKLE_PERIOD + TRICKLE_PERIOD / 2);
    let (mut asked, mut answered) = (0, 0);
    let started = Instant::now();
    while started.elapsed() < ATTACK - 2 * TRICKLE_PERIOD {
        asked += 1;
        if let Some((head, body)) = probe(addr, b"GET / HTTP/1.1\r\nHost: glint\r\n\r\n") {
            assert_eq!(status(&head), "HTTP/1.1 200 OK");
            assert_eq!(body.len(), content_length(&head));
            answered += 1;
        }
        thread::sleep(Duration::from_millis(500));
    }
    assert_eq!(answered, asked, "probes answered within {PROBE_PATIENCE:?}");
    // No trickled request held its connection much past the deadline.
    let longest = attackers
        .into_iter()
        .flat_map(|a| a.join().unwrap())
        .max()
        .unwrap();
    assert!(
        longest <= REQUEST_TIME + DEADLINE_SLACK,
        "a trickling client held its connection for {longest:?}"
    );
}

#[test]
fn head_and_bare_line_feeds_are_answered() {
    let sink = server();
    let addr = sink.local_addr();
    let (head, page) = probe(addr, b"GET / HTTP/1.1\r\n\r\n").expect("an answer to GET");
    assert_eq!(status(&head), "HTTP/1.1 200 OK");
    for path in ["/", "/state.json", "/frame.bmp"] {
        // HEAD: the same head as GET, no body.
        let request = format!("HEAD {path} HTTP/1.1\r\nHost: glint\r\n\r\n");
        let (head, body) = probe(addr, request.as_bytes()).expect("an answer to HEAD");
        assert_eq!(status(&head), "HTTP/1.1 200 OK", "HEAD {path}");
        assert!(body.is_empty(), "HEAD {path} has no body");
        assert!(content_length(&head) > 0, "HEAD {path}");
        if path == "/" {
            assert_eq!(content_length(&head), page.len());
        }
        // Bare line feeds end lines as well as CRLF.
        let request = format!("GET {path} HTTP/1.1\nHost: glint\n\n");
        let (head, body) = probe(addr, request.as_bytes()).expect("an answer with bare LF");
        assert_eq!(status(&head), "HTTP/1.1 200 OK", "bare LF {path}");
        assert_eq!(body.len(), content_length(&head));
    }
    let (head, _) = probe(addr, b"GET / HTTP/1.1\n\n").expect("the shortest bare-LF request");
    assert_eq!(status(&head), "HTTP/1.1 200 OK");
    let (head, _) = probe(addr, b"DELETE / HTTP/1.1\r\n\r\n").expect("an answer to DELETE");
    assert_eq!(status(&head), "HTTP/1.1 405 Method Not Allowed");
    assert!(head.contains("Allow: GET, HEAD"));
}

#[test]
fn oversized_heads_are_refused() {
    let sink = server();
    let addr = sink.local_addr();
    let long_value = format!(
        "GET / HTTP/1.1\r\nX-Filler: {}\r\n\r\n",
        "a".repeat(MAX_HEAD_BYTES)
    );
    let many_headers = format!("GET / HTTP/1.1\r\n{}\r\n", "X-A: b\r\n".repeat(200));
    for request in [long_value, many_headers] {
        let (head, _) = probe(addr, request.as_bytes()).expect("an answer");
        assert_eq!(
            status(&head),
            "HTTP/1.1 431 Request Header Fields Too Large"
        );
    }
    // The server goes on serving.
    let (head, _) = probe(addr, b"GET /state.json HTTP/1.1\r\n\r\n").expect("an answer");
    assert_eq!(status(&head), "HTTP/1.1 200 OK");
}

#[test]
fn one_address_holding_too_many_connections_sheds_its_oldest() {
    let sink = server();
    let addr = sink.local_addr();
    let extra = 2;
    let mut silent: Vec<TcpStream> = Vec::new();
    for _ in 0..CONNECTIONS_PER_CLIENT + extra {
        silent.push(TcpStream::connect(addr).unwrap());
        // Accepted in order, so "oldest" is well defined.
        thread::sleep(Duration::from_millis(50));
    }
    // The oldest are shut at once, long before their request deadline.
    for (i, stream) in silent.iter_mut().take(extra).enumerate() {
        assert!(
            closed_within(stream, REQUEST_TIME / 2),
            "connection {i} was not shed"
        );
    }
    // The newer ones are still open.
    for (i, stream) in silent.iter_mut().enumerate().skip(extra) {
        assert!(
            !closed_within(stream, Duration::from_millis(100)),
            "connection {i} was closed"
        );
    }
    // A request from the same address still gets in (shedding one of the silent ones).
    let (head, _) = probe(addr, b"GET / HTTP/1.1\r\n\r\n").expect("an answer");
    assert_eq!(status(&head), "HTTP/1.1 200 OK");
}
