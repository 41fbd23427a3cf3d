//! The test vectors written in SPEC.md, checked against the Rust encoder and decoder. The vectors
//! are parsed out of SPEC.md itself, so the document and the code cannot drift apart.

mod common;

use common::{describe, hex, parse_message, spec_vectors};
use glint_protocol::{encode, Decoder, MAX_ENCODED_LEN};

#[test]
fn spec_has_encoder_and_decoder_vectors() {
    let vectors = spec_vectors();
    let encoders = vectors.iter().filter(|v| v.message.is_some()).count();
    assert!(encoders >= 5, "SPEC.md has only {encoders} encoder vectors");
    assert!(
        vectors.len() >= 12,
        "SPEC.md has only {} vectors",
        vectors.len()
    );
}

#[test]
fn encoder_produces_the_spec_bytes() {
    for v in spec_vectors().iter().filter(|v| v.message.is_some()) {
        let text = v.message.as_deref().unwrap_or_default();
        let message = parse_message(text).unwrap_or_else(|e| panic!("{}: {e}", v.name));
        let mut out = [0u8; MAX_ENCODED_LEN + 1];
        let wire = encode(&message, &mut out).unwrap_or_else(|e| panic!("{}: {e}", v.name));
        assert_eq!(hex(wire), hex(&v.wire), "{}: wire bytes", v.name);
        let payload = v
            .payload
            .as_ref()
            .unwrap_or_else(|| panic!("{}: no payload", v.name));
        let decoded_payload = cobs::decode_vec(&wire[..wire.len() - 1]).expect("valid COBS");
        assert_eq!(
            hex(&decoded_payload),
            hex(payload),
            "{}: payload bytes",
            v.name
        );
        // The message line must round-trip through the text form too.
        assert_eq!(
            describe(&Ok(glint_protocol::Received::Message(message))),
            text
        );
    }
}

#[test]
fn decoder_reports_what_the_spec_says_byte_by_byte_and_in_one_chunk() {
    for v in spec_vectors() {
        let mut decoder = Decoder::new();
        let by_byte: Vec<String> = v
            .wire
            .iter()
            .filter_map(|&b| decoder.push(b))
            .map(|e| describe(&e))
            .collect();
        assert_eq!(by_byte, v.decodes, "{} (byte by byte)", v.name);

        let mut decoder = Decoder::new();
        let chunked: Vec<String> = decoder.feed(&v.wire).map(|e| describe(&e)).collect();
        assert_eq!(chunked, v.decodes, "{} (one chunk)", v.name);
    }
}
