//! Coverage-guided fuzzing of the stream decoder: arbitrary bytes, fed in the chunk sizes the
//! first input byte chooses. It must never panic, and anything it accepts must re-encode to the
//! exact bytes it came from (so a decoded message is one the encoder could have sent).
#![no_main]

use glint_protocol::{encode, Decoder, Received, MAX_ENCODED_LEN};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Some((&chunk, stream)) = data.split_first() else { return };
    let chunk = usize::from(chunk).max(1);
    let mut decoder = Decoder::new();
    let mut out = [0u8; MAX_ENCODED_LEN + 1];
    for piece in stream.chunks(chunk) {
        for event in decoder.feed(piece) {
            if let Ok(Received::Message(message)) = event {
                // Re-encoding must succeed; a decoded message always fits a frame.
                let frame = encode(&message, &mut out).expect("decoded message re-encodes");
                let mut again = Decoder::new();
                let back: Vec<_> = again.feed(frame).collect();
                assert_eq!(back, [Ok(Received::Message(message))]);
            }
        }
    }
});
