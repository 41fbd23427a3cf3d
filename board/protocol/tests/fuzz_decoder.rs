//! Property tests of the decoder against hostile input: random bytes, flipped bits, truncated
//! frames and concatenated streams fed in random chunks. This is the CI fuzz pass: bounded by
//! proptest's case count, it never panics and always resynchronises. The coverage-guided fuzz
//! target (`fuzz/fuzz_targets/decoder.rs`, nightly only, `fuzz/run.sh`) checks the same ground
//! deeper: `arbitrary_streams_accept_only_frames_that_check_out` is its property on stable Rust.

mod common;

use common::SplitMix64;
use glint_protocol::{encode, DecodeError, Decoder, Message, Received, DELIMITER, MAX_ENCODED_LEN};
use proptest::prelude::*;

fn frame(message: &Message) -> Vec<u8> {
    let mut out = [0u8; MAX_ENCODED_LEN + 1];
    encode(message, &mut out).expect("fits").to_vec()
}

fn messages(max: usize) -> impl Strategy<Value = Vec<Message>> {
    prop::collection::vec(
        any::<u64>().prop_map(|seed| SplitMix64(seed).message()),
        1..max,
    )
}

/// Feeds `bytes` in chunks of the given sizes (cycled), collecting every event.
fn feed_chunked(
    decoder: &mut Decoder,
    bytes: &[u8],
    chunk_sizes: &[usize],
) -> Vec<Result<Received, DecodeError>> {
    let mut events = Vec::new();
    let mut rest = bytes;
    for &size in chunk_sizes.iter().cycle() {
        if rest.is_empty() {
            break;
        }
        let (chunk, tail) = rest.split_at(size.clamp(1, rest.len()));
        events.extend(decoder.feed(chunk));
        rest = tail;
    }
    events
}

fn ok(message: &Message) -> Result<Received, DecodeError> {
    Ok(Received::Message(*message))
}

/// CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF, no reflection), bit by bit: written here so
/// the check does not share the decoder's table.
fn crc16_ccitt_false(bytes: &[u8]) -> u16 {
    let mut crc = 0xFFFFu16;
    for &byte in bytes {
        crc ^= u16::from(byte) << 8;
        for _ in 0..8 {
            crc = if crc & 0x8000 != 0 {
                (crc << 1) ^ 0x1021
            } else {
                crc << 1
            };
        }
    }
    crc
}

/// Whether a COBS payload (`id ‖ body ‖ CRC-16 LE`) carries a good CRC, checked independently.
fn crc_checks_out(payload: &[u8]) -> bool {
    match payload.len().checked_sub(2) {
        Some(n) if n >= 1 => {
            crc16_ccitt_false(&payload[..n]) == u16::from_le_bytes([payload[n], payload[n + 1]])
        }
        _ => false,
    }
}

/// One piece of a hostile stream.
fn piece() -> impl Strategy<Value = Vec<u8>> {
    prop_oneof![
        // Noise.
        prop::collection::vec(any::<u8>(), 0..80),
        // A real frame.
        any::<u64>().prop_map(|seed| frame(&SplitMix64(seed).message())),
        // A real frame with one bit flipped.
        (any::<u64>(), any::<prop::sample::Index>(), 0u8..8).prop_map(|(seed, at, bit)| {
            let mut f = frame(&SplitMix64(seed).message());
            let i = at.index(f.len());
            f[i] ^= 1 << bit;
            f
        }),
        // A forged frame: any id and body under a correct CRC (known ids with bodies that do
        // not parse, unknown ids), so the checks after the CRC see hostile bytes too.
        (
            prop_oneof![Just(1u8), Just(2u8), any::<u8>()],
            prop::collection::vec(any::<u8>(), 0..40)
        )
            .prop_map(|(id, body)| {
                let mut payload = vec![id];
                payload.extend(body);
                payload.extend(crc16_ccitt_false(&payload).to_le_bytes());
                let mut wire = cobs::encode_vec(&payload);
                wire.push(DELIMITER);
                wire
            }),
        Just(vec![DELIMITER]),
    ]
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

    /// The fuzz target's property on stable Rust: any stream in any chunking. One event per
    /// completed non-empty frame, nothing accepted that fails an independent CRC check, no
    /// good CRC reported as bad, and every accepted message survives re-encoding.
    #[test]
    fn arbitrary_streams_accept_only_frames_that_check_out(
        pieces in prop::collection::vec(piece(), 0..16),
        chunks in prop::collection::vec(1usize..100, 1..6),
    ) {
        let stream = pieces.concat();
        let mut decoder = Decoder::new();
        let events = feed_chunked(&mut decoder, &stream, &chunks);
        // The frames the stream completes: what lies before each delimiter, if anything.
        let mut segments: Vec<&[u8]> = stream.split(|&b| b == DELIMITER).collect();
        segments.pop(); // not ended by a delimiter (yet)
        segments.retain(|s| !s.is_empty());
        prop_assert_eq!(events.len(), segments.len());
        let mut out = [0u8; MAX_ENCODED_LEN + 1];
        for (segment, event) in segments.iter().zip(&events) {
            let payload = cobs::decode_vec(segment).ok();
            let good_crc = payload.as_deref().is_some_and(crc_checks_out);
            match event {
                Ok(received) => {
                    prop_assert!(good_crc, "accepted {:?} from {:02x?}", received, segment);
                    prop_assert!(segment.len() <= MAX_ENCODED_LEN);
                    let id = payload.as_ref().map(|p| p[0]);
                    if let Received::Message(message) = received {
                        prop_assert_eq!(id, Some(message.id()));
                        let again = encode(message, &mut out).expect("a decoded message re-encodes");
                        let back: Vec<_> = Decoder::new().feed(again).collect();
                        prop_assert_eq!(back, vec![Ok(*received)]);
                    }
                }
                Err(DecodeError::Crc) => prop_assert!(!good_crc, "good CRC refused: {:02x?}", segment),
                Err(DecodeError::Overflow) => prop_assert!(segment.len() > MAX_ENCODED_LEN),
                Err(_) => {}
            }
        }
    }

    #[test]
    fn concatenated_frames_decode_exactly_in_any_chunking(
        msgs in messages(20),
        chunks in prop::collection::vec(1usize..40, 1..8),
    ) {
        let stream: Vec<u8> = msgs.iter().flat_map(frame).collect();
        let mut decoder = Decoder::new();
        let events = feed_chunked(&mut decoder, &stream, &chunks);
        let expected: Vec<_> = msgs.iter().map(ok).collect();
        prop_assert_eq!(events, expected);
    }

    #[test]
    fn random_bytes_never_panic_and_the_next_frame_after_a_delimiter_decodes(
        garbage in prop::collection::vec(any::<u8>(), 0..300),
        seed in any::<u64>(),
        chunks in prop::collection::vec(1usize..70, 1..5),
    ) {
        let message = SplitMix64(seed).message();
        let mut stream = garbage;
        stream.push(0);
        stream.extend(frame(&message));
        let mut decoder = Decoder::new();
        let events = feed_chunked(&mut decoder, &stream, &chunks);
        prop_assert_eq!(events.last(), Some(&ok(&message)));
    }

    #[test]
    fn a_flipped_bit_costs_at_most_its_own_frame_and_the_next(
        msgs in messages(6).prop_filter("three frames", |m| m.len() >= 3),
        which in any::<prop::sample::Index>(),
        bit in 0u8..8,
    ) {
        // Corrupt one byte of the middle frame.
        let frames: Vec<Vec<u8>> = msgs.iter().map(frame).collect();
        let middle = frames.len() / 2;
        let before: usize = frames[..middle].iter().map(Vec::len).sum();
        let pos = before + which.index(frames[middle].len());
        let mut stream: Vec<u8> = frames.concat();
        let hit_delimiter = stream[pos] == 0;
        stream[pos] ^= 1 << bit;

        let mut decoder = Decoder::new();
        let events: Vec<_> = decoder.feed(&stream).collect();
        // Frames before the corrupted one are untouched.
        for (i, message) in msgs[..middle].iter().enumerate() {
            prop_assert_eq!(&events[i], &ok(message));
        }
        // Losing the delimiter merges the corrupted frame with the next one; otherwise the
        // frames after the corrupted one all decode.
        let first_intact = if hit_delimiter { middle + 2 } else { middle + 1 };
        let tail: Vec<_> = msgs[first_intact.min(msgs.len())..].iter().map(ok).collect();
        prop_assert!(events.len() >= tail.len());
        prop_assert_eq!(&events[events.len() - tail.len()..], &tail[..]);
    }

    #[test]
    fn a_cut_frame_is_dropped_and_the_stream_recovers(
        msgs in messages(4).prop_filter("three frames", |m| m.len() >= 3),
        cut in any::<prop::sample::Index>(),
        flush_first in any::<bool>(),
    ) {
        let first = frame(&msgs[0]);
        let keep = cut.index(first.len() - 1); // strictly shorter: the delimiter never arrives
        let mut stream = first[..keep].to_vec();
        if flush_first {
            // A sender reopening the port sends a lone delimiter first (SPEC.md).
            stream.push(0);
        }
        for m in &msgs[1..] {
            stream.extend(frame(m));
        }
        let mut decoder = Decoder::new();
        let events: Vec<_> = decoder.feed(&stream).collect();
        // Without the flush, the cut frame swallows the next one; everything after decodes.
        let first_intact = if flush_first || keep == 0 { 1 } else { 2 };
        let tail: Vec<_> = msgs[first_intact..].iter().map(ok).collect();
        prop_assert!(events.len() >= tail.len());
        prop_assert_eq!(&events[events.len() - tail.len()..], &tail[..]);
        // Whatever came before the intact frames was reported as an error, never a message.
        for e in &events[..events.len() - tail.len()] {
            prop_assert!(e.is_err(), "cut frame accepted: {:?}", e);
        }
    }

    #[test]
    fn small_decoders_overflow_cleanly(
        msgs in messages(10),
        garbage in prop::collection::vec(1u8..=255, 0..100),
    ) {
        // A 23-byte decoder (one robot's positions) drops longer frames (a robot-tagged
        // position, an update with its age) as overflows and keeps going.
        const CAPACITY: usize = 23;
        let mut decoder = Decoder::<CAPACITY>::with_capacity();
        let mut stream = garbage;
        stream.push(0);
        for m in &msgs {
            stream.extend(frame(m));
        }
        let events: Vec<_> = decoder.feed(&stream).collect();
        let tail: Vec<_> = msgs
            .iter()
            .map(|m| {
                let encoded_len = frame(m).iter().filter(|&&b| b != 0).count();
                if encoded_len > CAPACITY {
                    Err(DecodeError::Overflow)
                } else {
                    ok(m)
                }
            })
            .collect();
        prop_assert_eq!(&events[events.len() - tail.len()..], &tail[..]);
    }
}
