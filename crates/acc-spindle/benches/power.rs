//! Throughput of the Blondel power computation (`block_stats`), in sample instants per
//! second (4 channels each). Target: > 1000 × real time for 4 channels at 50 kS/s, i.e.
//! more than 5·10⁷ sample instants per second.
#![allow(missing_docs)]

use acc_core::PhaseBlock;
use acc_spindle::power::block_stats;
use criterion::{black_box, criterion_group, criterion_main, Criterion, Throughput};

fn bench_power(c: &mut Criterion) {
    // One 0.1 s period at 50 kS/s.
    let n = 5000;
    let fs = 50_000.0;
    let third = 2.0 * std::f64::consts::PI / 3.0;
    let wave = |amp: f64, shift: f64| -> Vec<f64> {
        (0..n)
            .map(|k| {
                let th = 2.0 * std::f64::consts::PI * 50.0 * k as f64 / fs;
                amp * (th + shift).cos()
            })
            .collect()
    };
    let (iu, iv) = (wave(40.0, -0.4), wave(40.0, -third - 0.4));
    let (vuw, vvw) = (wave(280.0, 0.5), wave(280.0, -third + 0.5));
    let block = PhaseBlock {
        sample_rate_hz: fs,
        i_u: &iu,
        i_v: &iv,
        v_uw: &vuw,
        v_vw: &vvw,
    };
    let mut g = c.benchmark_group("blondel_power");
    g.throughput(Throughput::Elements(n as u64));
    g.bench_function("block_stats_5000x4", |b| {
        b.iter(|| block_stats(black_box(&block)))
    });
    g.finish();
}

criterion_group!(benches, bench_power);
criterion_main!(benches);
