//! Encoding a position update (target: well under 1 µs), and decoding one for comparison.

use std::hint::black_box;

use criterion::{criterion_group, criterion_main, Criterion};
use glint_protocol::{encode, Decoder, Message, Position, Reading, Status, Units, MAX_ENCODED_LEN};

fn typical_position() -> Message {
    let q = Position::from_reading(
        42,
        1_234_567_890,
        Status::Found,
        230,
        Reading {
            units: Units::Floor,
            x: 1520.4,
            y: -310.2,
            vx_per_s: 250.0,
            vy_per_s: -12.5,
        },
    );
    Message::Position(q.position)
}

fn bench_encode(c: &mut Criterion) {
    let message = typical_position();
    let mut out = [0u8; MAX_ENCODED_LEN + 1];
    c.bench_function("encode_position", |b| {
        b.iter(|| encode(black_box(&message), black_box(&mut out)).map(|frame| frame.len()))
    });

    let mut frame = [0u8; MAX_ENCODED_LEN + 1];
    let len = encode(&message, &mut frame).map(|f| f.len()).unwrap_or(0);
    let mut decoder = Decoder::new();
    c.bench_function("decode_position", |b| {
        b.iter(|| decoder.feed(black_box(&frame[..len])).count())
    });
}

criterion_group!(benches, bench_encode);
criterion_main!(benches);
