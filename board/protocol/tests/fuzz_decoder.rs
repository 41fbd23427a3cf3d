//! Property tests of the decoder against hostile input: random bytes, flipped bits, truncated
//! frames and concatenated streams fed in random chunks. This is the CI fuzz pass: bounded by
//! proptest's case count, it never panics and always resynchronises.

mod common;

use common::SplitMix64;
use glint_protocol::{encode, DecodeError, Decoder, Message, Received, MAX_ENCODED_LEN};
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

proptest! {
    #![proptest_config(ProptestConfig::with_cases(512))]

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
        // A 23-byte decoder (positions only) drops longer frames and keeps going.
        let mut decoder = Decoder::<23>::with_capacity();
        let mut stream = garbage;
        stream.push(0);
        for m in &msgs {
            stream.extend(frame(m));
        }
        let events: Vec<_> = decoder.feed(&stream).collect();
        let tail: Vec<_> = msgs.iter().map(ok).collect();
        prop_assert_eq!(&events[events.len() - tail.len()..], &tail[..]);
    }
}
