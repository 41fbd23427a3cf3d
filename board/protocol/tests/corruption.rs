//! Over a million corrupted frames, and how many the decoder wrongly accepts.
//!
//! What can honestly be asserted:
//! - On the payload the CRC protects (id, body, CRC), CRC-16/CCITT-FALSE has Hamming distance 4
//!   at these lengths, and any 16-bit CRC catches every burst of at most 16 bits. So every 1-, 2-
//!   and 3-bit error and every burst of ≤ 16 bits must be rejected: zero accepted, exhaustively
//!   for 1 and 2 bits, by sampling for 3 bits and bursts.
//! - On the wire, a corrupted COBS code byte or delimiter rearranges the payload into a many-bit
//!   error, which any 16-bit CRC lets through with probability about 2⁻¹⁶. For random wire
//!   corruption the test measures the false-accept rate and bounds it by twice that ideal rate.
//!
//! "Accepted" means the decoder reported a message that differs from the one sent, or reported an
//! unknown id (a CRC pass on garbage). Run with `--nocapture` to see the figures.

mod common;

use common::SplitMix64;
use glint_protocol::{encode, Decoder, Message, Received, DELIMITER, FRAME_CRC, MAX_ENCODED_LEN};

/// Frames corrupted on the wire in `random_wire_corruption_is_bounded`.
const WIRE_CORRUPTIONS: usize = 1_000_000;
/// Messages whose payloads get every single and double bit flip.
const EXHAUSTIVE_MESSAGES: usize = 24;
/// Sampled 3-bit errors and bursts on the payload.
const SAMPLED_PAYLOAD_ERRORS: usize = 200_000;
/// A CRC-16 passes a random frame with probability 2⁻¹⁶.
const CRC16_PASS_RATE: f64 = 1.0 / 65536.0;

fn frame(message: &Message) -> Vec<u8> {
    let mut out = [0u8; MAX_ENCODED_LEN + 1];
    encode(message, &mut out).expect("fits").to_vec()
}

fn payload(message: &Message) -> Vec<u8> {
    let wire = frame(message);
    cobs::decode_vec(&wire[..wire.len() - 1]).expect("valid COBS")
}

/// Re-frames a (corrupted) payload as a sender would, and counts the frames the decoder accepts
/// that are not `original`.
fn accepted_wrongly_from_payload(
    decoder: &mut Decoder,
    corrupted: &[u8],
    original: &Message,
) -> usize {
    let mut wire = cobs::encode_vec(corrupted);
    wire.push(0);
    accepted_wrongly(decoder, &wire, original)
}

fn accepted_wrongly(decoder: &mut Decoder, wire: &[u8], original: &Message) -> usize {
    decoder
        .feed(wire)
        .filter(|event| match event {
            Ok(Received::Message(m)) => m != original,
            Ok(Received::Unknown { .. }) => true,
            Err(_) => false,
        })
        .count()
}

#[test]
fn every_one_and_two_bit_payload_error_is_rejected() {
    let mut rng = SplitMix64(0x6c69_6e74_0001);
    let mut decoder = Decoder::new();
    let (mut tried, mut accepted) = (0usize, 0usize);
    for _ in 0..EXHAUSTIVE_MESSAGES {
        let message = rng.message();
        let clean = payload(&message);
        let bits = clean.len() * 8;
        let mut bad = clean.clone();
        for i in 0..bits {
            bad[i / 8] ^= 1 << (i % 8);
            accepted += accepted_wrongly_from_payload(&mut decoder, &bad, &message);
            tried += 1;
            for j in i + 1..bits {
                bad[j / 8] ^= 1 << (j % 8);
                accepted += accepted_wrongly_from_payload(&mut decoder, &bad, &message);
                bad[j / 8] ^= 1 << (j % 8);
                tried += 1;
            }
            bad[i / 8] ^= 1 << (i % 8);
        }
    }
    println!("payload 1- and 2-bit errors: {tried} tried, {accepted} accepted");
    assert!(tried > 100_000);
    assert_eq!(accepted, 0);
}

#[test]
fn sampled_three_bit_errors_and_bursts_up_to_16_bits_are_rejected() {
    let mut rng = SplitMix64(0x6c69_6e74_0002);
    let mut decoder = Decoder::new();
    let (mut accepted_triples, mut accepted_bursts) = (0usize, 0usize);
    for _ in 0..SAMPLED_PAYLOAD_ERRORS {
        let message = rng.message();
        let clean = payload(&message);
        let bits = clean.len() * 8;

        // Three distinct bits.
        let mut bad = clean.clone();
        let a = rng.below(bits);
        let b = (a + 1 + rng.below(bits - 1)) % bits;
        let mut c = rng.below(bits);
        while c == a || c == b {
            c = rng.below(bits);
        }
        for i in [a, b, c] {
            bad[i / 8] ^= 1 << (i % 8);
        }
        accepted_triples += accepted_wrongly_from_payload(&mut decoder, &bad, &message);

        // A burst: length 1..=16 bits, first and last bit flipped, any pattern between.
        let len = 1 + rng.below(16.min(bits));
        let start = rng.below(bits - len + 1);
        let middle = rng.next_u64();
        let mut bad = clean.clone();
        for k in 0..len {
            let flip = k == 0 || k == len - 1 || (middle >> k) & 1 == 1;
            if flip {
                let i = start + k;
                bad[i / 8] ^= 1 << (i % 8);
            }
        }
        accepted_bursts += accepted_wrongly_from_payload(&mut decoder, &bad, &message);
    }
    println!(
        "payload errors: {SAMPLED_PAYLOAD_ERRORS} 3-bit ({accepted_triples} accepted), \
         {SAMPLED_PAYLOAD_ERRORS} bursts ≤ 16 bits ({accepted_bursts} accepted)"
    );
    assert_eq!(accepted_triples, 0);
    assert_eq!(accepted_bursts, 0);
}

/// The kinds of damage a UART line does to a frame on the wire.
#[derive(Clone, Copy, Debug)]
enum Damage {
    OneBit,
    TwoBits,
    ByteReplaced,
    ByteBurst,
    Truncated,
    ByteDropped,
    ByteInserted,
}

const DAMAGES: [Damage; 7] = [
    Damage::OneBit,
    Damage::TwoBits,
    Damage::ByteReplaced,
    Damage::ByteBurst,
    Damage::Truncated,
    Damage::ByteDropped,
    Damage::ByteInserted,
];

fn damage(rng: &mut SplitMix64, wire: &mut Vec<u8>, kind: Damage) {
    let len = wire.len();
    match kind {
        Damage::OneBit => wire[rng.below(len)] ^= 1 << rng.below(8),
        Damage::TwoBits => {
            let a = rng.below(len * 8);
            let b = (a + 1 + rng.below(len * 8 - 1)) % (len * 8);
            wire[a / 8] ^= 1 << (a % 8);
            wire[b / 8] ^= 1 << (b % 8);
        }
        Damage::ByteReplaced => {
            let i = rng.below(len);
            wire[i] ^= 1 + rng.below(255) as u8; // always a different byte
        }
        Damage::ByteBurst => {
            let start = rng.below(len);
            for b in wire.iter_mut().skip(start).take(1 + rng.below(4)) {
                *b = rng.byte();
            }
        }
        Damage::Truncated => wire.truncate(rng.below(len)),
        Damage::ByteDropped => {
            wire.remove(rng.below(len));
        }
        Damage::ByteInserted => wire.insert(rng.below(len + 1), rng.byte()),
    }
}

#[test]
fn random_wire_corruption_is_bounded() {
    let mut rng = SplitMix64(0x6c69_6e74_0003);
    let mut decoder = Decoder::new();
    let mut accepted = [0usize; DAMAGES.len()];
    let mut crc_checked = 0usize;
    for n in 0..WIRE_CORRUPTIONS {
        let message = rng.message();
        let clean = frame(&message);
        let mut wire = clean.clone();
        let kind = n % DAMAGES.len();
        damage(&mut rng, &mut wire, DAMAGES[kind]);
        if wire == clean {
            continue; // a random byte rewritten with itself: not a corruption
        }
        // Each damaged frame ends with its own delimiter so one frame's damage is counted once
        // (an extra 0x00 is an empty frame, ignored).
        wire.push(0);
        for event in decoder.feed(&wire) {
            match event {
                Ok(Received::Message(m)) if m == message => {}
                Ok(_) => accepted[kind] += 1,
                Err(glint_protocol::DecodeError::Crc) => crc_checked += 1,
                Err(_) => {}
            }
        }
    }
    let total: usize = accepted.iter().sum();
    let rate = total as f64 / WIRE_CORRUPTIONS as f64;
    for (kind, count) in DAMAGES.iter().zip(accepted) {
        println!(
            "wire damage {kind:?}: {count} accepted of {}",
            WIRE_CORRUPTIONS / DAMAGES.len()
        );
    }
    println!(
        "wire corruption: {WIRE_CORRUPTIONS} frames, {crc_checked} reached and failed the CRC, \
         {total} wrongly accepted (rate {rate:.2e}, ideal CRC-16 rate {CRC16_PASS_RATE:.2e})"
    );
    // Twice the ideal rate: with ~15 expected at most, exceeding 30 would mean the framing
    // weakens the CRC, not bad luck (Poisson tail < 1e-4).
    assert!(
        rate <= 2.0 * CRC16_PASS_RATE,
        "false-accept rate {rate:.2e}"
    );
}

#[test]
fn random_garbage_is_rarely_accepted() {
    let mut rng = SplitMix64(0x6c69_6e74_0004);
    let mut decoder = Decoder::new();
    let mut accepted = 0usize;
    let mut crc_passed = 0usize;
    for _ in 0..WIRE_CORRUPTIONS / 4 {
        let len = 1 + rng.below(MAX_ENCODED_LEN);
        let wire: Vec<u8> = (0..len)
            .map(|_| 1 + rng.below(255) as u8)
            .chain([DELIMITER])
            .collect();
        for event in decoder.feed(&wire) {
            match event {
                Ok(Received::Message(_)) => accepted += 1,
                Ok(Received::Unknown { .. }) => crc_passed += 1,
                Err(_) => {}
            }
        }
    }
    println!(
        "random garbage: {} frames, {accepted} accepted as messages, {crc_passed} as unknown ids",
        WIRE_CORRUPTIONS / 4
    );
    assert!(
        (accepted + crc_passed) as f64 <= 2.0 * CRC16_PASS_RATE * (WIRE_CORRUPTIONS / 4) as f64
    );
}

#[test]
fn random_payloads_in_valid_frames_pass_the_crc_at_the_ideal_rate() {
    // Valid COBS around random bytes: every frame reaches the CRC, which is the only guard left.
    let mut rng = SplitMix64(0x6c69_6e74_0005);
    let mut decoder = Decoder::new();
    let (mut crc_passed, mut accepted) = (0usize, 0usize);
    for _ in 0..WIRE_CORRUPTIONS {
        let len = 3 + rng.below(20);
        let random: Vec<u8> = (0..len).map(|_| rng.byte()).collect();
        let wire = [cobs::encode_vec(&random), vec![DELIMITER]].concat();
        for event in decoder.feed(&wire) {
            match event {
                Ok(Received::Message(_)) => {
                    crc_passed += 1;
                    accepted += 1;
                }
                Ok(Received::Unknown { .. })
                | Err(glint_protocol::DecodeError::Malformed { .. }) => crc_passed += 1,
                Err(_) => {}
            }
        }
    }
    let rate = crc_passed as f64 / WIRE_CORRUPTIONS as f64;
    println!(
        "random payloads: {WIRE_CORRUPTIONS} frames, {crc_passed} passed the CRC (rate {rate:.2e}), \
         {accepted} of those parsed as a known message"
    );
    // The CRC really is doing the work: it passes some (so this test can see it), about 1/65536.
    assert!(crc_passed > 0);
    assert!(rate <= 2.0 * CRC16_PASS_RATE, "CRC pass rate {rate:.2e}");
}

#[test]
fn crc_check_value_is_the_catalogued_one() {
    assert_eq!(FRAME_CRC.checksum(b"123456789"), 0x29B1);
}
