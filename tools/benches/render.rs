//! Render time per frame of a few presets: the accuracy tests render hundreds of frames, so
//! the renderer must stay cheap. Speed lives here, never in timed tests.

use criterion::{criterion_group, criterion_main, Criterion};
use glint_tools::scene::Scene;
use std::hint::black_box;
use std::time::Duration;

fn render_presets(c: &mut Criterion) {
    let mut group = c.benchmark_group("render");
    group
        .sample_size(10)
        .measurement_time(Duration::from_secs(2));
    for name in ["slow-line", "fast-line", "circles", "hd-720"] {
        let Some(scene) = Scene::preset(name) else {
            continue;
        };
        let mut out = vec![0u8; scene.frame_len_bytes()];
        let mut frame = 0;
        group.bench_function(name, |b| {
            b.iter(|| {
                frame = (frame + 1) % scene.frame_count();
                black_box(scene.render(frame, &mut out))
            })
        });
    }
    group.finish();
}

criterion_group!(benches, render_presets);
criterion_main!(benches);
