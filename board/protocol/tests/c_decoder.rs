//! The C decoder in `board/arduino/glint.h`, compiled with gcc (and g++, as Arduino sketches are
//! C++) and run against the SPEC's test vectors and against long streams that the Rust encoder
//! produced and then corrupted: its output must match the Rust decoder's event for event.
//!
//! Frozen copies of the version 1 and 2 headers (`tests/c/v1`, `tests/c/v2`) are run on version 3
//! streams too: the SPEC promises that old decoders skip what they do not know and still get
//! every message they do know.
//!
//! Needs gcc and g++ on the PATH (Debian: `apt-get install gcc g++`); the test fails, with that
//! message, if they are missing.

mod common;

use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::OnceLock;

use common::{describe, spec_vectors, SplitMix64};
use glint_protocol::{encode, Decoder, MAX_ENCODED_LEN};

const MANIFEST_DIR: &str = env!("CARGO_MANIFEST_DIR");
/// Warnings the header must compile cleanly under, on both compilers.
const STRICT_FLAGS: [&str; 5] = ["-Wall", "-Wextra", "-Wpedantic", "-Wconversion", "-Werror"];

/// A compiled build of the C test driver.
struct Driver {
    name: &'static str,
    binary: PathBuf,
}

/// Where the current header lives, relative to this crate.
const HEADER_DIR: &str = "../arduino";
/// Where the frozen version 1 header lives.
const V1_HEADER_DIR: &str = "tests/c/v1";
/// Where the frozen version 2 header lives.
const V2_HEADER_DIR: &str = "tests/c/v2";

fn compile(name: &'static str, compiler: &str, extra: &[&str]) -> Driver {
    compile_with(name, HEADER_DIR, compiler, extra)
}

fn compile_with(name: &'static str, header_dir: &str, compiler: &str, extra: &[&str]) -> Driver {
    let source = Path::new(MANIFEST_DIR).join("tests/c/decode_stdin.c");
    let include = Path::new(MANIFEST_DIR).join(header_dir);
    let binary = Path::new(env!("CARGO_TARGET_TMPDIR")).join(format!("glint_{name}"));
    let output = Command::new(compiler)
        .args(extra)
        .args(STRICT_FLAGS)
        .arg("-I")
        .arg(&include)
        .arg(&source)
        .arg("-o")
        .arg(&binary)
        .output()
        .unwrap_or_else(|e| {
            panic!("cannot run `{compiler}` ({e}): the C decoder test needs gcc and g++ (apt-get install gcc g++)")
        });
    assert!(
        output.status.success(),
        "{compiler} failed to compile glint.h ({name}):\n{}",
        String::from_utf8_lossy(&output.stderr)
    );
    Driver { name, binary }
}

/// The C driver in its three builds: C99 with address and undefined-behaviour sanitizers, C++11
/// (as the Arduino IDE compiles it), and C99 with the smallest buffer a position-only robot uses.
fn drivers() -> &'static [Driver; 3] {
    static DRIVERS: OnceLock<[Driver; 3]> = OnceLock::new();
    DRIVERS.get_or_init(|| {
        [
            compile(
                "c99",
                "gcc",
                &[
                    "-std=c99",
                    "-O1",
                    "-g",
                    "-fsanitize=address,undefined",
                    "-fno-sanitize-recover=all",
                ],
            ),
            compile("cxx11", "g++", &["-x", "c++", "-std=c++11", "-O2"]),
            compile(
                "c99_buf23",
                "gcc",
                &["-std=c99", "-O2", "-DGLINT_BUFFER_LEN=23"],
            ),
        ]
    })
}

fn run(driver: &Driver, input: &[u8]) -> Vec<String> {
    let mut child = Command::new(&driver.binary)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap_or_else(|e| panic!("cannot run {}: {e}", driver.binary.display()));
    let mut stdin = child.stdin.take().expect("piped stdin");
    let input = input.to_vec();
    // Write from a thread so a large input cannot deadlock against a full stdout pipe.
    let writer = std::thread::spawn(move || stdin.write_all(&input));
    let output = child.wait_with_output().expect("driver ran");
    writer.join().expect("writer thread").expect("wrote stdin");
    assert!(
        output.status.success(),
        "C driver {} failed: {}",
        driver.name,
        String::from_utf8_lossy(&output.stderr)
    );
    String::from_utf8(output.stdout)
        .expect("ASCII output")
        .lines()
        .map(str::to_owned)
        .collect()
}

#[test]
fn c_decoder_passes_the_spec_vectors() {
    let vectors = spec_vectors();
    assert!(!vectors.is_empty());
    for driver in &drivers()[..2] {
        for v in &vectors {
            assert_eq!(
                run(driver, &v.wire),
                v.decodes,
                "{} on {}",
                driver.name,
                v.name
            );
        }
    }
}

/// A long stream of frames from the Rust encoder, a fifth of them damaged, with garbage between.
fn hostile_stream(seed: u64, frames: usize) -> Vec<u8> {
    let mut rng = SplitMix64(seed);
    let mut stream = Vec::new();
    let mut out = [0u8; MAX_ENCODED_LEN + 1];
    for _ in 0..frames {
        let mut frame = encode(&rng.message(), &mut out).expect("fits").to_vec();
        match rng.below(10) {
            0 => {
                let i = rng.below(frame.len());
                frame[i] ^= 1 << rng.below(8);
            }
            1 => frame.truncate(rng.below(frame.len())),
            2 => stream.extend((0..rng.below(90)).map(|_| rng.byte())),
            3 => {
                // A frame with a good CRC and a malformed body or an unknown id.
                let payload_len = frame.len() - 1;
                let mut payload = cobs::decode_vec(&frame[..payload_len]).expect("valid");
                let body_end = payload.len() - 2;
                payload.truncate(body_end);
                let j = rng.below(body_end);
                payload[j] = rng.byte();
                let crc = glint_protocol::FRAME_CRC.checksum(&payload);
                payload.extend(crc.to_le_bytes());
                frame = cobs::encode_vec(&payload);
                frame.push(0);
            }
            _ => {}
        }
        stream.extend(frame);
    }
    stream
}

/// Compares event lists, reporting the first difference rather than thousands of lines.
fn assert_same_events(actual: &[String], expected: &[String], what: &str) {
    if let Some(i) =
        (0..actual.len().max(expected.len())).find(|&i| actual.get(i) != expected.get(i))
    {
        panic!(
            "{what}: event {i} differs (of {} actual, {} expected):\n  actual:   {:?}\n  expected: {:?}",
            actual.len(),
            expected.len(),
            actual.get(i),
            expected.get(i)
        );
    }
}

fn rust_events<const N: usize>(mut decoder: Decoder<N>, stream: &[u8]) -> Vec<String> {
    decoder.feed(stream).map(|e| describe(&e)).collect()
}

#[test]
fn c_decoder_matches_the_rust_decoder_on_hostile_streams() {
    let stream = hostile_stream(0x6c69_6e74_0c0c, 5_000);
    let expected = rust_events(Decoder::new(), &stream);
    // The stream must exercise every kind of outcome, or the comparison proves little.
    for kind in [
        "position",
        "heartbeat",
        "unknown",
        "error crc",
        "error cobs",
        "error malformed",
        "error overflow",
    ] {
        assert!(
            expected.iter().any(|e| e.starts_with(kind)),
            "stream has no `{kind}` event"
        );
    }
    for driver in &drivers()[..2] {
        assert_same_events(&run(driver, &stream), &expected, driver.name);
    }
    let small = rust_events(Decoder::<23>::with_capacity(), &stream);
    assert_same_events(&run(&drivers()[2], &stream), &small, "23-byte buffers");
}

/// What a decoder of an older `version` reports for an event of the current decoder: the ids
/// added since, well formed or not (it does not know their layout), are unknown ids; the rest is
/// the same.
fn as_version(version: u8, event: &str) -> String {
    let added_after = |id: u8| match id {
        0x03 | 0x04 => version < 2,
        0x05 => version < 3,
        _ => false,
    };
    let id = if event.starts_with("age ") {
        Some(0x03)
    } else if event.starts_with("led ") {
        Some(0x04)
    } else if event.starts_with("robot-position ") {
        Some(0x05)
    } else {
        event
            .strip_prefix("error malformed id=0x")
            .and_then(|hex| u8::from_str_radix(hex, 16).ok())
    };
    match id {
        Some(id) if added_after(id) => format!("unknown id={id:#04x}"),
        _ => event.to_string(),
    }
}

/// An older decoder on a current stream: every message it knows exactly as the current decoder
/// sees it, and the newer messages skipped as unknown ids, nothing dropped.
fn check_older_header(version: u8, header_dir: &str, name: &'static str) {
    let old = compile_with(
        name,
        header_dir,
        "gcc",
        &["-std=c99", "-O1", "-g", "-fsanitize=address,undefined"],
    );
    let stream = hostile_stream(0x7632_7631, 3_000);
    let events = rust_events(Decoder::new(), &stream);
    let expected: Vec<String> = events.iter().map(|e| as_version(version, e)).collect();
    for kind in ["age ", "led ", "position ", "robot-position ", "heartbeat "] {
        assert!(
            events.iter().any(|e| e.starts_with(kind)),
            "stream has no `{kind}` event"
        );
    }
    assert_same_events(&run(&old, &stream), &expected, name);

    // The SPEC's own vectors of newer traffic, through the old header.
    for v in spec_vectors().iter().filter(|v| v.name.starts_with('v')) {
        let got = run(&old, &v.wire);
        let want: Vec<String> = v.decodes.iter().map(|d| as_version(version, d)).collect();
        assert_eq!(got, want, "version {version} header on {}", v.name);
    }
}

#[test]
fn a_version_1_decoder_still_decodes_version_3_updates() {
    check_older_header(1, V1_HEADER_DIR, "v1_c99");
}

#[test]
fn a_version_2_decoder_still_decodes_version_3_traffic() {
    check_older_header(2, V2_HEADER_DIR, "v2_c99");
}
