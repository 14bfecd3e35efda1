//! The evaluation hot path: speeds and I-VT runs over one class's generated
//! sessions (72 x 7500 frames), and the KS test on pooled speeds.

use criterion::{black_box, criterion_group, criterion_main, Criterion};
use eyereplay_eval::{ks_2samp, IvtThresholds, MetricSamples};

/// Deterministic pseudo-random walk (xorshift), fixations and saccades mixed.
fn walk(n: usize, seed: u64) -> Vec<[f64; 2]> {
    let mut s = seed | 1;
    let mut next = move || {
        s ^= s << 13;
        s ^= s >> 7;
        s ^= s << 17;
        (s >> 11) as f64 / (1u64 << 53) as f64
    };
    let mut p = [640.0, 360.0];
    (0..n)
        .map(|_| {
            let big = next() < 0.1;
            let step = if big {
                20.0 + 40.0 * next()
            } else {
                3.0 * next()
            };
            let a = next() * std::f64::consts::TAU;
            p = [p[0] + step * a.cos(), p[1] + step * a.sin()];
            p
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let sessions: Vec<Vec<[f64; 2]>> = (0..72).map(|i| walk(7500, 1000 + i)).collect();
    let thr = IvtThresholds::default();
    c.bench_function("metrics_72_sessions_x_7500_frames", |b| {
        b.iter(|| {
            let mut m = MetricSamples::default();
            for s in &sessions {
                m.add_segment(black_box(s), &thr);
            }
            m
        })
    });
    let mut m = MetricSamples::default();
    for s in &sessions {
        m.add_segment(s, &thr);
    }
    let src = &m.speed_px_per_frame[..50_000];
    let gen = &m.speed_px_per_frame;
    c.bench_function("ks_speed_50k_vs_540k", |b| {
        b.iter(|| ks_2samp(black_box(src), black_box(gen)).unwrap())
    });
    let fa = &m.saccade_amplitude_px[..2_000];
    let fb = &m.saccade_amplitude_px[2_000..9_000];
    c.bench_function("ks_exact_2k_vs_7k", |b| {
        b.iter(|| ks_2samp(black_box(fa), black_box(fb)).unwrap())
    });
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(10);
    targets = bench
}
criterion_main!(benches);
